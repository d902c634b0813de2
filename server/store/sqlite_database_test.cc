// SqliteDatabase: $N binding, value types, transactions (commit, rollback,
// retry) and two connections on one file.
#include "server/store/sqlite_database.h"

#include <gtest/gtest.h>

#include <limits>
#include <memory>
#include <string>

#include "tests/test_util.h"

namespace pf {
namespace {

std::unique_ptr<SqliteDatabase> OpenFresh(std::string* path = nullptr) {
  const std::string file = testing::MakeTempDir("sqlite_database_test") + "/test.db";
  if (path != nullptr) *path = file;
  absl::StatusOr<std::unique_ptr<SqliteDatabase>> db = SqliteDatabase::Open(file);
  EXPECT_TRUE(db.ok()) << db.status();
  return db.ok() ? *std::move(db) : nullptr;
}

TEST(SqliteDatabase, OpensInWalModeWithForeignKeys) {
  std::unique_ptr<SqliteDatabase> db = OpenFresh();
  ASSERT_NE(db, nullptr);
  EXPECT_EQ(db->dialect(), SqlDialect::kSqlite);
  EXPECT_EQ(db->Exec("PRAGMA journal_mode")->at(0).at(0).AsString(), "wal");
  EXPECT_EQ(db->Exec("PRAGMA foreign_keys")->at(0).at(0).AsInt(), 1);
}

TEST(SqliteDatabase, BindsDollarParametersByNumberAndRoundTripsTypes) {
  std::unique_ptr<SqliteDatabase> db = OpenFresh();
  ASSERT_TRUE(db->Exec("CREATE TABLE t (a BIGINT, b DOUBLE PRECISION, c TEXT, d TEXT)").ok());
  const int64_t big = std::numeric_limits<int64_t>::max();
  // Out of order and reused placeholders bind by number, not position.
  ASSERT_TRUE(db->Exec("INSERT INTO t (c, a, b, d) VALUES ($3, $1, $2, $4)",
                       {big, 0.25, "it's \"text\"", SqlValue()})
                  .ok());
  absl::StatusOr<SqlRows> rows =
      db->Exec("SELECT a, b, c, d FROM t WHERE a = $1 AND $1 > 0", {big});
  ASSERT_TRUE(rows.ok()) << rows.status();
  ASSERT_EQ(rows->size(), 1u);
  const SqlRow& row = rows->at(0);
  EXPECT_TRUE(row[0].is_int());
  EXPECT_EQ(row[0].AsInt(), big);
  EXPECT_DOUBLE_EQ(row[1].AsDouble(), 0.25);
  EXPECT_EQ(row[2].AsString(), "it's \"text\"");
  EXPECT_TRUE(row[3].is_null());
  EXPECT_EQ(row[3].AsString(), "");
}

TEST(SqlValue, ConvertsTextCellsAsATextProtocolWouldReturnThem) {
  EXPECT_EQ(SqlValue("42").AsInt(), 42);
  EXPECT_DOUBLE_EQ(SqlValue("0.5").AsDouble(), 0.5);
  EXPECT_EQ(SqlValue(int64_t{7}).AsString(), "7");
  EXPECT_EQ(SqlValue().AsInt(), 0);
}

TEST(SqliteDatabase, RejectsMissingUnusedAndMultipleStatements) {
  std::unique_ptr<SqliteDatabase> db = OpenFresh();
  EXPECT_EQ(db->Exec("SELECT $1, $2", {1}).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(db->Exec("SELECT $1", {1, 2}).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(db->Exec("SELECT ?", {1}).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(db->Exec("SELECT 1; SELECT 2").status().code(), absl::StatusCode::kInvalidArgument);
  absl::Status syntax = db->Exec("SELEKT 1").status();
  EXPECT_EQ(syntax.code(), absl::StatusCode::kInternal);
  EXPECT_NE(std::string(syntax.message()).find("SELEKT"), std::string::npos);
}

TEST(SqliteDatabase, TransactionCommitsOrRollsBack) {
  std::unique_ptr<SqliteDatabase> db = OpenFresh();
  ASSERT_TRUE(db->Exec("CREATE TABLE t (v INTEGER)").ok());
  ASSERT_TRUE(db->Transaction([](SqlExecutor& tx) {
                  return tx.Exec("INSERT INTO t (v) VALUES (1)").status();
                }).ok());
  absl::Status failed = db->Transaction([](SqlExecutor& tx) {
    EXPECT_TRUE(tx.Exec("INSERT INTO t (v) VALUES (2)").ok());
    return absl::NotFoundError("stop");
  });
  EXPECT_EQ(failed.code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(db->Exec("SELECT SUM(v), COUNT(*) FROM t")->at(0).at(0).AsInt(), 1);
}

TEST(SqliteDatabase, TransactionRetriesOnConflict) {
  std::unique_ptr<SqliteDatabase> db = OpenFresh();
  ASSERT_TRUE(db->Exec("CREATE TABLE t (v INTEGER)").ok());
  int runs = 0;
  ASSERT_TRUE(db->Transaction([&](SqlExecutor& tx) -> absl::Status {
                  ++runs;
                  absl::Status status = tx.Exec("INSERT INTO t (v) VALUES ($1)", {runs}).status();
                  if (!status.ok()) return status;
                  return runs == 1 ? absl::AbortedError("conflict") : absl::OkStatus();
                }).ok());
  EXPECT_EQ(runs, 2);
  // Only the second run's row is committed.
  SqlRows rows = *db->Exec("SELECT v FROM t");
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0][0].AsInt(), 2);
}

TEST(SqliteDatabase, TwoConnectionsShareTheFile) {
  std::string path;
  std::unique_ptr<SqliteDatabase> a = OpenFresh(&path);
  absl::StatusOr<std::unique_ptr<SqliteDatabase>> b = SqliteDatabase::Open(path);
  ASSERT_TRUE(b.ok()) << b.status();
  ASSERT_TRUE(a->Exec("CREATE TABLE t (v INTEGER)").ok());
  ASSERT_TRUE((*b)->Transaction([](SqlExecutor& tx) {
                    return tx.Exec("INSERT INTO t (v) VALUES (5)").status();
                  })
                  .ok());
  EXPECT_EQ(a->Exec("SELECT v FROM t")->at(0).at(0).AsInt(), 5);
}

TEST(SqliteDatabase, OpenFailsNamingThePath) {
  absl::StatusOr<std::unique_ptr<SqliteDatabase>> db =
      SqliteDatabase::Open("/nonexistent-dir/sub/jobs.db");
  EXPECT_FALSE(db.ok());
  EXPECT_NE(std::string(db.status().message()).find("/nonexistent-dir/sub/jobs.db"),
            std::string::npos);
}

}  // namespace
}  // namespace pf
