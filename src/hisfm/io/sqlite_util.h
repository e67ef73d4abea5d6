// Small RAII helpers around the SQLite C API, used by the database readers and
// writers.
#pragma once

#include <sqlite3.h>

#include <memory>

#include <string>

#include "hisfm/util/error.h"

namespace hisfm {

/// A prepared statement, finalized on destruction.
class SqliteStatement {
 public:
  SqliteStatement(sqlite3* db, const std::string& sql);
  ~SqliteStatement();
  SqliteStatement(const SqliteStatement&) = delete;
  SqliteStatement& operator=(const SqliteStatement&) = delete;

  sqlite3_stmt* get() const { return stmt_; }
  /// Steps once; true while a row is available, false when done.
  bool Step();
  /// Resets for another execution with new bindings.
  void Reset();

 private:
  sqlite3* db_;
  sqlite3_stmt* stmt_ = nullptr;
  std::string sql_;
};

/// Closes a connection (for std::unique_ptr).
struct SqliteCloser {
  void operator()(sqlite3* db) const { sqlite3_close(db); }
};
/// A connection closed on destruction.
using SqliteConnection = std::unique_ptr<sqlite3, SqliteCloser>;

/// The URI that opens `path` read-only. Without a write-ahead log beside
/// the file (a database closed cleanly, COLMAP's in WAL mode included) it is
/// opened as immutable: SQLite then creates no -shm or -wal file next to it
/// and needs no write access to its folder. With a log or a rollback
/// journal (a writer is still at work, or crashed) it is opened normally, so
/// that SQLite reads the log and takes its locks.
std::string ReadOnlyUri(const std::string& path);

/// Opens a database read-only through ReadOnlyUri (5 s busy timeout); null
/// if it cannot be opened, with SQLite's message in `error` if given.
SqliteConnection OpenReadOnlyConnection(const std::string& path,
                                        std::string* error = nullptr);

/// The last error of a connection as a user reads it: SQLite's message,
/// preceded by what it means for the common cases ("the file is corrupt",
/// "locked by another program").
std::string DescribeSqliteError(sqlite3* db);

/// Executes SQL without results; throws Error naming `context` on failure.
void SqliteExec(sqlite3* db, const std::string& sql);

/// Quotes a string as an SQL literal ('it''s').
std::string SqliteQuote(const std::string& value);

/// Quotes a name as an SQL identifier ("a""b").
std::string SqliteQuoteIdentifier(const std::string& name);

/// True if the main schema of `db` has a table `table`.
bool SqliteHasTable(sqlite3* db, const std::string& table);

/// True if `table` of `db` has a column `column` (false without the table).
bool SqliteHasColumn(sqlite3* db, const std::string& table,
                     const std::string& column);

}  // namespace hisfm
