// The systemd units in deploy/systemd/ as systemd itself reads them: `systemd-analyze verify`
// accepts each (the binary path replaced by the one just built), and the command lines they
// start are ones millsim accepts (every option known; the suite path it names is checked).
#include <gtest/gtest.h>

#include <fstream>
#include <regex>
#include <sstream>

#include "support/process.h"
#include "support/scenes.h"

namespace millsim {
namespace {

const std::filesystem::path kUnits = MILLSIM_SOURCE_DIR "/deploy/systemd";

TEST(Deploy, SystemdUnitsVerify) {
  if (test::run_shell("command -v systemd-analyze").exit_code != 0)
    GTEST_SKIP() << "systemd-analyze is not installed (Debian package systemd)";
  test::TempDir dir;
  std::string units;
  for (const char* name :
       {"millsim-server.service", "millsim-regress.service", "millsim-regress.timer"}) {
    std::string text = test::read_file(kUnits / name);
    ASSERT_FALSE(text.empty()) << name;
    text = std::regex_replace(text, std::regex("/usr/local/bin/millsim"), MILLSIM_BINARY);
    test::write_file(dir.path() / name, text);
    units.append(" ").append((dir.path() / name).string());
  }
  const auto [status, out] = test::run_shell("systemd-analyze verify" + units).status_and_output();
  EXPECT_EQ(status, 0) << out;
  EXPECT_EQ(out, "") << "systemd-analyze found problems";
}

// The regress unit's command line, with its suite path pointing nowhere: millsim knows every
// option and stops at the missing suite (exit 2), not at an unknown option.
TEST(Deploy, RegressUnitCommandLineIsAccepted) {
  const std::string unit = test::read_file(kUnits / "millsim-regress.service");
  std::smatch m;
  ASSERT_TRUE(std::regex_search(unit, m, std::regex("ExecStart=/usr/local/bin/millsim (.*)")));
  test::TempDir dir;
  const std::string args = std::regex_replace(
      std::string(m[1]), std::regex("/usr/local/share/millsim/cases/regression/physics.json"),
      "nowhere.json");
  const test::CommandResult r = test::run_millsim(
      std::regex_replace(args, std::regex("/var/lib/millsim"), dir.path().string()), dir.path());
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("nowhere.json: no such suite file"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace millsim
