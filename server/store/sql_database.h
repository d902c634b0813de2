// A small abstract SQL connection: what SqlJobStore needs from a database,
// so that its logic is written once and runs on SQLite and PostgreSQL.
//
//   ASSIGN_OR_RETURN(SqlRows rows, db.Exec("SELECT id FROM jobs WHERE state = $1", {"QUEUED"}));
//   RETURN_IF_ERROR(db.Transaction([&](SqlExecutor& tx) -> absl::Status {
//     ASSIGN_OR_RETURN(SqlRows rows, tx.Exec("SELECT ..."));
//     return tx.Exec("UPDATE ...").status();
//   }));
//
// SQL text uses `$1, $2, ...` placeholders on both dialects; `params[i]`
// binds `$<i+1>`. Where the SQL differs, callers consult dialect().
#ifndef POINTFORWARD_SERVER_STORE_SQL_DATABASE_H_
#define POINTFORWARD_SERVER_STORE_SQL_DATABASE_H_

#include <cstdint>
#include <functional>
#include <string>
#include <variant>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace pf {

enum class SqlDialect { kSqlite, kPostgres };

// One parameter or result cell: NULL, a 64-bit integer, a double or text.
// The accessors convert, so a driver that returns every cell as text
// (libpq's text format) reads the same as one that returns typed cells.
class SqlValue {
 public:
  SqlValue() = default;  // NULL.
  SqlValue(std::nullptr_t) {}
  SqlValue(int value) : value_(int64_t{value}) {}
  SqlValue(int64_t value) : value_(value) {}
  SqlValue(double value) : value_(value) {}
  SqlValue(std::string value) : value_(std::move(value)) {}
  SqlValue(const char* value) : value_(std::string(value)) {}

  bool is_null() const { return std::holds_alternative<std::monostate>(value_); }
  bool is_int() const { return std::holds_alternative<int64_t>(value_); }
  bool is_double() const { return std::holds_alternative<double>(value_); }
  bool is_text() const { return std::holds_alternative<std::string>(value_); }

  // Returns the value as an integer: 0 for NULL, doubles truncated, text
  // parsed (0 if it is not a number).
  int64_t AsInt() const;
  // Returns the value as a double: 0 for NULL, text parsed.
  double AsDouble() const;
  // Returns the value as text: "" for NULL, numbers formatted.
  std::string AsString() const;

 private:
  std::variant<std::monostate, int64_t, double, std::string> value_;
};

using SqlRow = std::vector<SqlValue>;
using SqlRows = std::vector<SqlRow>;

// Runs statements: the database itself (each statement on its own) or an
// open transaction.
class SqlExecutor {
 public:
  virtual ~SqlExecutor() = default;

  virtual SqlDialect dialect() const = 0;

  // Runs one statement with `params` bound to $1, $2, ...; returns the rows
  // it produced (none for statements that produce none). Errors carry the
  // database's message; kAborted means a conflict with another connection
  // (busy database, serialisation failure, unique-key race) that retrying
  // the whole transaction may resolve.
  virtual absl::StatusOr<SqlRows> Exec(const std::string& sql,
                                       const std::vector<SqlValue>& params = {}) = 0;
};

class SqlDatabase : public SqlExecutor {
 public:
  using TransactionFn = std::function<absl::Status(SqlExecutor& tx)>;

  // Runs `fn` inside one transaction: commits when it returns OK, rolls back
  // otherwise and returns its status. When `fn` or the commit fails with
  // kAborted, rolls back and runs `fn` again (a bounded number of times), so
  // `fn` must only produce results through what it assigns on each run.
  // Business logic inside `fn` must not return kAborted itself.
  virtual absl::Status Transaction(const TransactionFn& fn) = 0;
};

}  // namespace pf

#endif  // POINTFORWARD_SERVER_STORE_SQL_DATABASE_H_
