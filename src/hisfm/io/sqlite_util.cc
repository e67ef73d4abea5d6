#include "hisfm/io/sqlite_util.h"

namespace hisfm {

SqliteStatement::SqliteStatement(sqlite3* db, const std::string& sql)
    : db_(db), sql_(sql) {
  const int rc = sqlite3_prepare_v2(db_, sql.c_str(), -1, &stmt_, nullptr);
  ThrowUnless(rc == SQLITE_OK,
              StrCat("database error: ", sqlite3_errmsg(db_), " in: ", sql));
}

SqliteStatement::~SqliteStatement() { sqlite3_finalize(stmt_); }

bool SqliteStatement::Step() {
  const int rc = sqlite3_step(stmt_);
  if (rc == SQLITE_ROW) return true;
  ThrowUnless(rc == SQLITE_DONE,
              StrCat("database error: ", sqlite3_errmsg(db_), " in: ", sql_));
  return false;
}

void SqliteStatement::Reset() {
  sqlite3_reset(stmt_);
  sqlite3_clear_bindings(stmt_);
}

SqliteConnection OpenReadOnlyConnection(const std::string& path) {
  sqlite3* db = nullptr;
  const int rc =
      sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READONLY, nullptr);
  SqliteConnection connection(db);
  if (rc != SQLITE_OK) return nullptr;
  sqlite3_busy_timeout(db, 5000);
  return connection;
}

void SqliteExec(sqlite3* db, const std::string& sql) {
  char* message = nullptr;
  const int rc = sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &message);
  if (rc != SQLITE_OK) {
    const std::string text = message ? message : "unknown error";
    sqlite3_free(message);
    throw Error(StrCat("database error: ", text));
  }
}

std::string SqliteQuote(const std::string& value) {
  std::string out = "'";
  for (char c : value) {
    out += c;
    if (c == '\'') out += '\'';
  }
  return out + "'";
}

}  // namespace hisfm
