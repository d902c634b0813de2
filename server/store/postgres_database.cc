// PostgresDatabase: libpq's extended protocol (PQexecParams, one statement
// per call, $N placeholders as PostgreSQL itself numbers them), SQLSTATEs
// mapped to status codes, transactions retried on conflicts.
//
// Why libpq and not libpqxx: the store needs exactly four things (run a
// statement with text parameters, read text cells, read the SQLSTATE,
// reset a dropped connection), which libpq offers as plain C calls that
// return error values; libpqxx would add an exception boundary around every
// call and a C++ ABI tied to one Debian version, for nothing the store uses.
#include "server/store/postgres_database.h"

#include <libpq-fe.h>

#include <charconv>
#include <chrono>
#include <memory>
#include <random>
#include <thread>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_replace.h"
#include "common/status_macros.h"

namespace pf {
namespace {

// How often Transaction starts over after a conflict before giving up.
constexpr int kPostgresTransactionTries = 12;

// Type OIDs (pg_type.h) of the parameters we send and the cells we read.
constexpr Oid kBoolOid = 16;
constexpr Oid kInt8Oid = 20;
constexpr Oid kInt2Oid = 21;
constexpr Oid kInt4Oid = 23;
constexpr Oid kOidOid = 26;
constexpr Oid kFloat4Oid = 700;
constexpr Oid kFloat8Oid = 701;

// Frees a PGresult when it goes out of scope.
struct ResultCloser {
  void operator()(PGresult* result) const { PQclear(result); }
};
using Result = std::unique_ptr<PGresult, ResultCloser>;

// Maps a SQLSTATE to the status code callers act on: conflicts another try
// may resolve are kAborted (SqlDatabase::Transaction retries them), a lost
// or shutting-down server is kUnavailable, anything else (a bug in our SQL,
// a violated constraint) kInternal.
absl::StatusCode CodeForSqlState(const std::string& state) {
  if (state == "40001" ||  // serialization_failure
      state == "40P01" ||  // deadlock_detected
      state == "23505" ||  // unique_violation: two transactions inserted the same key
      state == "55P03") {  // lock_not_available
    return absl::StatusCode::kAborted;
  }
  if (absl::StartsWith(state, "08") ||                             // connection_exception
      state == "57P01" || state == "57P02" || state == "57P03") {  // server shutting down/starting
    return absl::StatusCode::kUnavailable;
  }
  return absl::StatusCode::kInternal;
}

// Formats a double so that PostgreSQL's float8 reads back the same value.
std::string DoubleText(double value) {
  char text[64];
  const std::to_chars_result end = std::to_chars(text, text + sizeof(text), value);
  return std::string(text, end.ptr);
}

// Reads one result cell as the SqlValue its column type calls for.
SqlValue CellValue(const PGresult* result, int row, int column) {
  if (PQgetisnull(result, row, column)) return SqlValue();
  const std::string text(PQgetvalue(result, row, column),
                         static_cast<size_t>(PQgetlength(result, row, column)));
  switch (PQftype(result, column)) {
    case kInt2Oid:
    case kInt4Oid:
    case kInt8Oid:
    case kOidOid: {
      int64_t value = 0;
      if (absl::SimpleAtoi(text, &value)) return SqlValue(value);
      break;
    }
    case kFloat4Oid:
    case kFloat8Oid: {
      double value = 0;
      if (absl::SimpleAtod(text, &value)) return SqlValue(value);
      break;
    }
    case kBoolOid:
      return SqlValue(int64_t{text == "t" ? 1 : 0});
    default:
      break;
  }
  return SqlValue(text);
}

// Libpq prints server notices ("relation already exists, skipping") to
// stderr by default; the store has nothing to learn from them.
void IgnoreNotice(void* /*arg*/, const char* /*message*/) {}

// Replaces the value of every "password=" (key=value form or URI query
// parameter) in `text` with "***".
void RedactPasswordParameters(std::string& text) {
  size_t pos = 0;
  while (true) {
    const std::string lower = absl::AsciiStrToLower(text);
    pos = lower.find("password=", pos);
    if (pos == std::string::npos) return;
    const size_t begin = pos + std::string("password=").size();
    size_t end = begin;
    if (end < text.size() && text[end] == '\'') {  // Quoted key=value.
      ++end;
      while (end < text.size() && text[end] != '\'') end += text[end] == '\\' ? 2 : 1;
      end = std::min(end + 1, text.size());
    } else {
      while (end < text.size() && text[end] != '&' && !absl::ascii_isspace(text[end])) ++end;
    }
    text.replace(begin, end - begin, "***");
    pos = begin + 3;
  }
}

}  // namespace

std::string RedactPostgresConnection(const std::string& connection) {
  std::string text = connection;
  const size_t scheme_end = text.find("://");
  if (scheme_end != std::string::npos) {
    // postgresql://user:password@host...: the password is between the first
    // ':' and the last '@' of the authority.
    const size_t start = scheme_end + 3;
    const size_t authority_end = text.find_first_of("/?", start);
    size_t at =
        text.rfind('@', authority_end == std::string::npos ? std::string::npos : authority_end);
    if (at == std::string::npos || at < start) at = text.find('@', start);  // '/' in a password.
    if (at != std::string::npos) {
      const size_t colon = text.find(':', start);
      if (colon != std::string::npos && colon < at) text.replace(colon + 1, at - colon - 1, "***");
    }
  }
  RedactPasswordParameters(text);
  return text;
}

// The executor handed to a transaction's fn: runs statements on the
// connection whose mutex Transaction already holds.
class PostgresDatabase::LockedExecutor : public SqlExecutor {
 public:
  explicit LockedExecutor(PostgresDatabase* db) : db_(db) {}
  SqlDialect dialect() const override { return SqlDialect::kPostgres; }
  absl::StatusOr<SqlRows> Exec(const std::string& sql,
                               const std::vector<SqlValue>& params) override {
    return db_->ExecLocked(sql, params);
  }

