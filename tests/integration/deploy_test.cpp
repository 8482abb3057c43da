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

std::string read_text(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// Runs a shell command; its exit status and its stdout and stderr together.
std::pair<int, std::string> shell(const std::string& command) {
  std::string out;
  FILE* p = popen((command + " 2>&1").c_str(), "r");
  if (!p) return {-1, ""};
  char buffer[512];
  while (fgets(buffer, sizeof buffer, p)) out += buffer;
  const int status = pclose(p);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

TEST(Deploy, SystemdUnitsVerify) {
  if (shell("command -v systemd-analyze").first != 0)
    GTEST_SKIP() << "systemd-analyze is not installed (Debian package systemd)";
  test::TempDir dir;
  std::string units;
  for (const char* name :
       {"millsim-server.service", "millsim-regress.service", "millsim-regress.timer"}) {
    std::string text = read_text(kUnits / name);
    ASSERT_FALSE(text.empty()) << name;
    text = std::regex_replace(text, std::regex("/usr/local/bin/millsim"), MILLSIM_BINARY);
    test::write_file(dir.path() / name, text);
    units.append(" ").append((dir.path() / name).string());
  }
  const auto [status, out] = shell("systemd-analyze verify" + units);
  EXPECT_EQ(status, 0) << out;
  EXPECT_EQ(out, "") << "systemd-analyze found problems";
}

// The regress unit's command line, with its suite path pointing nowhere: millsim knows every
// option and stops at the missing suite (exit 2), not at an unknown option.
TEST(Deploy, RegressUnitCommandLineIsAccepted) {
  const std::string unit = read_text(kUnits / "millsim-regress.service");
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
