#include "queue/sqlite_db.h"

#include <type_traits>

namespace millsim {

Statement::Statement(sqlite3* db, const char* sql) : db_(db), sql_(sql) {
  if (sqlite3_prepare_v2(db, sql, -1, &stmt_, nullptr) != SQLITE_OK)
    throw DbError(std::string("SQLite: cannot prepare \"") + sql + "\": " + sqlite3_errmsg(db));
}

Statement::~Statement() {
  sqlite3_finalize(stmt_);
}

static void check_bind(int rc, sqlite3* db, const std::string& sql) {
  if (rc != SQLITE_OK)
    throw DbError("SQLite: bind failed in \"" + sql + "\": " + sqlite3_errmsg(db));
}

Statement& Statement::bind(int i, std::int64_t v) {
  check_bind(sqlite3_bind_int64(stmt_, i, v), db_, sql_);
  return *this;
}
Statement& Statement::bind(int i, double v) {
  check_bind(sqlite3_bind_double(stmt_, i, v), db_, sql_);
  return *this;
}
Statement& Statement::bind(int i, const std::string& v) {
  check_bind(sqlite3_bind_text(stmt_, i, v.data(), int(v.size()), SQLITE_TRANSIENT), db_, sql_);
  return *this;
}
Statement& Statement::bind(int i, std::nullopt_t) {
  check_bind(sqlite3_bind_null(stmt_, i), db_, sql_);
  return *this;
}
Statement& Statement::bind(int i, const std::optional<std::string>& v) {
  return v ? bind(i, *v) : bind(i, std::nullopt);
}

bool Statement::step() {
  const int rc = sqlite3_step(stmt_);
  if (rc == SQLITE_ROW) return true;
  if (rc == SQLITE_DONE) return false;
  throw DbError("SQLite: \"" + sql_ + "\" failed: " + sqlite3_errmsg(db_));
}

void Statement::run() {
  while (step()) {
  }
}

std::int64_t Statement::integer(int c) const {
  return sqlite3_column_int64(stmt_, c);
}
double Statement::real(int c) const {
  return sqlite3_column_double(stmt_, c);
}
std::string Statement::text(int c) const {
  const unsigned char* t = sqlite3_column_text(stmt_, c);
  return t ? std::string(reinterpret_cast<const char*>(t),
                         std::size_t(sqlite3_column_bytes(stmt_, c)))
           : std::string();
}
bool Statement::is_null(int c) const {
  return sqlite3_column_type(stmt_, c) == SQLITE_NULL;
}

Database::Database(const std::filesystem::path& path) {
  if (sqlite3_open_v2(path.c_str(), &db_, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE, nullptr) !=
      SQLITE_OK) {
    const std::string message = db_ ? sqlite3_errmsg(db_) : "out of memory";
    sqlite3_close(db_);
    db_ = nullptr;
    throw DbError("SQLite: cannot open " + path.string() + ": " + message);
  }
  sqlite3_busy_timeout(db_, 5000);
  exec("PRAGMA journal_mode=WAL");
  exec("PRAGMA foreign_keys=ON");
  exec("PRAGMA synchronous=NORMAL");
}

Database::~Database() {
  sqlite3_close(db_);
}

void Database::exec(const char* sql) {
  char* message = nullptr;
  if (sqlite3_exec(db_, sql, nullptr, nullptr, &message) != SQLITE_OK) {
    const std::string text = message ? message : "unknown error";
    sqlite3_free(message);
    throw DbError(std::string("SQLite: \"") + sql + "\" failed: " + text);
  }
}

}  // namespace millsim
