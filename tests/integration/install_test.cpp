// Installing as a user would: `cmake --install` into a fresh prefix puts the binary, the man
// page (the same text as `millsim help --man`), the docs, the cases and the systemd units in
// their usual places, and the installed binary runs; `cpack -G DEB` makes a package holding
// the same files under /usr/local.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "support/process.h"
#include "support/scenes.h"

namespace millsim {
namespace {

std::string read_text(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

std::pair<int, std::string> shell(const std::string& command) {
  std::string out;
  FILE* p = popen((command + " 2>&1").c_str(), "r");
  if (!p) return {-1, ""};
  char buffer[512];
  while (fgets(buffer, sizeof buffer, p)) out += buffer;
  const int status = pclose(p);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

const char* const kInstalled[] = {
    "bin/millsim",
    "share/man/man1/millsim.1",
    "share/doc/millsim/regression.md",
    "share/doc/millsim/openapi.yaml",
    "share/doc/millsim/README.md",
    "share/millsim/cases/spiral_jet_mill.json",
    "share/millsim/cases/regression/physics.json",
    "share/millsim/cases/regression/baseline.json",
    "lib/systemd/system/millsim-server.service",
    "lib/systemd/system/millsim-regress.timer",
};

TEST(Install, CmakeInstallPutsEverythingInItsPlace) {
  test::TempDir dir;
  const std::filesystem::path prefix = dir.path() / "prefix";
  const auto [status, out] =
      shell("cmake --install " MILLSIM_BUILD_DIR " --prefix " + prefix.string());
  ASSERT_EQ(status, 0) << out;
  for (const char* file : kInstalled)
    EXPECT_TRUE(std::filesystem::is_regular_file(prefix / file)) << file;
  const auto [version_status, version] = shell((prefix / "bin/millsim").string() + " version");
  EXPECT_EQ(version_status, 0);
  EXPECT_EQ(version.rfind("millsim ", 0), 0u) << version;
  const auto [man_status, man] = shell((prefix / "bin/millsim").string() + " help --man");
  EXPECT_EQ(read_text(prefix / "share/man/man1/millsim.1"), man);
  // The installed suite finds its scenes relative to itself.
  const auto [suite_status, suite_out] =
      shell((prefix / "bin/millsim").string() + " regress " +
            (prefix / "share/millsim/cases/regression/physics.json").string() + " --format xml");
  EXPECT_EQ(suite_status, 2) << suite_out;  // bad option, but the suite path was accepted
}

TEST(Install, CpackMakesADebianPackage) {
  if (shell("command -v cpack && command -v dpkg-deb").first != 0)
    GTEST_SKIP() << "cpack or dpkg-deb is not installed";
  test::TempDir dir;
  const auto [status, out] =
      shell("cd " + dir.path().string() +
            " && cpack -G DEB --config " MILLSIM_BUILD_DIR "/CPackConfig.cmake -B " +
            dir.path().string());
  ASSERT_EQ(status, 0) << out;
  std::filesystem::path deb;
  for (const auto& entry : std::filesystem::directory_iterator(dir.path()))
    if (entry.path().extension() == ".deb") deb = entry.path();
  ASSERT_FALSE(deb.empty()) << out;
  const auto [list_status, listing] = shell("dpkg-deb -c " + deb.string());
  ASSERT_EQ(list_status, 0) << listing;
  for (const char* file : kInstalled)
    EXPECT_NE(listing.find(std::string("./usr/local/") + file), std::string::npos) << file;
  const auto [info_status, info] = shell("dpkg-deb -f " + deb.string() + " Package Depends");
  EXPECT_NE(info.find("Package: millsim"), std::string::npos) << info;
  EXPECT_NE(info.find("libhdf5"), std::string::npos) << "shared-library dependencies: " << info;
}

}  // namespace
}  // namespace millsim
