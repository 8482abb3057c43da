// Opening a file the run reads (a particle file, a scene, a checkpoint) so that what may be read
// is decided when the file is opened, by the process that opens it: the file is opened without
// blocking (a FIFO cannot hang the reader), must be a regular file (not a device, FIFO, socket
// or directory), may refuse a symlink as its last component, and, given a root, the file
// actually opened (its /proc/self/fd link, after every symlink) must lie under the root's real
// path. A check made earlier on the name (when a study is posted) cannot be raced by a symlink
// placed afterwards.
#pragma once

#include <filesystem>
#include <stdexcept>
#include <string>

namespace millsim {

struct InputFileRules {
  std::filesystem::path root;   // empty: anywhere
  bool follow_symlinks = true;  // false: a symlink as the last component is refused
  std::size_t max_bytes = std::size_t(1) << 32;
};

// The whole file as bytes. Throws InputFileRefused (a special file, a symlink where none is
// taken, outside the root, too large: bad input) or IoError (missing, unreadable).
std::string read_input_file(const std::filesystem::path& path, const InputFileRules& rules);

struct InputFileRefused : std::runtime_error {
  using std::runtime_error::runtime_error;
};

}  // namespace millsim
