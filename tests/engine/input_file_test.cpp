// What a run may read is decided when the file is opened (io/input_file.h, issue 33): a FIFO or
// a device is refused without blocking or reading it, a symlink is refused where none is taken
// (checkpoints), and under a files root the file actually opened must lie inside it, however
// the name leads there. Checked on the reader itself and through `millsim run`.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "core/errors.h"
#include "io/input_file.h"
#include "support/process.h"
#include "support/scenes.h"

namespace millsim {
namespace {

namespace fs = std::filesystem;

TEST(InputFile, RegularFilesAreReadAndSpecialFilesRefusedWithoutBlocking) {
  test::TempDir dir;
  test::write_file(dir.path() / "plain.txt", "1 2 3\n");
  EXPECT_EQ(read_input_file(dir.path() / "plain.txt", {}), "1 2 3\n");
  // A FIFO nobody writes would block an open() or a read() for ever.
  ASSERT_EQ(mkfifo((dir.path() / "fifo").c_str(), 0600), 0);
  EXPECT_THROW(read_input_file(dir.path() / "fifo", {}), InputFileRefused);
  // /dev/zero reads for ever, growing the reader's memory.
  EXPECT_THROW(read_input_file("/dev/zero", {}), InputFileRefused);
  fs::create_symlink("/dev/zero", dir.path() / "zero");
  EXPECT_THROW(read_input_file(dir.path() / "zero", {}), InputFileRefused);
  EXPECT_THROW(read_input_file(dir.path(), {}), InputFileRefused);  // a directory
  EXPECT_THROW(read_input_file(dir.path() / "missing", {}), IoError);
  // Where symlinks are not taken, a link to a regular file is refused too.
  fs::create_symlink(dir.path() / "plain.txt", dir.path() / "link.txt");
  EXPECT_EQ(read_input_file(dir.path() / "link.txt", {}), "1 2 3\n");
  EXPECT_THROW(read_input_file(dir.path() / "link.txt", {{}, false}), InputFileRefused);
  // A file larger than allowed is refused before it is read.
  EXPECT_THROW(read_input_file(dir.path() / "plain.txt", {{}, true, 3}), InputFileRefused);
}

TEST(InputFile, UnderARootTheFileOpenedMustLieInsideWhateverTheNameSays) {
  test::TempDir dir;
  const fs::path root = dir.path() / "scenes";
  fs::create_directories(root / "sub");
  test::write_file(root / "sub" / "inside.txt", "inside\n");
  test::write_file(dir.path() / "secret.txt", "secret\n");
  EXPECT_EQ(read_input_file(root / "sub" / "inside.txt", {root}), "inside\n");
  // A link inside the root to a file inside it is fine...
  fs::create_symlink(root / "sub" / "inside.txt", root / "alias.txt");
  EXPECT_EQ(read_input_file(root / "alias.txt", {root}), "inside\n");
  // ...one that leads out is not, nor a link to a directory out of it, nor "..".
  fs::create_symlink(dir.path() / "secret.txt", root / "out.txt");
  EXPECT_THROW(read_input_file(root / "out.txt", {root}), InputFileRefused);
  fs::create_directory_symlink(dir.path(), root / "up");
  EXPECT_THROW(read_input_file(root / "up" / "secret.txt", {root}), InputFileRefused);
  EXPECT_THROW(read_input_file(root / ".." / "secret.txt", {root}), InputFileRefused);
  // A sibling whose name starts like the root is outside it.
  fs::create_directories(dir.path() / "scenes2");
  test::write_file(dir.path() / "scenes2" / "x.txt", "x\n");
  EXPECT_THROW(read_input_file(dir.path() / "scenes2" / "x.txt", {root}), InputFileRefused);
  // The root itself may be reached through a link.
  fs::create_directory_symlink(root, dir.path() / "root-link");
  EXPECT_EQ(read_input_file(root / "sub" / "inside.txt", {dir.path() / "root-link"}), "inside\n");
}

// The two-sphere case with its particles from a file.
nlohmann::json scene_with_file(const std::string& path) {
  std::ifstream in(MILLSIM_SOURCE_DIR "/cases/impact_two_spheres.json");
  nlohmann::json scene = nlohmann::json::parse(in);
  scene["sources"] = {
      {{"type", "file"}, {"material", scene["materials"][0]["name"]}, {"path", path}}};
  scene["time"]["end_s"] = 1e-6;
  scene["output"] = {{"h5", false}};
  return scene;
}

TEST(InputFile, RunFilesRootRefusesAParticleFileSwappedForALinkOut) {
  // What the service's worker meets when a particle file checked at submission is replaced by
  // a symlink to /etc/passwd before the run starts: the engine refuses it as bad input and
  // never quotes what is there.
  test::TempDir dir;
  const fs::path root = dir.path() / "scenes";
  fs::create_directories(root);
  test::write_file(root / "p.txt", "# N: 1\n1 5e-4 5e-4 5e-4 1e-4 0 0 0\n");
  test::write_file(root / "scene.json", scene_with_file("p.txt").dump());
  auto ok = test::run_millsim(
      "run scene.json --out out --quiet --files-root '" + root.string() + "'", root);
  EXPECT_EQ(ok.exit_code, 0) << ok.err;
  fs::remove(root / "p.txt");
  fs::create_symlink("/etc/passwd", root / "p.txt");
  auto refused = test::run_millsim(
      "run scene.json --out out2 --quiet --files-root '" + root.string() + "'", root);
  EXPECT_EQ(refused.exit_code, 2) << refused.err;
  EXPECT_NE(refused.err.find("outside the files root"), std::string::npos) << refused.err;
  EXPECT_EQ(refused.err.find("root:x:0"), std::string::npos) << refused.err;
  // Without a root (a user's own run) a link is followed: /etc/passwd is read as particles and
  // fails as a malformed particle file, not as a refused one.
  auto unrooted = test::run_millsim("run scene.json --out out3 --quiet", root);
  EXPECT_EQ(unrooted.exit_code, 2) << unrooted.err;
  EXPECT_EQ(unrooted.err.find("outside the files root"), std::string::npos) << unrooted.err;
}

TEST(InputFile, ResumeRefusesACheckpointThatIsALinkToDevZeroOrAFifo) {
  // Before, --resume read /dev/zero behind a checkpoint's name until memory ran out, and hung
  // on a FIFO. Now each is a damaged checkpoint, and with nothing else to resume from, exit 2.
  test::TempDir dir;
  test::write_file(dir.path() / "p.txt", "# N: 1\n1 5e-4 5e-4 5e-4 1e-4 0 0 0\n");
  test::write_file(dir.path() / "scene.json", scene_with_file("p.txt").dump());
  fs::create_directories(dir.path() / "out" / "checkpoints");
  fs::create_symlink("/dev/zero", dir.path() / "out" / "checkpoints" / "step-000000000100.ckpt");
  ASSERT_EQ(mkfifo((dir.path() / "out" / "checkpoints" / "step-000000000050.ckpt").c_str(), 0600),
            0);
  auto r = test::run_millsim("run scene.json --out out --quiet --resume", dir.path());
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("symbolic link"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("not a regular file"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace millsim
