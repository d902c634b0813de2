// SqliteDatabase: statements prepared, bound by `$N` name, stepped to the
// end; transactions retried when another connection holds the write lock.
#include "server/store/sqlite_database.h"

#include <sqlite3.h>

#include <chrono>
#include <thread>

#include "absl/strings/ascii.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "common/status_macros.h"

namespace pf {
namespace {

// How long a statement waits for another connection's write lock before
// failing with SQLITE_BUSY, and how often Transaction then starts over.
constexpr int kBusyTimeoutMs = 10000;
constexpr int kSqliteTransactionTries = 8;

// Maps an SQLite result code to a status naming `what` and SQLite's message.
absl::Status SqliteError(sqlite3* db, int code, const std::string& what) {
  std::string message = absl::StrCat(what, ": ", db ? sqlite3_errmsg(db) : sqlite3_errstr(code));
  switch (code & 0xff) {
    case SQLITE_BUSY:
    case SQLITE_LOCKED:
      return absl::AbortedError(message);
    case SQLITE_CANTOPEN:
    case SQLITE_PERM:
    case SQLITE_READONLY:
    case SQLITE_NOTADB:
      return absl::FailedPreconditionError(message);
    default:
      return absl::InternalError(message);
  }
}

// Finalizes a prepared statement when it goes out of scope.
struct StatementCloser {
  void operator()(sqlite3_stmt* stmt) const { sqlite3_finalize(stmt); }
};
using Statement = std::unique_ptr<sqlite3_stmt, StatementCloser>;

// Binds params[i] to the parameter named "$<i+1>". Every parameter in the
// SQL must be one of those and every param must be used, as PostgreSQL
// requires.
absl::Status BindParams(sqlite3* db, sqlite3_stmt* stmt, const std::vector<SqlValue>& params,
                        const std::string& sql) {
  const int count = sqlite3_bind_parameter_count(stmt);
  std::vector<bool> used(params.size(), false);
  for (int k = 1; k <= count; ++k) {
    const char* name = sqlite3_bind_parameter_name(stmt, k);
    int number = 0;
    if (name == nullptr || name[0] != '$' || !absl::SimpleAtoi(name + 1, &number) || number < 1 ||
        number > static_cast<int>(params.size())) {
      return absl::InvalidArgumentError(absl::StrCat("SQL parameter '", name ? name : "?",
                                                     "' has no value (", params.size(),
                                                     " given) in: ", sql));
    }
    used[number - 1] = true;
    const SqlValue& value = params[number - 1];
    int rc = SQLITE_OK;
    if (value.is_null()) {
      rc = sqlite3_bind_null(stmt, k);
    } else if (value.is_int()) {
      rc = sqlite3_bind_int64(stmt, k, value.AsInt());
    } else if (value.is_double()) {
      rc = sqlite3_bind_double(stmt, k, value.AsDouble());
    } else {
      const std::string text = value.AsString();
      rc = sqlite3_bind_text(stmt, k, text.data(), static_cast<int>(text.size()), SQLITE_TRANSIENT);
    }
    if (rc != SQLITE_OK) return SqliteError(db, rc, absl::StrCat("binding ", name));
  }
  for (size_t i = 0; i < used.size(); ++i) {
    if (!used[i]) {
      return absl::InvalidArgumentError(
          absl::StrCat("SQL parameter $", i + 1, " is given but not used in: ", sql));
    }
  }
  return absl::OkStatus();
}

SqlValue ColumnValue(sqlite3_stmt* stmt, int column) {
  switch (sqlite3_column_type(stmt, column)) {
    case SQLITE_INTEGER:
      return SqlValue(static_cast<int64_t>(sqlite3_column_int64(stmt, column)));
    case SQLITE_FLOAT:
      return SqlValue(sqlite3_column_double(stmt, column));
    case SQLITE_NULL:
      return SqlValue();
    default: {
      const auto* text = reinterpret_cast<const char*>(sqlite3_column_blob(stmt, column));
      const int size = sqlite3_column_bytes(stmt, column);
      return SqlValue(std::string(text ? text : "", static_cast<size_t>(size)));
    }
  }
}

}  // namespace

// The executor handed to a transaction's fn: runs statements on the
// connection whose mutex Transaction already holds.
class SqliteDatabase::LockedExecutor : public SqlExecutor {
 public:
  explicit LockedExecutor(SqliteDatabase* db) : db_(db) {}
  SqlDialect dialect() const override { return SqlDialect::kSqlite; }
  absl::StatusOr<SqlRows> Exec(const std::string& sql,
                               const std::vector<SqlValue>& params) override {
    return db_->ExecLocked(sql, params);
  }

