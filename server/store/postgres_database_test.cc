// PostgresDatabase on a real throwaway server: typed parameters and cells,
// SQLSTATEs mapped to codes, transactions (commit, rollback, retry of a
// real unique-key race), reconnecting after a server restart, migrations
// from many connections at once, and password redaction.
#include "server/store/postgres_database.h"

#include <gtest/gtest.h>

#include <atomic>
#include <future>
#include <limits>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "server/store/sql_job_store.h"
#include "tests/postgres_server.h"

namespace pf {
namespace {

// Skips the test when no PostgreSQL can run here.
#define PF_REQUIRE_POSTGRES()                                                       \
  if (std::optional<std::string> why = testing::PostgresServer::WhyUnavailable()) { \
    GTEST_SKIP() << *why;                                                           \
  }

// Returns the URL of a new database on the shared test server.
std::string FreshDatabaseUrl() {
  absl::StatusOr<testing::PostgresServer*> server = testing::PostgresServer::Shared();
  EXPECT_TRUE(server.ok()) << server.status();
  if (!server.ok()) return "";
  absl::StatusOr<std::string> url = (*server)->CreateFreshDatabase();
  EXPECT_TRUE(url.ok()) << url.status();
  return url.ok() ? *url : "";
}

std::unique_ptr<PostgresDatabase> OpenOrNull(const std::string& url) {
  absl::StatusOr<std::unique_ptr<PostgresDatabase>> db = PostgresDatabase::Open(url);
  EXPECT_TRUE(db.ok()) << db.status();
  return db.ok() ? *std::move(db) : nullptr;
}

TEST(RedactPostgresConnection, HidesPasswordsInEveryForm) {
  EXPECT_EQ(RedactPostgresConnection("postgresql://pf:s3cret@db:5432/jobs"),
            "postgresql://pf:***@db:5432/jobs");
  EXPECT_EQ(RedactPostgresConnection("postgres://pf:p@ss:w@db/jobs?sslmode=require"),
            "postgres://pf:***@db/jobs?sslmode=require");
  EXPECT_EQ(RedactPostgresConnection("postgresql://pf@db/jobs?password=s3cret&sslmode=disable"),
            "postgresql://pf@db/jobs?password=***&sslmode=disable");
  EXPECT_EQ(RedactPostgresConnection("host=db user=pf password='it\\'s x' dbname=jobs"),
            "host=db user=pf password=*** dbname=jobs");
  EXPECT_EQ(RedactPostgresConnection("host=db PASSWORD=x dbname=jobs"),
            "host=db PASSWORD=*** dbname=jobs");
  // Nothing to hide.
  EXPECT_EQ(RedactPostgresConnection("postgresql://pf@db:5432/jobs"),
            "postgresql://pf@db:5432/jobs");
  EXPECT_EQ(RedactPostgresConnection("postgresql:///jobs"), "postgresql:///jobs");
}

TEST(PostgresDatabase, RefusedConnectionIsUnavailableWithoutThePassword) {
  absl::StatusOr<std::unique_ptr<PostgresDatabase>> db =
      PostgresDatabase::Open("postgresql://pf:hunter2@127.0.0.1:1/jobs");
  EXPECT_EQ(db.status().code(), absl::StatusCode::kUnavailable);
  EXPECT_NE(std::string(db.status().message()).find("pf:***@127.0.0.1:1"), std::string::npos)
      << db.status();
  EXPECT_EQ(std::string(db.status().message()).find("hunter2"), std::string::npos);
}

TEST(PostgresDatabase, BindsParametersAndReadsTypedCells) {
  PF_REQUIRE_POSTGRES();
  std::unique_ptr<PostgresDatabase> db = OpenOrNull(FreshDatabaseUrl());
  ASSERT_NE(db, nullptr);
  EXPECT_EQ(db->dialect(), SqlDialect::kPostgres);
  ASSERT_TRUE(
      db->Exec("CREATE TABLE t (a BIGINT, b DOUBLE PRECISION, c TEXT, d TEXT, e INTEGER)").ok());
  const int64_t big = std::numeric_limits<int64_t>::min();
  const double third = 1.0 / 3.0;
  const std::string text = "it's \"text\" with $1 and ünïcode";
  // Out of order and reused placeholders bind by number; an int8 parameter
  // fits an INTEGER column.
  absl::StatusOr<SqlRows> inserted =
      db->Exec("INSERT INTO t (c, a, b, d, e) VALUES ($3, $1, $2, $4, $5)",
               {big, third, text, SqlValue(), 7});
  ASSERT_TRUE(inserted.ok()) << inserted.status();
  absl::StatusOr<SqlRows> rows = db->Exec("SELECT a, b, c, d, e, a = $1 FROM t", {big});
  ASSERT_TRUE(rows.ok()) << rows.status();
  ASSERT_EQ(rows->size(), 1u);
  const SqlRow& row = rows->at(0);
  EXPECT_TRUE(row[0].is_int());
  EXPECT_EQ(row[0].AsInt(), big);
  EXPECT_TRUE(row[1].is_double());
  EXPECT_EQ(row[1].AsDouble(), third);  // Exactly: the text form round-trips.
  EXPECT_TRUE(row[2].is_text());
  EXPECT_EQ(row[2].AsString(), text);
  EXPECT_TRUE(row[3].is_null());
  EXPECT_EQ(row[4].AsInt(), 7);
  EXPECT_EQ(row[5].AsInt(), 1);  // Booleans read as 0/1.
  // A typed parameter in a select list keeps its type.
  absl::StatusOr<SqlRows> echo = db->Exec("SELECT $1, $2", {int64_t{42}, 0.5});
  ASSERT_TRUE(echo.ok()) << echo.status();
  EXPECT_TRUE(echo->at(0)[0].is_int());
  EXPECT_EQ(echo->at(0)[0].AsInt(), 42);
  EXPECT_EQ(echo->at(0)[1].AsDouble(), 0.5);
  // Statements without rows return none.
  EXPECT_TRUE(db->Exec("UPDATE t SET e = 8")->empty());
}

TEST(PostgresDatabase, ConnectionStringOverridesOurDefaults) {
  PF_REQUIRE_POSTGRES();
  const std::string url = FreshDatabaseUrl();
  std::unique_ptr<PostgresDatabase> plain = OpenOrNull(url);
  std::unique_ptr<PostgresDatabase> named = OpenOrNull(url + "?application_name=mine");
  ASSERT_NE(plain, nullptr);
  ASSERT_NE(named, nullptr);
  constexpr char kQuery[] = "SELECT current_setting('application_name')";
  EXPECT_EQ(plain->Exec(kQuery)->at(0)[0].AsString(), "pointforward");
  EXPECT_EQ(named->Exec(kQuery)->at(0)[0].AsString(), "mine");
}

TEST(PostgresDatabase, ErrorsCarryTheSqlStateAndConflictsAreAborted) {
  PF_REQUIRE_POSTGRES();
  std::unique_ptr<PostgresDatabase> db = OpenOrNull(FreshDatabaseUrl());
  ASSERT_NE(db, nullptr);
  absl::Status syntax = db->Exec("SELEC 1").status();
  EXPECT_EQ(syntax.code(), absl::StatusCode::kInternal);
  EXPECT_NE(std::string(syntax.message()).find("SQLSTATE 42601"), std::string::npos) << syntax;
  EXPECT_NE(std::string(syntax.message()).find("SELEC 1"), std::string::npos) << syntax;

  ASSERT_TRUE(db->Exec("CREATE TABLE k (id TEXT PRIMARY KEY)").ok());
  ASSERT_TRUE(db->Exec("INSERT INTO k VALUES ($1)", {"a"}).ok());
  absl::Status duplicate = db->Exec("INSERT INTO k VALUES ($1)", {"a"}).status();
  EXPECT_EQ(duplicate.code(), absl::StatusCode::kAborted) << duplicate;
  EXPECT_NE(std::string(duplicate.message()).find("SQLSTATE 23505"), std::string::npos);
  // Several statements in one Exec are refused (extended protocol).
  EXPECT_FALSE(db->Exec("SELECT 1; SELECT 2").ok());
}

TEST(PostgresDatabase, TransactionCommitsOrRollsBackAsAWhole) {
  PF_REQUIRE_POSTGRES();
  std::unique_ptr<PostgresDatabase> db = OpenOrNull(FreshDatabaseUrl());
  ASSERT_NE(db, nullptr);
  ASSERT_TRUE(db->Exec("CREATE TABLE k (id TEXT PRIMARY KEY)").ok());
  absl::Status failed = db->Transaction([](SqlExecutor& tx) -> absl::Status {
    if (absl::Status s = tx.Exec("INSERT INTO k VALUES ('rolled back')").status(); !s.ok()) {
      return s;
    }
    return absl::NotFoundError("business rule");
  });
  EXPECT_EQ(failed.code(), absl::StatusCode::kNotFound);
  // A statement that failed inside fn and was ignored does not commit the rest.
  absl::Status ignored = db->Transaction([](SqlExecutor& tx) -> absl::Status {
    tx.Exec("INSERT INTO k VALUES ('lost')").IgnoreError();
    tx.Exec("SELEC 1").IgnoreError();
    return absl::OkStatus();
  });
  EXPECT_EQ(ignored.code(), absl::StatusCode::kInternal) << ignored;
  ASSERT_TRUE(db->Transaction([](SqlExecutor& tx) {
                  return tx.Exec("INSERT INTO k VALUES ('kept')").status();
                }).ok());
  absl::StatusOr<SqlRows> rows = db->Exec("SELECT id FROM k ORDER BY id");
  ASSERT_TRUE(rows.ok()) << rows.status();
  ASSERT_EQ(rows->size(), 1u);
  EXPECT_EQ(rows->at(0)[0].AsString(), "kept");
}

// Two connections insert the same key: the second blocks on the first's
// uncommitted row, fails with a unique violation once it commits, and its
// retry sees the row, which is how two servers creating one scene end up
// with one job.
TEST(PostgresDatabase, UniqueKeyRaceIsRetriedAndTheRetrySeesTheWinner) {
  PF_REQUIRE_POSTGRES();
  const std::string url = FreshDatabaseUrl();
  std::unique_ptr<PostgresDatabase> first = OpenOrNull(url);
  std::unique_ptr<PostgresDatabase> second = OpenOrNull(url);
  ASSERT_NE(first, nullptr);
  ASSERT_NE(second, nullptr);
  ASSERT_TRUE(first->Exec("CREATE TABLE k (id TEXT PRIMARY KEY, owner TEXT NOT NULL)").ok());

  std::promise<void> first_inserted;
  std::thread winner([&] {
    absl::Status status = first->Transaction([&](SqlExecutor& tx) -> absl::Status {
      absl::Status s = tx.Exec("INSERT INTO k VALUES ('scene', 'first')").status();
      first_inserted.set_value();
      // Hold the uncommitted row while the other connection tries.
      std::this_thread::sleep_for(std::chrono::milliseconds(300));
      return s;
    });
    EXPECT_TRUE(status.ok()) << status;
  });
  first_inserted.get_future().wait();

  int runs = 0;
  std::string owner;
  absl::Status status = second->Transaction([&](SqlExecutor& tx) -> absl::Status {
    ++runs;
    absl::StatusOr<SqlRows> found = tx.Exec("SELECT owner FROM k WHERE id = 'scene'");
    if (!found.ok()) return found.status();
    if (!found->empty()) {
      owner = found->at(0)[0].AsString();
      return absl::OkStatus();
    }
    owner = "second";
    return tx.Exec("INSERT INTO k VALUES ('scene', 'second')").status();
  });
  winner.join();
  EXPECT_TRUE(status.ok()) << status;
  EXPECT_EQ(runs, 2);
  EXPECT_EQ(owner, "first");
  EXPECT_EQ(second->Exec("SELECT COUNT(*) FROM k")->at(0)[0].AsInt(), 1);
}

TEST(PostgresDatabase, TransactionGivesUpAfterRepeatedAborts) {
  PF_REQUIRE_POSTGRES();
  std::unique_ptr<PostgresDatabase> db = OpenOrNull(FreshDatabaseUrl());
  ASSERT_NE(db, nullptr);
  int runs = 0;
  absl::Status status = db->Transaction([&](SqlExecutor&) -> absl::Status {
    ++runs;
    return runs < 3 ? absl::AbortedError("conflict") : absl::OkStatus();
  });
  EXPECT_TRUE(status.ok()) << status;
  EXPECT_EQ(runs, 3);
  runs = 0;
  status = db->Transaction([&](SqlExecutor&) -> absl::Status {
    ++runs;
    return absl::AbortedError("always");
  });
  EXPECT_EQ(status.code(), absl::StatusCode::kAborted);
  EXPECT_NE(std::string(status.message()).find("gave up after"), std::string::npos) << status;
  EXPECT_GT(runs, 3);
}

TEST(PostgresDatabase, ReconnectsAfterTheServerRestarts) {
  PF_REQUIRE_POSTGRES();
  // Its own server: restarting the shared one would disturb other tests.
  absl::StatusOr<std::unique_ptr<testing::PostgresServer>> server =
      testing::PostgresServer::Start();
  ASSERT_TRUE(server.ok()) << server.status();
  absl::StatusOr<std::string> url = (*server)->CreateDatabase("restart");
  ASSERT_TRUE(url.ok()) << url.status();
  std::unique_ptr<PostgresDatabase> db = OpenOrNull(*url);
  ASSERT_NE(db, nullptr);
  ASSERT_TRUE(db->Exec("CREATE TABLE k (id TEXT PRIMARY KEY)").ok());

  ASSERT_TRUE((*server)->Restart().ok());
  absl::StatusOr<SqlRows> rows = db->Exec("SELECT COUNT(*) FROM k");
  ASSERT_TRUE(rows.ok()) << rows.status();
  EXPECT_EQ(rows->at(0)[0].AsInt(), 0);

  ASSERT_TRUE((*server)->Restart().ok());
  absl::Status status = db->Transaction(
      [](SqlExecutor& tx) { return tx.Exec("INSERT INTO k VALUES ('after restart')").status(); });
  EXPECT_TRUE(status.ok()) << status;
  EXPECT_EQ(db->Exec("SELECT COUNT(*) FROM k")->at(0)[0].AsInt(), 1);

  // A server that stays down is UNAVAILABLE, naming the connection.
  ASSERT_TRUE((*server)->Stop().ok());
  absl::Status down = db->Exec("SELECT 1").status();
  EXPECT_EQ(down.code(), absl::StatusCode::kUnavailable) << down;
  EXPECT_NE(std::string(down.message()).find("127.0.0.1"), std::string::npos) << down;
}

TEST(PostgresDatabase, ServersStartingAtOnceApplyEachMigrationOnce) {
  PF_REQUIRE_POSTGRES();
  constexpr int kServers = 8;
  const std::string url = FreshDatabaseUrl();
  std::vector<std::unique_ptr<PostgresDatabase>> dbs;
  for (int i = 0; i < kServers; ++i) {
    dbs.push_back(OpenOrNull(url));
    ASSERT_NE(dbs.back(), nullptr);
  }
  std::atomic<int> applied{0};
  std::atomic<int> failures{0};
  std::vector<std::thread> threads;
  for (int i = 0; i < kServers; ++i) {
    threads.emplace_back([&, i] {
      absl::StatusOr<int> count = ApplyMigrations(*dbs[i]);
      if (count.ok()) {
        applied += *count;
      } else {
        ++failures;
        ADD_FAILURE() << count.status();
      }
    });
  }
  for (std::thread& thread : threads) thread.join();
  EXPECT_EQ(failures.load(), 0);
  EXPECT_EQ(applied.load(), LatestSchemaVersion());
  EXPECT_EQ(dbs[0]->Exec("SELECT COUNT(*) FROM schema_migrations")->at(0)[0].AsInt(),
            LatestSchemaVersion());
  EXPECT_EQ(*ApplyMigrations(*dbs[0]), 0);
}

}  // namespace
}  // namespace pf
