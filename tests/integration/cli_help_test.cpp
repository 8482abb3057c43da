// The command line by convention: every verb answers --help and `millsim help VERB` with its
// usage, every option it accepts and an example; a missing argument prints the usage and exits
// 2; the man page is valid roff (groff finds no problem) and names every verb.
#include <gtest/gtest.h>

#include <fstream>
#include <regex>
#include <set>

#include "studies/study.h"
#include "support/process.h"
#include "support/scenes.h"

namespace millsim {
namespace {

const char* const kVerbs[] = {"run",    "study",  "regress", "serve", "worker",
                              "submit", "status", "results", "psd",   "cancel"};

TEST(CliHelp, EveryVerbHasHelpListingTheOptionsItAccepts) {
  test::TempDir dir;
  for (const char* verb : kVerbs) {
    const test::CommandResult a = test::run_millsim(std::string(verb) + " --help", dir.path());
    EXPECT_EQ(a.exit_code, 0) << verb << a.err;
    EXPECT_EQ(a.out.rfind(std::string("usage: millsim ") + verb, 0), 0u) << a.out;
    const std::size_t example = a.out.find("example:\n");
    ASSERT_NE(example, std::string::npos) << a.out;
    EXPECT_NE(a.out.find("millsim " + std::string(verb), example), std::string::npos) << a.out;
    EXPECT_NE(a.out.find("exit codes:"), std::string::npos);
    const test::CommandResult b = test::run_millsim(std::string("help ") + verb, dir.path());
    EXPECT_EQ(b.out, a.out) << verb;
    // Every option the help lists is one the verb accepts: given alone with a dummy value, it
    // never gets "unknown option".
    const std::regex option("\n  (--[a-z-]+)");
    for (std::sregex_iterator it(a.out.begin(), a.out.end(), option), end; it != end; ++it) {
      const std::string flag = (*it)[1];
      if (flag == "--help") continue;
      const test::CommandResult c = test::run_millsim(
          std::string(verb) + " " + flag + " 1 --server http://127.0.0.1:9 --db x.db", dir.path());
      EXPECT_EQ(c.err.find("unknown option \"" + flag), std::string::npos)
          << verb << " " << flag << ": " << c.err;
    }
  }
  EXPECT_EQ(test::run_millsim("help frobnicate", dir.path()).exit_code, 2);
  const test::CommandResult overview = test::run_millsim("--help", dir.path());
  for (const char* verb : kVerbs)
    EXPECT_NE(overview.out.find(std::string("\n  ") + verb + " "), std::string::npos) << verb;
}

TEST(CliHelp, AMissingArgumentPrintsTheUsage) {
  test::TempDir dir;
  for (const char* verb : {"results", "psd", "cancel", "submit", "run", "study", "regress"}) {
    const bool client = std::string(verb) != "run" && std::string(verb) != "study";
    const test::CommandResult r = test::run_millsim(
        std::string(verb) + (client ? " --server http://127.0.0.1:9" : ""), dir.path());
    EXPECT_EQ(r.exit_code, 2) << verb;
    EXPECT_NE(r.err.find(std::string("usage: millsim ") + verb), std::string::npos)
        << verb << ": " << r.err;
  }
}

TEST(CliHelp, HelpOnHelpAndAStudyWithoutLocalPointTheWay) {
  // Issue 32, item 8: `help --help` exited 2, `study` without --local said the server "comes
  // next" although `serve` and `submit` exist, and `run --out` without a value was an unknown
  // option.
  test::TempDir dir;
  for (const char* args : {"help --help", "help -h"}) {
    const test::CommandResult r = test::run_millsim(args, dir.path());
    EXPECT_EQ(r.exit_code, 0) << args << ": " << r.err;
    EXPECT_NE(r.out.find("help"), std::string::npos) << args << ": " << r.out;
  }
  const test::CommandResult study = test::run_millsim(
      "study " MILLSIM_SOURCE_DIR "/cases/spiral_jet_mill_quick_scan.study.json", dir.path());
  EXPECT_EQ(study.exit_code, 2);
  EXPECT_NE(study.err.find("millsim submit"), std::string::npos) << study.err;
  EXPECT_EQ(study.err.find("come next"), std::string::npos) << study.err;
  // `run --out` at the end of the line said "unknown option".
  const test::CommandResult run = test::run_millsim(
      "run " MILLSIM_SOURCE_DIR "/cases/impact_two_spheres.json --out", dir.path());
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find("--out needs a value"), std::string::npos) << run.err;
}

// `study --help` is true to what a study does: every file a local study writes beside its run
// directories (results.json, results.csv, error_vs_time.svg, psd.svg) is named, and so is the
// study file's `slurm` key with every field the study parser accepts in it (and no other).
TEST(CliHelp, StudyHelpNamesEveryFileItWritesAndTheSlurmKey) {
  test::TempDir dir;
  const test::CommandResult help = test::run_millsim("study --help", dir.path());
  ASSERT_EQ(help.exit_code, 0) << help.err;

  // Two short attrition runs, fed just above the outlet plane so that particles leave within
  // the run: an outlet PSD each, and a reference run.
  std::ifstream in(MILLSIM_SOURCE_DIR "/cases/attrition_target.json");
  nlohmann::json scene = nlohmann::json::parse(in);
  scene["feeds"][0]["region"] = {{"min_m", {0.0002, 0, 0.0002}}, {"max_m", {0.001, 0.002, 0.0006}}};
  scene["feeds"][0]["velocity_m_per_s"] = {0, 0, -8};
  const nlohmann::json study = {
      {"name", "attrition"},
      {"scene", scene},
      {"set", {{"time.end_s", 1.5e-4}, {"output.h5", false}}},
      {"parameters", {{{"path", "dust.threshold_diameter_m"}, {"values", {1e-4, 8e-5}}}}},
      {"reference", {{"dust.threshold_diameter_m", 8e-5}}}};
  test::write_file(dir.path() / "study.json", study.dump());
  const test::CommandResult r = test::run_millsim(
      "study study.json --local --db q.db --out runs --workers 2 --format json", dir.path());
  ASSERT_EQ(r.exit_code, 0) << r.err << r.out;
  const std::string study_id = nlohmann::json::parse(r.out)["study"];
  std::set<std::string> written;
  for (const auto& entry : std::filesystem::directory_iterator(dir.path() / "runs" / study_id))
    if (entry.is_regular_file()) written.insert(entry.path().filename().string());
  EXPECT_TRUE(written.count("psd.svg")) << "the runs have outlet PSDs";
  for (const std::string& file : written)
    EXPECT_NE(help.out.find(file), std::string::npos) << file << " is not in:\n" << help.out;

  // The slurm key: the fields the help names are accepted, and an unnamed one is refused.
  EXPECT_NE(help.out.find("\"slurm\""), std::string::npos) << help.out;
  nlohmann::json slurm = nlohmann::json::object();
  for (const char* field : {"partition", "account", "qos", "sbatch_args"}) {
    EXPECT_NE(help.out.find(field), std::string::npos) << field << " is not in:\n" << help.out;
    slurm[field] = std::string(field) == "sbatch_args" ? nlohmann::json::array({"--time=240"})
                                                       : nlohmann::json("short");
  }
  SlurmOptions options;
  InputErrors errors;
  parse_slurm(slurm, options, errors);
  EXPECT_TRUE(errors.empty()) << errors.front().path;
  parse_slurm({{"nodes", 2}}, options, errors);
  EXPECT_FALSE(errors.empty()) << "the parser takes a field the help does not name";
}

TEST(CliHelp, TheManPageIsValidRoffNamingEveryVerb) {
  test::TempDir dir;
  const test::CommandResult r = test::run_millsim("help --man", dir.path());
  ASSERT_EQ(r.exit_code, 0);
  EXPECT_EQ(r.out.rfind(".TH MILLSIM 1", 0), 0u);
  for (const char* verb : kVerbs)
    EXPECT_NE(r.out.find(std::string(".SS ") + verb + "\n"), std::string::npos) << verb;
  EXPECT_NE(r.out.find(".SH EXIT STATUS"), std::string::npos);
  if (std::system("command -v groff >/dev/null 2>&1") != 0)
    GTEST_SKIP() << "groff is not installed";
  test::write_file(dir.path() / "millsim.1", r.out);
  const std::string check = "groff -man -ww -z " + (dir.path() / "millsim.1").string() + " 2>" +
                            (dir.path() / "groff.err").string();
  EXPECT_EQ(std::system(check.c_str()), 0);
  std::ifstream err(dir.path() / "groff.err");
  const std::string warnings((std::istreambuf_iterator<char>(err)),
                             std::istreambuf_iterator<char>());
  EXPECT_EQ(warnings, "");
}

}  // namespace
}  // namespace millsim
