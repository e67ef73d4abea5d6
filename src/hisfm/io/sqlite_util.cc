#include "hisfm/io/sqlite_util.h"

#include <cstdio>
#include <filesystem>

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
  ThrowUnless(rc == SQLITE_DONE, StrCat("database error: ",
                                        DescribeSqliteError(db_), " in: ",
                                        sql_));
  return false;
}

void SqliteStatement::Reset() {
  sqlite3_reset(stmt_);
  sqlite3_clear_bindings(stmt_);
}

std::string ReadOnlyUri(const std::string& path) {
  const std::string absolute = std::filesystem::absolute(path).string();
  // "file://" and an empty authority: a path starting with "//" stays a
  // path.
  std::string uri = "file://";
  for (char c : absolute) {
    if (c == '%' || c == '?' || c == '#') {
      char buf[4];
      std::snprintf(buf, sizeof(buf), "%%%02X", static_cast<unsigned char>(c));
      uri += buf;
    } else {
      uri += c;
    }
  }
  std::error_code ec;
  const std::string wal = absolute + "-wal";
  const bool has_log = (std::filesystem::exists(wal, ec) &&
                        std::filesystem::file_size(wal, ec) > 0) ||
                       std::filesystem::exists(absolute + "-journal", ec);
  return uri + (has_log ? "?mode=ro" : "?mode=ro&immutable=1");
}

SqliteConnection OpenReadOnlyConnection(const std::string& path,
                                        std::string* error) {
  sqlite3* db = nullptr;
  const int rc = sqlite3_open_v2(ReadOnlyUri(path).c_str(), &db,
                                 SQLITE_OPEN_READONLY | SQLITE_OPEN_URI,
                                 nullptr);
  SqliteConnection connection(db);
  if (rc != SQLITE_OK) {
    if (error) *error = db ? sqlite3_errmsg(db) : "cannot open";
    return nullptr;
  }
  sqlite3_busy_timeout(db, 5000);
  return connection;
}

std::string DescribeSqliteError(sqlite3* db) {
  const std::string message = sqlite3_errmsg(db);
  switch (sqlite3_errcode(db) & 0xff) {
    case SQLITE_CORRUPT:
      return "the file is corrupt (SQLite: " + message + ")";
    case SQLITE_NOTADB:
      return "the file is not an SQLite database (SQLite: " + message + ")";
    case SQLITE_BUSY:
    case SQLITE_LOCKED:
      return "it is locked by another program that is writing it, e.g. "
             "colmap (SQLite: " +
             message + "); try again when that program has finished";
    default:
      return message;
  }
}

void SqliteExec(sqlite3* db, const std::string& sql) {
  char* message = nullptr;
  const int rc = sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &message);
  if (rc != SQLITE_OK) {
    sqlite3_free(message);
    throw Error(StrCat("database error: ", DescribeSqliteError(db)));
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

std::string SqliteQuoteIdentifier(const std::string& name) {
  std::string out = "\"";
  for (char c : name) {
    out += c;
    if (c == '"') out += '"';
  }
  return out + "\"";
}

bool SqliteHasTable(sqlite3* db, const std::string& table) {
  SqliteStatement stmt(
      db, "SELECT count(*) FROM sqlite_master WHERE type='table' AND name=?");
  sqlite3_bind_text(stmt.get(), 1, table.c_str(), -1, SQLITE_TRANSIENT);
  return stmt.Step() && sqlite3_column_int(stmt.get(), 0) > 0;
}

bool SqliteHasColumn(sqlite3* db, const std::string& table,
                     const std::string& column) {
  SqliteStatement stmt(
      db, "SELECT count(*) FROM pragma_table_info(?) WHERE name = ?");
  sqlite3_bind_text(stmt.get(), 1, table.c_str(), -1, SQLITE_TRANSIENT);
  sqlite3_bind_text(stmt.get(), 2, column.c_str(), -1, SQLITE_TRANSIENT);
  return stmt.Step() && sqlite3_column_int(stmt.get(), 0) > 0;
}

}  // namespace hisfm