 private:
  SqliteDatabase* db_;
};

absl::StatusOr<std::unique_ptr<SqliteDatabase>> SqliteDatabase::Open(const std::string& path) {
  sqlite3* db = nullptr;
  const int rc = sqlite3_open_v2(
      path.c_str(), &db, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_NOMUTEX, nullptr);
  if (rc != SQLITE_OK) {
    absl::Status status = SqliteError(db, rc, absl::StrCat("opening SQLite database ", path));
    sqlite3_close(db);
    return status;
  }
  sqlite3_busy_timeout(db, kBusyTimeoutMs);
  std::unique_ptr<SqliteDatabase> database(new SqliteDatabase(db, path));
  ASSIGN_OR_RETURN(SqlRows mode, database->Exec("PRAGMA journal_mode = WAL"));
  if (mode.empty() || absl::AsciiStrToLower(mode[0][0].AsString()) != "wal") {
    return absl::FailedPreconditionError(
        absl::StrCat("SQLite database ", path, ": cannot switch to WAL journal mode (got '",
                     mode.empty() ? "" : mode[0][0].AsString(), "')"));
  }
  RETURN_IF_ERROR(database->Exec("PRAGMA foreign_keys = ON").status());
  RETURN_IF_ERROR(database->Exec("PRAGMA synchronous = NORMAL").status());
  return database;
}

SqliteDatabase::~SqliteDatabase() { sqlite3_close(db_); }

absl::StatusOr<SqlRows> SqliteDatabase::Exec(const std::string& sql,
                                             const std::vector<SqlValue>& params) {
  std::lock_guard<std::mutex> lock(mutex_);
  return ExecLocked(sql, params);
}

absl::StatusOr<SqlRows> SqliteDatabase::ExecLocked(const std::string& sql,
                                                   const std::vector<SqlValue>& params) {
  sqlite3_stmt* raw = nullptr;
  const char* tail = nullptr;
  int rc = sqlite3_prepare_v2(db_, sql.c_str(), static_cast<int>(sql.size()), &raw, &tail);
  Statement stmt(raw);
  if (rc != SQLITE_OK) return SqliteError(db_, rc, absl::StrCat("preparing: ", sql));
  if (tail != nullptr && !absl::StripAsciiWhitespace(tail).empty()) {
    return absl::InvalidArgumentError(absl::StrCat("one statement per Exec, got: ", sql));
  }
  if (stmt == nullptr) return SqlRows{};  // Only whitespace or a comment.
  RETURN_IF_ERROR(BindParams(db_, stmt.get(), params, sql));

  SqlRows rows;
  const int columns = sqlite3_column_count(stmt.get());
  while ((rc = sqlite3_step(stmt.get())) == SQLITE_ROW) {
    SqlRow row;
    row.reserve(columns);
    for (int c = 0; c < columns; ++c) row.push_back(ColumnValue(stmt.get(), c));
    rows.push_back(std::move(row));
  }
  if (rc != SQLITE_DONE) return SqliteError(db_, rc, absl::StrCat("running: ", sql));
  return rows;
}

absl::Status SqliteDatabase::Transaction(const TransactionFn& fn) {
  std::lock_guard<std::mutex> lock(mutex_);
  absl::Status status;
  for (int attempt = 1; attempt <= kSqliteTransactionTries; ++attempt) {
    status = TransactionOnce(fn);
    if (status.code() != absl::StatusCode::kAborted) return status;
    std::this_thread::sleep_for(std::chrono::milliseconds(5 * attempt));
  }
  return StatusWithContext(status, absl::StrCat("SQLite database ", path_, ": gave up after ",
                                                kSqliteTransactionTries, " tries"));
}

absl::Status SqliteDatabase::TransactionOnce(const TransactionFn& fn) {
  RETURN_IF_ERROR(ExecLocked("BEGIN IMMEDIATE", {}).status());
  LockedExecutor executor(this);
  absl::Status status = fn(executor);
  if (status.ok()) status = ExecLocked("COMMIT", {}).status();
  if (!status.ok() && !sqlite3_get_autocommit(db_)) {
    // Still inside the transaction (fn failed, or COMMIT was busy).
    ExecLocked("ROLLBACK", {}).IgnoreError();
  }
  return status;
}

}  // namespace pf
