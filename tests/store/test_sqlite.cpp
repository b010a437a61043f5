// The store's SQLite wrapper: what each access may do to the file, the binds
// and column reads, transactions, and errors that name the database and keep
// SQLite's reason. The files are checked with the sqlite3 program.
#include "hgtest/paths.h"
#include "hullgauge/store/sqlite.h"

#include <chrono>
#include <gtest/gtest.h>

namespace hg::store::sqlite {
namespace {

std::string sqlite3Cli(const std::filesystem::path& file, const std::string& query)
{
    return hgtest::run("sqlite3 " + file.string() + " \"" + query + "\"").out;
}

TEST(Sqlite, CreateMakesTheFileWriteAndReadNeedOne)
{
    hgtest::TempDir dir;
    const auto file = dir / "t.db";
    EXPECT_THROW(open(file, Access::Write, "t"), Error);
    EXPECT_THROW(open(file, Access::Read, "t"), Error);
    EXPECT_FALSE(std::filesystem::exists(file)) << "neither creates the database";
    open(file, Access::Create, "t").exec("CREATE TABLE t (a INTEGER)");
    open(file, Access::Write, "t").exec("INSERT INTO t VALUES (1)");
    EXPECT_EQ(sqlite3Cli(file, "SELECT a FROM t"), "1\n");
}

TEST(Sqlite, AReadConnectionNeverWrites)
{
    hgtest::TempDir dir;
    const auto file = dir / "t.db";
    open(file, Access::Create, "t").exec("CREATE TABLE t (a INTEGER); INSERT INTO t VALUES (7)");
    const auto db = open(file, Access::Read, "result store " + file.string());
    auto select = db.prepare("SELECT a FROM t");
    ASSERT_TRUE(select.step());
    EXPECT_EQ(select.integer(0), 7);
    try {
        db.exec("INSERT INTO t VALUES (8)");
        FAIL() << "a read-only connection wrote";
    } catch (const Error& e) {
        EXPECT_EQ(std::string(e.what()), "result store " + file.string() + ": " + e.reason());
        EXPECT_NE(e.reason().find("readonly"), std::string::npos) << e.reason();
    }
    EXPECT_EQ(sqlite3Cli(file, "SELECT count(*) FROM t"), "1\n");
}

TEST(Sqlite, BindsAndReadsBackEveryKindOfColumn)
{
    hgtest::TempDir dir;
    const auto db = open(dir / "t.db", Access::Create, "t");
    db.exec("CREATE TABLE t (i INTEGER, s TEXT, n INTEGER)");
    const std::string text = "O'Neil \"ø\" %_";
    db.prepare("INSERT INTO t VALUES (?, ?, ?)").bind(1, std::int64_t{1} << 40).bind(2, text).bindNull(3).step();
    EXPECT_EQ(db.lastInsertRowId(), 1);
    auto select = db.prepare("SELECT i, s, n FROM t");
    ASSERT_TRUE(select.step());
    EXPECT_EQ(select.int64(0), std::int64_t{1} << 40);
    EXPECT_EQ(select.text(1), text);
    EXPECT_TRUE(select.isNull(2));
    EXPECT_FALSE(select.isNull(0));
    EXPECT_EQ(select.text(2), "") << "NULL reads as no text";
    EXPECT_FALSE(select.step()) << "one row";
}

TEST(Sqlite, AStatementRunsAgainWithNewBindingsAfterAReset)
{
    hgtest::TempDir dir;
    const auto db = open(dir / "t.db", Access::Create, "t");
    db.exec("CREATE TABLE t (a INTEGER)");
    auto insert = db.prepare("INSERT INTO t VALUES (?)");
    for (std::int64_t a : {3, 5, 8}) {
        insert.bind(1, a).step();
        insert.reset();
    }
    auto sum = db.prepare("SELECT sum(a), count(*) FROM t");
    ASSERT_TRUE(sum.step());
    EXPECT_EQ(sum.int64(0), 16);
    EXPECT_EQ(sum.int64(1), 3);
}

TEST(Sqlite, ATransactionLeftWithoutCommitLeavesNothing)
{
    hgtest::TempDir dir;
    const auto file = dir / "t.db";
    const auto db = open(file, Access::Create, "t");
    db.exec("CREATE TABLE t (a INTEGER NOT NULL)");
    EXPECT_THROW(
        {
            Transaction transaction(db);
            db.exec("INSERT INTO t VALUES (1)");
            db.prepare("INSERT INTO t VALUES (?)").bindNull(1).step(); // NOT NULL: throws
            transaction.commit();
        },
        Error);
    EXPECT_EQ(sqlite3Cli(file, "SELECT count(*) FROM t"), "0\n");
    {
        Transaction transaction(db);
        db.exec("INSERT INTO t VALUES (2)");
        transaction.commit();
    }
    EXPECT_EQ(sqlite3Cli(file, "SELECT a FROM t"), "2\n");
}

TEST(Sqlite, ALockHeldLongerThanTheBusyTimeoutIsAnError)
{
    hgtest::TempDir dir;
    const auto file = dir / "t.db";
    const auto writer = open(file, Access::Create, "writer");
    writer.exec("CREATE TABLE t (a INTEGER)");
    const auto other = open(file, Access::Write, "other");
    Transaction held(writer);
    const auto start = std::chrono::steady_clock::now();
    EXPECT_THROW(other.exec("INSERT INTO t VALUES (1)"), Error);
    // It waited for the lock (the busy timeout, 2 s) before giving up.
    EXPECT_GE(std::chrono::steady_clock::now() - start, std::chrono::milliseconds(1500));
}

TEST(Sqlite, AFileThatIsNoDatabaseIsNamedAtTheFirstStatement)
{
    hgtest::TempDir dir;
    const auto file = hgtest::writeFile(dir / "notes.txt", std::string(200, 'x'));
    const auto db = open(file, Access::Read, "result store " + file.string());
    try {
        db.prepare("SELECT 1 FROM sqlite_master");
        FAIL() << "a text file was read as a database";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find(file.string()), std::string::npos) << e.what();
    }
}

} // namespace
} // namespace hg::store::sqlite
