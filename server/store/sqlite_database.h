// SqlDatabase over one SQLite file: WAL journal (readers never wait for the
// writer), a busy timeout (writers wait for each other), foreign keys on,
// and BEGIN IMMEDIATE transactions so a transaction takes the write lock
// before it reads and never has to be upgraded. One connection, guarded by
// a mutex, so one object may be used from many threads; several objects
// (or processes) may open the same file.
//
//   ASSIGN_OR_RETURN(std::unique_ptr<SqliteDatabase> db, SqliteDatabase::Open("/var/pf/jobs.db"));
#ifndef POINTFORWARD_SERVER_STORE_SQLITE_DATABASE_H_
#define POINTFORWARD_SERVER_STORE_SQLITE_DATABASE_H_

#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "server/store/sql_database.h"

struct sqlite3;

namespace pf {

class SqliteDatabase : public SqlDatabase {
 public:
  // Opens (creating if absent) the database file at `path`. The directory
  // must exist.
  static absl::StatusOr<std::unique_ptr<SqliteDatabase>> Open(const std::string& path);

  ~SqliteDatabase() override;
  SqliteDatabase(const SqliteDatabase&) = delete;
  SqliteDatabase& operator=(const SqliteDatabase&) = delete;

  SqlDialect dialect() const override { return SqlDialect::kSqlite; }
  absl::StatusOr<SqlRows> Exec(const std::string& sql,
                               const std::vector<SqlValue>& params = {}) override;
  absl::Status Transaction(const TransactionFn& fn) override;

 private:
  class LockedExecutor;

  SqliteDatabase(sqlite3* db, std::string path) : db_(db), path_(std::move(path)) {}

  // Exec with mutex_ held.
  absl::StatusOr<SqlRows> ExecLocked(const std::string& sql, const std::vector<SqlValue>& params);
  // One try of Transaction, with mutex_ held.
  absl::Status TransactionOnce(const TransactionFn& fn);

  std::mutex mutex_;
  sqlite3* db_;
  const std::string path_;
};

}  // namespace pf

#endif  // POINTFORWARD_SERVER_STORE_SQLITE_DATABASE_H_
