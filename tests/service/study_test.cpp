// Study expansion: grids, zips and ranges give the expected points; the reference is found;
// every run's scene is validated and a bad path or value names the parameter and the point;
// over-large studies are refused before anything is queued.
#include "studies/study.h"
#include "executors/slurm_executor.h"
#include "studies/results.h"

#include <gtest/gtest.h>

#include <cmath>

namespace millsim {
namespace {

using nlohmann::json;

json base_scene() {
  return json::parse(R"({
    "domain": {"min_m": [0,0,0], "max_m": [1e-3,1e-3,1e-3]},
    "materials": [{"name": "m", "youngs_modulus_pa": 1e9, "poisson_ratio": 0.3,
                   "density_kg_per_m3": 2000, "restitution": 0.5}],
    "sources": [{"type": "list", "material": "m",
                 "particles": [{"position_m": [5e-4,5e-4,5e-4], "diameter_m": 1e-4}]}],
    "seed": 10,
    "time": {"end_s": 1e-5}
  })");
}

json study_with(json parameters) {
  json s = {{"name", "t"}, {"scene", base_scene()}, {"parameters", parameters}};
  return s;
}

std::vector<InputError> errors_of(const json& spec, int max_runs = 1000) {
  try {
    expand_study(spec, ".", max_runs);
  } catch (const InputErrorList& e) {
    return e.errors();
  }
  return {};
}

TEST(Study, GridZipAndRangesExpandAsDeclared) {
  json spec = study_with(
      {{{"path", "search.subcells"}, {"values", {1, 2, 3}}},
       {{"path", "time.safety_factor"}, {"range", {{"from", 0.1}, {"to", 0.4}, {"count", 4}}}}});
  Study grid = expand_study(spec, ".", 1000);
  ASSERT_EQ(grid.runs.size(), 12u);
  // Last parameter fastest; values applied to the scene.
  EXPECT_EQ(grid.runs[5].params["search.subcells"], 2);
  EXPECT_NEAR(grid.runs[5].params["time.safety_factor"].get<double>(), 0.2, 1e-15);
  EXPECT_EQ(grid.runs[5].scene["search"]["subcells"], 2);  // created: the base has no "search"
  EXPECT_NEAR(grid.runs[5].scene["time"]["safety_factor"].get<double>(), 0.2, 1e-15);

  spec["parameters"][1]["range"] = {{"from", 0.1}, {"to", 0.3}, {"count", 3}};
  spec["combine"] = "zip";
  EXPECT_EQ(expand_study(spec, ".", 1000).runs.size(), 3u);

  json log =
      study_with({{{"path", "/contact/max_impact_speed_m_per_s"},
                   {"range", {{"from", 1}, {"to", 100}, {"count", 3}, {"spacing", "log"}}}}});
  const Study logs = expand_study(log, ".", 1000);
  ASSERT_EQ(logs.runs.size(), 3u);
  EXPECT_NEAR(logs.runs[1].scene["contact"]["max_impact_speed_m_per_s"].get<double>(), 10.0, 1e-12);
}

TEST(Study, RepeatsGetSuccessiveSeedsAndTheReferenceIsFound) {
  json spec = study_with({{{"path", "time.safety_factor"}, {"values", {0.1, 0.2}}}});
  spec["repeats"] = 3;
  spec["reference"] = {{"time.safety_factor", 0.1}};
  const Study s = expand_study(spec, ".", 1000);
  ASSERT_EQ(s.runs.size(), 6u);
  EXPECT_EQ(s.runs[0].seed, 10u);
  EXPECT_EQ(s.runs[2].seed, 12u);
  EXPECT_EQ(s.runs[2].scene["seed"], 12);
  ASSERT_TRUE(s.reference_index.has_value());
  EXPECT_EQ(*s.reference_index, 0);
  EXPECT_TRUE(s.runs[0].is_reference);
  EXPECT_FALSE(s.runs[1].is_reference);
}

// reference_set: overrides for the reference run alone (the quick start's run.h5), checked like
// `set`, refused without a reference to apply to.
TEST(Study, ReferenceSetChangesTheReferenceRunAlone) {
  json spec = study_with({{{"path", "time.safety_factor"}, {"values", {0.1, 0.2}}}});
  spec["repeats"] = 2;
  spec["reference"] = {{"time.safety_factor", 0.2}};
  spec["reference_set"] = {{"output.h5", true}};
  spec["set"] = {{"output.h5", false}};
  const Study s = expand_study(spec, ".", 1000);
  ASSERT_EQ(s.runs.size(), 4u);
  ASSERT_TRUE(s.reference_index.has_value());
  for (const StudyRun& run : s.runs)
    EXPECT_EQ(run.scene["output"]["h5"], run.index == *s.reference_index) << run.index;

  json unknown = spec;
  unknown["reference_set"] = {{"output.h55", true}};
  std::vector<InputError> errors = errors_of(unknown);
  ASSERT_FALSE(errors.empty());
  EXPECT_NE(errors[0].path.find("/output/h55"), std::string::npos) << errors[0].path;

  json orphan = spec;
  orphan.erase("reference");
  errors = errors_of(orphan);
  ASSERT_FALSE(errors.empty());
  EXPECT_EQ(errors[0].path, "/reference_set");
}

TEST(Study, BadInputNamesTheParameterAndThePoint) {
  // A value the scene rejects: the run, its point and the scene's own message.
  auto errors = errors_of(study_with({{{"path", "time.safety_factor"}, {"values", {0.2, 5.0}}}}));
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_EQ(errors[0].path, "run 1 (time.safety_factor = 5.0) /time/safety_factor");
  EXPECT_NE(errors[0].allowed.find("(0, 1]"), std::string::npos);

  // A key the scene does not know.
  errors = errors_of(study_with({{{"path", "time.saftey_factor"}, {"values", {0.2}}}}));
  ASSERT_FALSE(errors.empty());
  EXPECT_NE(errors[0].allowed.find("did you mean \"safety_factor\""), std::string::npos);

  // An index past an array.
  errors = errors_of(study_with({{{"path", "materials.3.restitution"}, {"values", {0.5}}}}));
  ASSERT_FALSE(errors.empty());
  EXPECT_NE(errors[0].allowed.find("1-element array"), std::string::npos);

  // Reference matching no point; a bad metric; no values.
  json spec = study_with({{{"path", "time.safety_factor"}, {"values", {0.1}}}});
  spec["reference"] = {{"time.safety_factor", 0.3}};
  errors = errors_of(spec);
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_EQ(errors[0].path, "/reference");
  // Every problem at once: the study's own field and its runs' scene problems together, a base
  // scene's problem once (not once per run).
  spec["error"] = "rmse";
  spec["parameters"][0]["values"] = {0.1, 0.2, 5.0};
  spec["set"] = {{"materials.0.restitution", 2.0}};
  errors = errors_of(spec);
  std::vector<std::string> paths;
  for (const InputError& e : errors) paths.push_back(e.path);
  EXPECT_EQ(paths, (std::vector<std::string>{
                       "/error", "run 0 (time.safety_factor = 0.1) /materials/0/restitution",
                       "run 2 (time.safety_factor = 5.0) /time/safety_factor", "/reference",
                       "(other runs)"}));
  EXPECT_EQ(errors.back().allowed, "2 more problems repeat the ones above");
  errors = errors_of(study_with({{{"path", "seed"}}}));
  ASSERT_FALSE(errors.empty());
  EXPECT_EQ(errors[0].path, "/parameters/0");
}

TEST(Study, ASourceTypeThatIsNotAStringIsAProblemOfTheScene) {
  // Found in issue 33's study fuzz: a number as sources[0].type threw nlohmann's type_error
  // (exit 1, HTTP 500) from the path handling before the scene was validated.
  json spec = study_with({{{"path", "time.safety_factor"}, {"values", {0.2}}}});
  spec["scene"]["sources"][0]["type"] = 3;
  const auto errors = errors_of(spec);
  ASSERT_FALSE(errors.empty());
  EXPECT_NE(errors[0].path.find("/sources/0/type"), std::string::npos) << errors[0].path;
}

TEST(Study, AScenePathTooLongForTheSystemIsAMissingScene) {
  // Found by fuzz/fuzz_study.cpp: a 5,000-character scene path made the file check throw
  // std::filesystem::filesystem_error (ENAMETOOLONG) out of the parser.
  json spec = {{"name", "long"}, {"scene", std::string(5000, 'a') + ".json"}};
  const auto errors = errors_of(spec);
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_EQ(errors[0].path, "/scene");
  EXPECT_NE(errors[0].allowed.find("no such scene file"), std::string::npos);
}

TEST(Study, OverLargeStudiesAreRefused) {
  const json spec = study_with(
      {{{"path", "seed"}, {"range", {{"from", 1}, {"to", 40}, {"step", 1}}}},
       {{"path", "time.safety_factor"}, {"range", {{"from", 0.1}, {"to", 0.5}, {"count", 30}}}}});
  const auto errors = errors_of(spec, 1000);
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_NE(errors[0].allowed.find("expands to 1200 runs"), std::string::npos);
  EXPECT_EQ(expand_study(spec, ".", 2000).runs.size(), 1200u);
}

TEST(Study, ARepeatedParameterIsOneProblemPerRepeatAndNothingIsExpanded) {
  // Issue 33: each parameter was compared with every earlier one and each match reported, so n
  // identical parameters made n(n-1)/2 problems (4,000 of them: 8 million, 1.7 GB, a minute).
  const std::size_t n = 2000;
  json parameters = json::array();
  for (std::size_t k = 0; k < n; ++k)
    parameters.push_back({{"path", "time.safety_factor"}, {"values", {0.2}}});
  const auto errors = errors_of(study_with(parameters));
  ASSERT_EQ(errors.size(), n - 1);  // the second to the last, each once
  EXPECT_EQ(errors[0].path, "/parameters/1/path");
  EXPECT_EQ(errors.back().path, "/parameters/1999/path");
  EXPECT_EQ(errors.back().allowed, "each parameter once");
}

TEST(Study, ProblemsOfARunWithThousandsOfParametersStayShort) {
  // Every problem of a run named the whole point: 2,000 unknown parameters made 2,000 problems
  // of 40 kB each. The point is cut at about 200 characters.
  json parameters = json::array();
  for (int k = 0; k < 2000; ++k)
    parameters.push_back({{"path", "unknown_" + std::to_string(k)}, {"values", {k}}});
  const auto errors = errors_of(study_with(parameters));
  ASSERT_GE(errors.size(), 2000u);  // each unknown key once
  for (const InputError& e : errors) EXPECT_LT(e.path.size(), 400u) << e.path.substr(0, 400);
  EXPECT_EQ(errors[0].path.rfind("run 0 (unknown_0 = 0, unknown_1 = 1", 0), 0u) << errors[0].path;
  EXPECT_NE(errors[0].path.find(", ...)"), std::string::npos);
}

TEST(Study, TheStoredSizeIsBoundedBeforeTheRunsAreExpanded) {
  // A large inline scene times many runs: refused from its base scene and the run count alone
  // when even the smallest run times the count is over the limit, before a run is made.
  json scene = base_scene();
  json many = json::array();
  for (int k = 0; k < 2000; ++k)
    many.push_back({{"position_m", {5e-4, 5e-4, 5e-4}}, {"diameter_m", 1e-5}});
  scene["sources"][0]["particles"] = many;  // about 110 kB as text
  json spec = {
      {"name", "big"},
      {"scene", scene},
      {"parameters", {{{"path", "seed"}, {"range", {{"from", 1}, {"to", 50}, {"step", 1}}}}}}};
  const std::size_t scene_bytes = scene.dump().size();
  const std::size_t limit = 40 * scene_bytes + scene_bytes / 2;  // 40.5 runs' worth
  try {
    expand_study(spec, ".", 1000, nullptr, limit);
    FAIL() << "50 runs of " << scene_bytes << " bytes passed a limit of 40 runs' worth";
  } catch (const StudyTooLarge& e) {
    EXPECT_NE(std::string(e.what()).find("at least"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("(50 runs)"), std::string::npos) << e.what();
  }
  // A parameter that replaces the bulk makes runs small: the bound cannot refuse it beforehand,
  // and the runs as made fit.
  spec["parameters"].push_back(
      {{"path", "sources.0.particles"},
       {"values", {json::array({{{"position_m", {5e-4, 5e-4, 5e-4}}, {"diameter_m", 1e-4}}})}}});
  EXPECT_EQ(expand_study(spec, ".", 1000, nullptr, limit).runs.size(), 50u);
  // Runs that grow past the limit as they are made stop at the run that crosses it.
  spec["parameters"][1]["values"] = json::array({many});  // one value: the whole list
  spec["scene"]["sources"][0]["particles"] =
      json::array({{{"position_m", {5e-4, 5e-4, 5e-4}}, {"diameter_m", 1e-4}}});
  try {
    expand_study(spec, ".", 1000, nullptr, limit);
    FAIL() << "50 runs of " << scene_bytes << " bytes passed a limit of 40 runs' worth";
  } catch (const StudyTooLarge& e) {
    EXPECT_NE(std::string(e.what()).find("after 41 of its 50 runs"), std::string::npos) << e.what();
  }
}

TEST(Study, ParameterPathsSplitOnDotsOrSlashes) {
  EXPECT_EQ(parameter_keys("dust.threshold_diameter_m"),
            (std::vector<std::string>{"dust", "threshold_diameter_m"}));
  EXPECT_EQ(parameter_keys("/materials/0/restitution"),
            (std::vector<std::string>{"materials", "0", "restitution"}));
}

}  // namespace
}  // namespace millsim