 private:
  PostgresDatabase* db_;
};

absl::StatusOr<std::unique_ptr<PostgresDatabase>> PostgresDatabase::Open(
    const std::string& connection) {
  const std::string redacted = RedactPostgresConnection(connection);
  char* parse_error = nullptr;
  PQconninfoOption* options = PQconninfoParse(connection.c_str(), &parse_error);
  if (options == nullptr) {
    // libpq quotes the URI it could not parse, password included.
    const std::string why = absl::StrReplaceAll(
        absl::StripAsciiWhitespace(parse_error != nullptr ? parse_error : "out of memory"),
        {{connection, redacted}});
    PQfreemem(parse_error);
    return absl::InvalidArgumentError(
        absl::StrCat("PostgreSQL connection '", redacted, "': ", why));
  }
  PQconninfoFree(options);

  // Defaults the connection string may override (it is expanded in place
  // of "dbname", and later entries win): give up on an unreachable host
  // after 10 s instead of the OS's minutes, and name ourselves in
  // pg_stat_activity. PQreset reuses these.
  const char* const keywords[] = {"connect_timeout", "application_name", "dbname", nullptr};
  const char* const values[] = {"10", "pointforward", connection.c_str(), nullptr};
  PGconn* conn = PQconnectdbParams(keywords, values, /*expand_dbname=*/1);
  if (conn == nullptr) {
    return absl::ResourceExhaustedError(
        absl::StrCat("PostgreSQL connection '", redacted, "': out of memory"));
  }
  if (PQstatus(conn) != CONNECTION_OK) {
    const std::string why = absl::StrReplaceAll(absl::StripAsciiWhitespace(PQerrorMessage(conn)),
                                                {{connection, redacted}});
    PQfinish(conn);
    return absl::UnavailableError(
        absl::StrCat("PostgreSQL connection '", redacted, "' failed: ", why));
  }
  PQsetNoticeProcessor(conn, IgnoreNotice, nullptr);
  return std::unique_ptr<PostgresDatabase>(new PostgresDatabase(conn, redacted));
}

PostgresDatabase::~PostgresDatabase() { PQfinish(conn_); }

bool PostgresDatabase::ConnectionLost() const { return PQstatus(conn_) != CONNECTION_OK; }

absl::Status PostgresDatabase::Reconnect() {
  PQreset(conn_);
  if (PQstatus(conn_) != CONNECTION_OK) {
    return absl::UnavailableError(absl::StrCat(
        "PostgreSQL connection '", redacted_,
        "' lost and reconnecting failed: ", absl::StripAsciiWhitespace(PQerrorMessage(conn_))));
  }
  PQsetNoticeProcessor(conn_, IgnoreNotice, nullptr);
  return absl::OkStatus();
}

absl::StatusOr<SqlRows> PostgresDatabase::Exec(const std::string& sql,
                                               const std::vector<SqlValue>& params) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (ConnectionLost()) RETURN_IF_ERROR(Reconnect());
  absl::StatusOr<SqlRows> rows = ExecLocked(sql, params);
  if (!rows.ok() && ConnectionLost()) {
    // The server went away (restarted) since the last call. A statement
    // outside a transaction either committed alone or not at all; the store
    // runs only reads this way, so running it again is safe.
    RETURN_IF_ERROR(Reconnect());
    rows = ExecLocked(sql, params);
  }
  return rows;
}

