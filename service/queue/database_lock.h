// Who owns a SQLite file: one process at a time, a `millsim serve` or a `millsim study --local`.
// The lock is an exclusive flock on the database file itself, so it is keyed by the file's
// identity (device and inode): a symlink or a hard link to the same file meets the same lock,
// and two names for one file cannot both be served. (flock and SQLite's own POSIX record locks
// are independent on Linux, so the lock does not get in SQLite's way.) A refusal names the
// holder's command and pid, found in /proc/locks by the same identity.
#pragma once

#include <filesystem>
#include <string>

namespace millsim {

class DatabaseLock {
 public:
  // Creates the database file when missing and takes the lock; throws IoError naming the holder
  // (its command and pid) when another process has it.
  explicit DatabaseLock(const std::filesystem::path& db);
  ~DatabaseLock();
  DatabaseLock(const DatabaseLock&) = delete;
  DatabaseLock& operator=(const DatabaseLock&) = delete;

 private:
  int db_fd_ = -1;
};

}  // namespace millsim