namespace millsim {
namespace {

TEST(StudyError, TotalPsdDistancesCompareEverythingTheRunsMade) {
  // Two runs on classes [1, 10, 100] µm: the product alone differs (all of one run's product is
  // fine, none of the other's), but counting the hold-up both made 30 % of their mass below
  // 10 µm: the total distances are 0 where the product's KS is 1.
  auto result = [](double product_fine_share, double total_fine_share) {
    nlohmann::json r;
    r["outlet_psd"] = {{"edges_m", {1e-6, 1e-5, 1e-4}},
                       {"cumulative_mass", {0.0, product_fine_share, 1.0}},
                       {"d50_m", 1e-5},
                       {"total_mass_kg", 1e-9}};
    r["total_psd"] = {{"cumulative_mass", {0.0, total_fine_share, 1.0}},
                      {"d50_m", 2e-5},
                      {"total_mass_kg", 1e-6}};
    return r;
  };
  const nlohmann::json a = result(1.0, 0.3), b = result(0.0, 0.3), c = result(0.0, 0.8);
  EXPECT_DOUBLE_EQ(*error_against(a, b, "psd_ks"), 1.0);
  EXPECT_DOUBLE_EQ(*error_against(a, b, "total_psd_ks"), 0.0);
  EXPECT_DOUBLE_EQ(*error_against(a, c, "total_psd_ks"), 0.5);
  // L1: the gap 0.5 spans one of the two decades: mean 0.25.
  EXPECT_DOUBLE_EQ(*error_against(a, c, "total_psd_l1"), 0.25);
  nlohmann::json no_total = a;
  no_total.erase("total_psd");
  EXPECT_FALSE(error_against(no_total, c, "total_psd_ks").has_value());
}

// A study's `slurm` key: its options are kept for the runs' batch jobs, each one shell-quoted
// on the sbatch line; anything that could be more than one word there is refused by its path.
TEST(Study, SlurmOptionsAreCheckedAndQuoted) {
  json spec = {{"scene", base_scene()},
               {"slurm",
                {{"partition", "short"},
                 {"account", "lab-42"},
                 {"qos", "normal"},
                 {"sbatch_args", {"--constraint=avx2", "--exclusive"}}}}};
  const Study study = expand_study(spec, ".", 10);
  EXPECT_EQ(study.slurm.partition, "short");
  EXPECT_EQ(study.slurm.sbatch_args.size(), 2u);
  EXPECT_EQ(study_options(study.slurm),
            " --partition='short' --account='lab-42' --qos='normal' '--constraint=avx2' "
            "'--exclusive'");
  EXPECT_EQ(SlurmOptions::from_json(study.slurm.to_json()).to_json(), study.slurm.to_json());

  spec["slurm"] = {{"partition", "a b"},
                   {"account", "x;rm -rf /"},
                   {"sbatch_args", {"constraint", "--x=$(id)", 3}},
                   {"queue", "q"}};
  std::vector<std::string> paths;
  try {
    expand_study(spec, ".", 10);
  } catch (const InputErrorList& e) {
    for (const InputError& err : e.errors()) paths.push_back(err.path);
  }
  EXPECT_EQ(paths, (std::vector<std::string>{"/slurm/partition", "/slurm/account",
                                             "/slurm/sbatch_args/0", "/slurm/sbatch_args/1",
                                             "/slurm/sbatch_args/2", "/slurm/queue"}));
}

// limits.threads_per_run: a whole number in [1, 1024], 1 when not given; a machine refuses a
// study whose runs, one per local worker, would start more threads than its cores.
TEST(Study, ThreadsPerRunIsCheckedAndMustFitTheCores) {
  json spec = study_with({{{"path", "seed"}, {"values", {1, 2}}}});
  EXPECT_EQ(expand_study(spec, ".", 1000).limits.threads_per_run, 1);
  spec["limits"] = {{"threads_per_run", 3}};
  EXPECT_EQ(expand_study(spec, ".", 1000).limits.threads_per_run, 3);
  for (const json& bad : {json(0), json(-2), json(1025), json(1.5), json("2")}) {
    spec["limits"] = {{"threads_per_run", bad}};
    const std::vector<InputError> errors = errors_of(spec);
    ASSERT_EQ(errors.size(), 1u) << bad;
    EXPECT_EQ(errors[0].path, "/limits/threads_per_run");
  }
  EXPECT_FALSE(thread_budget_problem(1, 2, 2));   // one thread per worker on each core
  EXPECT_FALSE(thread_budget_problem(2, 4, 8));   // 8 threads on 8 cores
  EXPECT_FALSE(thread_budget_problem(16, 0, 2));  // no local worker: the cluster's cores
  const std::optional<InputError> over = thread_budget_problem(3, 2, 4);  // 6 threads on 4
  ASSERT_TRUE(over);
  EXPECT_EQ(over->path, "/limits/threads_per_run");
  EXPECT_EQ(over->value, "3");
  EXPECT_NE(over->allowed.find("at most 2"), std::string::npos) << over->allowed;
  EXPECT_NE(over->allowed.find("6 threads on the 4 core(s)"), std::string::npos) << over->allowed;
}

}  // namespace
}  // namespace millsim
