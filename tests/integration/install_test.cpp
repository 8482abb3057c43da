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
      test::run_shell("cmake --install " MILLSIM_BUILD_DIR " --prefix " + prefix.string())
          .status_and_output();
  ASSERT_EQ(status, 0) << out;
  for (const char* file : kInstalled)
    EXPECT_TRUE(std::filesystem::is_regular_file(prefix / file)) << file;
  const auto [version_status, version] =
      test::run_shell((prefix / "bin/millsim").string() + " version").status_and_output();
  EXPECT_EQ(version_status, 0);
  EXPECT_EQ(version.rfind("millsim ", 0), 0u) << version;
  const auto [man_status, man] =
      test::run_shell((prefix / "bin/millsim").string() + " help --man").status_and_output();
  EXPECT_EQ(test::read_file(prefix / "share/man/man1/millsim.1"), man);
  // The installed suite finds its scenes relative to itself.
  const auto [suite_status, suite_out] =
      test::run_shell((prefix / "bin/millsim").string() + " regress " +
                      (prefix / "share/millsim/cases/regression/physics.json").string() +
                      " --format xml")
          .status_and_output();
  EXPECT_EQ(suite_status, 2) << suite_out;  // bad option, but the suite path was accepted
}

TEST(Install, CpackMakesADebianPackage) {
  if (test::run_shell("command -v cpack && command -v dpkg-deb").exit_code != 0)
    GTEST_SKIP() << "cpack or dpkg-deb is not installed";
  test::TempDir dir;
  const auto [status, out] =
      test::run_shell("cd " + dir.path().string() +
                      " && cpack -G DEB --config " MILLSIM_BUILD_DIR "/CPackConfig.cmake -B " +
                      dir.path().string())
          .status_and_output();
  ASSERT_EQ(status, 0) << out;
  std::filesystem::path deb;
  for (const auto& entry : std::filesystem::directory_iterator(dir.path()))
    if (entry.path().extension() == ".deb") deb = entry.path();
  ASSERT_FALSE(deb.empty()) << out;
  const auto [list_status, listing] =
      test::run_shell("dpkg-deb -c " + deb.string()).status_and_output();
  ASSERT_EQ(list_status, 0) << listing;
  for (const char* file : kInstalled)
    EXPECT_NE(listing.find(std::string("./usr/local/") + file), std::string::npos) << file;
  const auto [info_status, info] =
      test::run_shell("dpkg-deb -f " + deb.string() + " Package Depends").status_and_output();
  EXPECT_NE(info.find("Package: millsim"), std::string::npos) << info;
  EXPECT_NE(info.find("libhdf5"), std::string::npos) << "shared-library dependencies: " << info;
}

}  // namespace
}  // namespace millsim
