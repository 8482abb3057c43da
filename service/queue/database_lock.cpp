#include "queue/database_lock.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>

#include "core/errors.h"

namespace millsim {
namespace {

// "millsim serve, pid 123": the process that holds a flock on the file behind `fd`, read from
// /proc/locks (keyed by device and inode, as the lock is) and its command line; "" when unknown.
std::string flock_holder(int fd) {
  struct stat info {};
  if (fstat(fd, &info) != 0) return "";
  char device[64];
  std::snprintf(device, sizeof device, "%02x:%02x:%llu", major(info.st_dev), minor(info.st_dev),
                static_cast<unsigned long long>(info.st_ino));
  std::ifstream locks("/proc/locks");
  for (std::string line; std::getline(locks, line);) {
    std::istringstream fields(line);
    std::string number, kind, mode, access, pid, where;
    if (!(fields >> number >> kind)) continue;
    if (kind == "->") fields >> kind;  // a waiter's line
    if (!(fields >> mode >> access >> pid >> where) || kind != "FLOCK" || where != device) continue;
    std::ifstream cmdline("/proc/" + pid + "/cmdline");
    std::string argv0, argv1;
    std::getline(cmdline, argv0, '\0');
    std::getline(cmdline, argv1, '\0');
    const std::string program = std::filesystem::path(argv0).filename().string();
    return (program.empty() ? std::string("a process") : program + " " + argv1) + ", pid " + pid;
  }
  return "";
}

}  // namespace

DatabaseLock::DatabaseLock(const std::filesystem::path& db) {
  db_fd_ = open(db.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (db_fd_ < 0) throw IoError("cannot open " + db.string() + ": " + std::strerror(errno));
  if (flock(db_fd_, LOCK_EX | LOCK_NB) == 0) return;
  const std::string holder = flock_holder(db_fd_);
  close(db_fd_);
  db_fd_ = -1;
  throw IoError(concat(db.string(), " is in use by ",
                       holder.empty() ? std::string("another process") : holder,
                       " (the lock is on the file itself, whatever name it is opened by): stop "
                       "it or give another --db; to add a study to a served database use "
                       "millsim submit"));
}

DatabaseLock::~DatabaseLock() {
  if (db_fd_ >= 0) close(db_fd_);
}

}  // namespace millsim
