// Installing as a user would: `cmake --install` into a fresh prefix puts the binary, the man
// page (the text of `millsim help --man`, gzip -9n compressed as man pages are), the docs, the
// cases and the systemd units (naming the binary and cases where they were installed) in their
// usual places, and the installed binary runs; `cpack -G DEB` makes a package holding the same
// files under /usr, as a Debian package installs them, and nothing under /usr/local.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "support/process.h"
#include "support/sanitizers.h"
#include "support/scenes.h"

namespace millsim {
namespace {

const char* const kInstalled[] = {
    "bin/millsim",
    "share/man/man1/millsim.1.gz",
    "share/doc/millsim/regression.md",
    "share/doc/millsim/openapi.yaml",
    "share/doc/millsim/README.md",
    "share/millsim/cases/spiral_jet_mill.json",
    "share/millsim/cases/regression/physics.json",
    "share/millsim/cases/regression/baseline.json",
    "lib/systemd/system/millsim-server.service",
    "lib/systemd/system/millsim-regress.timer",
};

// A gzip file made with -n: no file name and no time stamp in its header (RFC 1952: FLG bit 3
// FNAME, MTIME bytes 4-7), so the package is the same whenever it is built.
bool gzip_without_name_or_time(const std::string& bytes) {
  return bytes.size() > 10 && bytes[0] == '\x1f' && bytes[1] == '\x8b' && (bytes[3] & 0x08) == 0 &&
         bytes.substr(4, 4) == std::string(4, '\0');
}

// The ExecStart lines of the installed systemd units name `prefix`'s binary and cases.
void expect_units_name(const std::string& server_unit, const std::string& prefix) {
  EXPECT_NE(server_unit.find("ExecStart=" + prefix + "/bin/millsim serve"), std::string::npos)
      << server_unit;
  EXPECT_NE(server_unit.find("--scenes " + prefix + "/share/millsim/cases"), std::string::npos)
      << server_unit;
}

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
  const std::filesystem::path man_page = prefix / "share/man/man1/millsim.1.gz";
  EXPECT_TRUE(gzip_without_name_or_time(test::read_file(man_page)));
  const auto [unzip_status, unzipped] =
      test::run_shell("gzip -dc " + man_page.string()).status_and_output();
  EXPECT_EQ(unzip_status, 0);
  EXPECT_EQ(unzipped, man);
  EXPECT_FALSE(std::filesystem::exists(prefix / "share/man/man1/millsim.1"));
  expect_units_name(test::read_file(prefix / "lib/systemd/system/millsim-server.service"),
                    prefix.string());
  // The installed suite finds its scenes relative to itself.
  const auto [suite_status, suite_out] =
      test::run_shell((prefix / "bin/millsim").string() + " regress " +
                      (prefix / "share/millsim/cases/regression/physics.json").string() +
                      " --format xml")
          .status_and_output();
  EXPECT_EQ(suite_status, 2) << suite_out;  // bad option, but the suite path was accepted
}

TEST(Install, CpackMakesADebianPackage) {
  MILLSIM_RELEASE_ONLY("Install.CmakeInstallPutsEverythingInItsPlace (the package is cpack's)");
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
    EXPECT_NE(listing.find(std::string("./usr/") + file + "\n"), std::string::npos)
        << file << " in:\n"
        << listing;
  EXPECT_EQ(listing.find("/usr/local"), std::string::npos) << listing;
  // The man page in the package: gzip -9n of `millsim help --man`.
  const auto [man_status, man] = test::run_millsim("help --man", dir.path()).status_and_output();
  const std::string extract = "dpkg-deb --fsys-tarfile " + deb.string() + " | tar -xO ";
  const auto [gz_status, gz] =
      test::run_shell(extract + "./usr/share/man/man1/millsim.1.gz").status_and_output();
  EXPECT_EQ(gz_status, 0);
  EXPECT_TRUE(gzip_without_name_or_time(gz));
  const auto [unzip_status, unzipped] =
      test::run_shell(extract + "./usr/share/man/man1/millsim.1.gz | gzip -dc").status_and_output();
  EXPECT_EQ(unzip_status, 0);
  EXPECT_EQ(unzipped, man);
  // Its systemd units start the packaged binary.
  expect_units_name(
      test::run_shell(extract + "./usr/lib/systemd/system/millsim-server.service").out, "/usr");
  const auto [info_status, info] =
      test::run_shell("dpkg-deb -f " + deb.string() + " Package Depends").status_and_output();
  EXPECT_NE(info.find("Package: millsim"), std::string::npos) << info;
  EXPECT_NE(info.find("libhdf5"), std::string::npos) << "shared-library dependencies: " << info;
}

}  // namespace
}  // namespace millsim