absl::StatusOr<SqlRows> PostgresDatabase::ExecLocked(const std::string& sql,
                                                     const std::vector<SqlValue>& params) {
  // Integers and doubles go as text with their type, so that PostgreSQL
  // reads "$2" in "SELECT ..., $2 FROM" as a number; text goes untyped
  // (OID 0) and takes the type its context needs.
  std::vector<std::string> texts(params.size());
  std::vector<const char*> values(params.size(), nullptr);
  std::vector<Oid> types(params.size(), 0);
  for (size_t i = 0; i < params.size(); ++i) {
    const SqlValue& value = params[i];
    if (value.is_null()) continue;
    if (value.is_int()) {
      types[i] = kInt8Oid;
      texts[i] = absl::StrCat(value.AsInt());
    } else if (value.is_double()) {
      types[i] = kFloat8Oid;
      texts[i] = DoubleText(value.AsDouble());
    } else {
      texts[i] = value.AsString();
    }
    values[i] = texts[i].c_str();
  }
  Result result(PQexecParams(conn_, sql.c_str(), static_cast<int>(params.size()), types.data(),
                             values.data(), /*paramLengths=*/nullptr, /*paramFormats=*/nullptr,
                             /*resultFormat=*/0));
  const ExecStatusType status = result ? PQresultStatus(result.get()) : PGRES_FATAL_ERROR;
  if (status != PGRES_COMMAND_OK && status != PGRES_TUPLES_OK) {
    const char* state = result ? PQresultErrorField(result.get(), PG_DIAG_SQLSTATE) : nullptr;
    const std::string message(absl::StripAsciiWhitespace(result ? PQresultErrorMessage(result.get())
                                                                : PQerrorMessage(conn_)));
    const absl::StatusCode code =
        state != nullptr
            ? CodeForSqlState(state)
            : (ConnectionLost() ? absl::StatusCode::kUnavailable : absl::StatusCode::kInternal);
    return absl::Status(
        code, absl::StrCat("PostgreSQL '", redacted_, "': running: ", sql, ": ", message,
                           state ? absl::StrCat(" (SQLSTATE ", state, ")") : std::string()));
  }
  SqlRows rows;
  const int row_count = PQntuples(result.get());
  const int columns = PQnfields(result.get());
  rows.reserve(row_count);
  for (int r = 0; r < row_count; ++r) {
    SqlRow row;
    row.reserve(columns);
    for (int c = 0; c < columns; ++c) row.push_back(CellValue(result.get(), r, c));
    rows.push_back(std::move(row));
  }
  return rows;
}

absl::Status PostgresDatabase::Transaction(const TransactionFn& fn) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (ConnectionLost()) RETURN_IF_ERROR(Reconnect());
  std::minstd_rand jitter(std::random_device{}());
  bool reconnected = false;
  absl::Status status;
  for (int attempt = 1; attempt <= kPostgresTransactionTries; ++attempt) {
    bool in_commit = false;
    status = TransactionOnce(fn, &in_commit);
    if (status.ok()) return status;
    if (ConnectionLost()) {
      if (in_commit) {
        return absl::UnavailableError(absl::StrCat(
            "PostgreSQL '", redacted_,
            "': the connection was lost during COMMIT, so whether the transaction committed is "
            "unknown: ",
            status.message()));
      }
      // Nothing was committed: run it again once on a fresh connection.
      if (reconnected) return status;
      reconnected = true;
      RETURN_IF_ERROR(Reconnect());
      continue;
    }
    if (status.code() != absl::StatusCode::kAborted) return status;
    // Two transactions wanted the same rows: back off a little, randomly,
    // so that they do not collide again in step.
    std::this_thread::sleep_for(
        std::chrono::microseconds(std::uniform_int_distribution<int>(500, 2000 * attempt)(jitter)));
  }
  return StatusWithContext(status, absl::StrCat("PostgreSQL '", redacted_, "': gave up after ",
                                                kPostgresTransactionTries, " tries"));
}

absl::Status PostgresDatabase::TransactionOnce(const TransactionFn& fn, bool* in_commit) {
  // READ COMMITTED is enough: every read-then-write in SqlJobStore locks
  // the rows it is about to change (SELECT ... FOR UPDATE, or FOR UPDATE
  // SKIP LOCKED when leasing), so a second transaction waits for the first
  // and then reads the committed row. Inserts of the same key by two
  // transactions end in a unique violation, which is retried, and the retry
  // sees the winner's row. SERIALIZABLE would only add aborts to retry.
  RETURN_IF_ERROR(ExecLocked("BEGIN ISOLATION LEVEL READ COMMITTED", {}).status());
  LockedExecutor executor(this);
  absl::Status status = fn(executor);
  if (status.ok() && PQtransactionStatus(conn_) == PQTRANS_INERROR) {
    // fn ignored a failed statement: COMMIT would silently roll back.
    status = absl::InternalError(absl::StrCat(
        "PostgreSQL '", redacted_, "': a statement in the transaction failed unnoticed"));
  }
  if (status.ok()) {
    *in_commit = true;
    status = ExecLocked("COMMIT", {}).status();
    if (status.ok()) return status;
    if (!ConnectionLost()) *in_commit = false;  // COMMIT refused (e.g. 40001): rolled back.
  }
  if (!ConnectionLost() && PQtransactionStatus(conn_) != PQTRANS_IDLE) {
    ExecLocked("ROLLBACK", {}).IgnoreError();
  }
  return status;
}

}  // namespace pf
