#include "io/input_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <climits>
#include <cstring>

#include "core/errors.h"

namespace millsim {
namespace {

// Closes a descriptor at the end of its scope.
struct Descriptor {
  int fd = -1;
  ~Descriptor() {
    if (fd >= 0) close(fd);
  }
};

// Whether `inner` is `outer` or lies below it, compared by whole path components.
bool lies_under(const std::filesystem::path& inner, const std::filesystem::path& outer) {
  const auto [outer_end, unused] =
      std::mismatch(outer.begin(), outer.end(), inner.begin(), inner.end());
  return outer_end == outer.end();
}

}  // namespace

std::string read_input_file(const std::filesystem::path& path, const InputFileRules& rules) {
  const std::string name = path.string();
  Descriptor file;
  file.fd = open(name.c_str(),
                 O_RDONLY | O_CLOEXEC | O_NONBLOCK | (rules.follow_symlinks ? 0 : O_NOFOLLOW));
  if (file.fd < 0) {
    if (errno == ELOOP && !rules.follow_symlinks)
      throw InputFileRefused(name + " is a symbolic link, which is not followed here");
    throw IoError(concat("cannot read ", name, ": ", std::strerror(errno)));
  }
  struct stat info {};
  if (fstat(file.fd, &info) != 0)
    throw IoError(concat("cannot read ", name, ": ", std::strerror(errno)));
  if (!S_ISREG(info.st_mode))
    throw InputFileRefused(name + " is not a regular file (a device, FIFO, socket or directory)");
  if (std::size_t(info.st_size) > rules.max_bytes)
    throw InputFileRefused(concat(name, " has ", info.st_size, " bytes, more than the ",
                                  rules.max_bytes, " read here"));
  if (!rules.root.empty()) {
    std::error_code ec;
    const std::filesystem::path real_root = std::filesystem::canonical(rules.root, ec);
    if (ec)
      throw IoError(
          concat("cannot resolve the files root ", rules.root.string(), ": ", ec.message()));
    char opened[PATH_MAX + 1] = {};
    const std::string link = "/proc/self/fd/" + std::to_string(file.fd);
    const ssize_t n = readlink(link.c_str(), opened, PATH_MAX);
    if (n <= 0) throw IoError(concat("cannot tell where ", name, " leads: ", std::strerror(errno)));
    if (!lies_under(std::filesystem::path(std::string(opened, std::size_t(n))), real_root))
      throw InputFileRefused(name + " leads outside the files root " + rules.root.string() +
                             " (through a symbolic link)");
  }
  fcntl(file.fd, F_SETFL, fcntl(file.fd, F_GETFL) & ~O_NONBLOCK);
  std::string bytes;
  bytes.resize(std::size_t(info.st_size));
  std::size_t have = 0;
  while (true) {
    if (have == bytes.size()) bytes.resize(std::min(rules.max_bytes + 1, bytes.size() * 2 + 4096));
    const ssize_t got = read(file.fd, bytes.data() + have, bytes.size() - have);
    if (got < 0 && errno == EINTR) continue;
    if (got < 0) throw IoError(concat("cannot read ", name, ": ", std::strerror(errno)));
    if (got == 0) break;
    have += std::size_t(got);
    if (have > rules.max_bytes)  // it grew while read
      throw InputFileRefused(
          concat(name, " has more than the ", rules.max_bytes, " bytes read here"));
  }
  bytes.resize(have);
  return bytes;
}

}  // namespace millsim
