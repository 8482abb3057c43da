// The study plots as files a person opens: a study of three runs with known PSDs (a reference
// among them) gives an error-against-time plot and a PSD plot that rsvg-convert renders, with
// one curve per run, the reference named, a log size axis and no "-0" tick.
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>

#include "queue/store.h"
#include "studies/results.h"
#include "support/process.h"
#include "support/scenes.h"

namespace millsim {
namespace {

using nlohmann::json;

// A result.json with an outlet PSD on three classes (1, 10, 100 µm edges) whose cumulative mass
// is `fine` at 10 µm, and a run time.
std::string result_with_psd(double fine, double wall_s) {
  return json{{"particle_steps_per_second", 1e6},
              {"wall_time_s", wall_s},
              {"outlet_psd",
               {{"edges_m", {1e-6, 1e-5, 1e-4}},
                {"cumulative_mass", {0.0, fine, 1.0}},
                {"d10_m", 2e-6},
                {"d50_m", 1e-5},
                {"d90_m", 8e-5},
                {"total_mass_kg", 1e-6}}}}
      .dump();
}

std::size_t count(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (std::size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

// A psd_ks study of `runs` dust thresholds (8e-5 / (k + 1) m), the last the reference,
// submitted to `store`; returns its id.
std::string threshold_study(Store& store, const std::filesystem::path& dir, const char* name,
                            int runs) {
  Study study;
  study.name = name;
  study.spec = json::object();
  study.error_metric = "psd_ks";
  for (int k = 0; k < runs; ++k) {
    StudyRun r;
    r.index = k;
    r.params = {{"dust.threshold_diameter_m", 8e-5 / (k + 1)}};
    r.scene = json::object();
    r.is_reference = k == runs - 1;
    study.runs.push_back(r);
  }
  study.reference_index = runs - 1;
  return store.submit(study, std::nullopt, dir, 1.0).study_id;
}

// Claims the study's next run and finishes it complete with `result`.
void complete_next(Store& store, const std::string& id, double wall_s, const std::string& result) {
  const std::optional<Claim> c = store.claim("w", 60, 2.0, id);
  ASSERT_TRUE(c);
  FinishReport done;
  done.state = RunState::Complete;
  done.wall_time_s = wall_s;
  done.result = result;
  ASSERT_TRUE(store.finish(c->run.id, c->token, done, 3.0));
}

TEST(StudyPlots, RenderWithOneCurvePerRunAndTheReferenceMarked) {
  test::TempDir dir;
  Store store(dir.path() / "q.db");
  const std::string id = threshold_study(store, dir.path(), "plots", 3);
  for (int k = 0; k < 3; ++k)
    complete_next(store, id, 10.0 * (k + 1), result_with_psd(0.2 + 0.3 * k, 10.0 * (k + 1)));
  const std::string psd = psd_svg(store, id);
  const std::string errors = error_vs_time_svg(results_table(store, id));
  EXPECT_EQ(count(psd, "<polyline"), 3u);
  EXPECT_NE(psd.find("r2 threshold_diameter_m=2.666666666666667e-05 (reference)"),
            std::string::npos);
  EXPECT_NE(psd.find("particle size (um, log scale)"), std::string::npos);
  EXPECT_NE(psd.find("stroke=\"#d62728\""), std::string::npos) << "the reference in red";
  EXPECT_NE(errors.find("error (psd_ks)"), std::string::npos);
  // The KS distance of r0 and r1 from the reference: |0.2 - 0.8| and |0.5 - 0.8| at 10 µm.
  const json table = results_table(store, id);
  EXPECT_NEAR(table["runs"][0]["error"].get<double>(), 0.6, 1e-12);
  EXPECT_NEAR(table["runs"][1]["error"].get<double>(), 0.3, 1e-12);
  for (const std::string* svg : {&psd, &errors})
    EXPECT_EQ(svg->find(">-0<"), std::string::npos) << "a tick labelled -0";

  if (std::system("command -v rsvg-convert >/dev/null 2>&1") != 0)
    GTEST_SKIP() << "rsvg-convert is not installed (Debian librsvg2-bin)";
  for (const auto& [name, svg] :
       {std::pair<std::string, std::string>{"psd", psd}, {"err", errors}}) {
    test::write_file(dir.path() / (name + ".svg"), svg);
    const test::CommandResult r =
        test::run_shell("rsvg-convert -o " + (dir.path() / (name + ".png")).string() + " " +
                        (dir.path() / (name + ".svg")).string());
    EXPECT_EQ(r.exit_code, 0) << name << ": " << r.out;
    EXPECT_EQ(r.out, "") << name;
    EXPECT_GT(std::filesystem::file_size(dir.path() / (name + ".png")), 1000u) << name;
  }
}

// A run whose product is still empty (null sizes in its result.json): its row has no sizes and
// no error, shown as "-", and the other runs' rows are unaffected.
TEST(StudyPlots, AnEmptyProductHasNoSizesAndNoErrorInTheTable) {
  test::TempDir dir;
  Store store(dir.path() / "q.db");
  const std::string id = threshold_study(store, dir.path(), "empty", 2);
  for (int k = 0; k < 2; ++k) {
    json result = json::parse(result_with_psd(0.5, 10.0));
    if (k == 0) {
      result["outlet_psd"]["total_mass_kg"] = 0.0;
      result["outlet_psd"]["cumulative_mass"] = {0.0, 0.0, 0.0};
      for (const char* d : {"d10_m", "d50_m", "d90_m"}) result["outlet_psd"][d] = nullptr;
    }
    complete_next(store, id, 10.0, result.dump());
  }
  const nlohmann::ordered_json table = results_table(store, id);
  ASSERT_EQ(table["runs"].size(), 2u);
  EXPECT_TRUE(table["runs"][0]["d50_m"].is_null());
  EXPECT_TRUE(table["runs"][0]["error"].is_null());
  EXPECT_EQ(table["runs"][1]["d50_m"], 1e-5);
  const std::string text = results_text(table);
  const std::size_t row = text.find(table["runs"][0]["run"].get<std::string>());
  ASSERT_NE(row, std::string::npos);
  const std::string line = text.substr(row, text.find('\n', row) - row);
  EXPECT_EQ(line.find(" 0.0 "), std::string::npos) << line;
  EXPECT_EQ(count(line, " -"), 4u) << "d10, d50, d90 and error: " << line;
}

}  // namespace
}  // namespace millsim
