// The audit trail (docs/audit.md, "The audit trail"): entries appended and
// selected by every filter, the table's refusal of an UPDATE or DELETE from
// any connection (checked with the sqlite3 program), the files it refuses to
// open, the watched files' state kept with their entry, and the CSV export
// against hand-written RFC 4180 text.
#include "hgtest/paths.h"
#include "hullgauge/store/audit_log.h"

#include <gtest/gtest.h>

namespace hg::store {
namespace {

/// 2026-05-28T20:26:40Z (`date -u -d @1780000000`).
constexpr std::int64_t kT0 = 1'780'000'000'000;

hgtest::RunResult sqlite3Cli(const std::filesystem::path& file, const std::string& sql)
{
    return hgtest::run("sqlite3 " + file.string() + " \"" + sql + "\"");
}

AuditEntry entry(std::int64_t atMs, std::string who, std::string action, std::string outcome = "done")
{
    AuditEntry e;
    e.atMs = atMs;
    e.who = std::move(who);
    e.role = "engineer";
    e.source = "hmi 127.0.0.1";
    e.action = std::move(action);
    e.object = "block";
    e.outcome = std::move(outcome);
    return e;
}

std::vector<std::int64_t> ids(const std::vector<AuditEntry>& entries)
{
    std::vector<std::int64_t> out;
    for (const auto& e : entries) out.push_back(e.id);
    return out;
}

/// Six entries, one second apart from kT0: ids 1..6.
///   1 anna  program.release      done
///   2 olga  program.add          refused
///   3 anna  user_x.add           done     (an `_` in the action)
///   4 anna  userAx.add           done     (what `user_` would match as a LIKE pattern)
///   5 hullgauged file.changed    done
///   6 anna  calibration.run      failed
void fill(AuditLog& log)
{
    const AuditEntry rows[] = {
        entry(kT0, "anna", "program.release"),           entry(kT0 + 1000, "olga", "program.add", "refused"),
        entry(kT0 + 2000, "anna", "user_x.add"),         entry(kT0 + 3000, "anna", "userAx.add"),
        entry(kT0 + 4000, "hullgauged", "file.changed"), entry(kT0 + 5000, "anna", "calibration.run", "failed")};
    std::int64_t expected = 1;
    for (const auto& row : rows) EXPECT_EQ(log.record(row), expected++);
}

TEST(AuditLog, RecordsEveryFieldAndSelectsNewestFirst)
{
    hgtest::TempDir dir;
    AuditLog log(dir / "sub" / "audit.sqlite");
    AuditEntry e = entry(kT0 + 250, "anna", "program.release");
    e.detail = "version 3";
    e.before = "revision: 2\n";
    e.after = "revision: 3\n";
    EXPECT_EQ(log.record(e), 1);
    EXPECT_EQ(log.record(entry(kT0 + 500, "olga", "sign-in", "refused")), 2);

    const auto all = log.select({});
    ASSERT_EQ(ids(all), (std::vector<std::int64_t>{2, 1}));
    const auto& first = all[1];
    EXPECT_EQ(first.atMs, kT0 + 250);
    EXPECT_EQ(first.who, "anna");
    EXPECT_EQ(first.role, "engineer");
    EXPECT_EQ(first.source, "hmi 127.0.0.1");
    EXPECT_EQ(first.action, "program.release");
    EXPECT_EQ(first.object, "block");
    EXPECT_EQ(first.outcome, "done");
    EXPECT_EQ(first.detail, "version 3");
    EXPECT_EQ(first.before, "revision: 2\n");
    EXPECT_EQ(first.after, "revision: 3\n");
    // The file itself, read by another program, holds the same.
    EXPECT_EQ(sqlite3Cli(log.file(), "SELECT who, action, outcome FROM audit ORDER BY id").out,
              "anna|program.release|done\nolga|sign-in|refused\n");
}

TEST(AuditLog, AnOutcomeOtherThanDoneRefusedOrFailedIsNotStored)
{
    hgtest::TempDir dir;
    AuditLog log(dir / "audit.sqlite");
    EXPECT_THROW(log.record(entry(kT0, "anna", "program.add", "maybe")), sqlite::Error);
    EXPECT_TRUE(log.select({}).empty());
}

TEST(AuditLog, SelectsByEveryFilter)
{
    hgtest::TempDir dir;
    AuditLog log(dir / "audit.sqlite");
    fill(log);
    const auto select = [&](auto&& set) {
        AuditQuery q;
        set(q);
        return ids(log.select(q));
    };
    using Ids = std::vector<std::int64_t>;
    // The window: at or after since, before until.
    EXPECT_EQ(select([](AuditQuery& q) { q.sinceMs = kT0 + 2000; }), (Ids{6, 5, 4, 3}));
    EXPECT_EQ(select([](AuditQuery& q) { q.untilMs = kT0 + 2000; }), (Ids{2, 1}));
    EXPECT_EQ(select([](AuditQuery& q) {
                  q.sinceMs = kT0 + 1000;
                  q.untilMs = kT0 + 3000;
              }),
              (Ids{3, 2}));
    EXPECT_EQ(select([](AuditQuery& q) { q.who = "olga"; }), (Ids{2}));
    EXPECT_EQ(select([](AuditQuery& q) { q.who = "ann"; }), (Ids{})) << "who is matched exactly";
    EXPECT_EQ(select([](AuditQuery& q) { q.actionPrefix = "program."; }), (Ids{2, 1}));
    EXPECT_EQ(select([](AuditQuery& q) { q.actionPrefix = "file.changed"; }), (Ids{5}));
    // `_` and `%` are characters of the prefix, not LIKE wildcards.
    EXPECT_EQ(select([](AuditQuery& q) { q.actionPrefix = "user_"; }), (Ids{3}));
    EXPECT_EQ(select([](AuditQuery& q) { q.actionPrefix = "%"; }), (Ids{}));
    EXPECT_EQ(select([](AuditQuery& q) { q.outcome = "refused"; }), (Ids{2}));
    EXPECT_EQ(select([](AuditQuery& q) { q.outcome = "failed"; }), (Ids{6}));
    // Filters narrow together.
    EXPECT_EQ(select([](AuditQuery& q) {
                  q.who = "anna";
                  q.outcome = "done";
                  q.sinceMs = kT0 + 1;
              }),
              (Ids{4, 3}));
}

TEST(AuditLog, PagesByTheLastIdSeen)
{
    hgtest::TempDir dir;
    AuditLog log(dir / "audit.sqlite");
    fill(log);
    using Ids = std::vector<std::int64_t>;
    AuditQuery q;
    q.limit = 4;
    EXPECT_EQ(ids(log.select(q)), (Ids{6, 5, 4, 3}));
    q.beforeId = 3;
    EXPECT_EQ(ids(log.select(q)), (Ids{2, 1}));
    q.beforeId = 1;
    EXPECT_EQ(ids(log.select(q)), (Ids{}));
    // Paging within a filter.
    q = {};
    q.who = "anna";
    q.limit = 2;
    EXPECT_EQ(ids(log.select(q)), (Ids{6, 4}));
    q.beforeId = 4;
    EXPECT_EQ(ids(log.select(q)), (Ids{3, 1}));
}

TEST(AuditLog, AnotherConnectionCanNeitherChangeNorDeleteAnEntry)
{
    hgtest::TempDir dir;
    const auto file = dir / "audit.sqlite";
    {
        AuditLog log(file);
        fill(log);
    }
    const auto update = sqlite3Cli(file, "UPDATE audit SET who = 'mallory' WHERE id = 2");
    EXPECT_NE(update.status, 0);
    EXPECT_NE(update.err.find("the audit trail is append-only"), std::string::npos) << update.err;
    const auto remove = sqlite3Cli(file, "DELETE FROM audit WHERE id <= 6");
    EXPECT_NE(remove.status, 0);
    EXPECT_NE(remove.err.find("the audit trail is append-only"), std::string::npos) << remove.err;
    EXPECT_EQ(sqlite3Cli(file, "SELECT count(*), group_concat(who) FROM audit").out,
              "6|anna,olga,anna,anna,hullgauged,anna\n");
}

TEST(AuditLog, AReadOnlyOpenRefusesAFileThatIsNoAuditTrailNamingIt)
{
    hgtest::TempDir dir;
    const auto other = dir / "results.db";
    ASSERT_EQ(sqlite3Cli(other, "CREATE TABLE inspections (id INTEGER)").status, 0);
    try {
        AuditLog log(other, true);
        FAIL() << "a result store opened as an audit trail";
    } catch (const sqlite::Error& e) {
        EXPECT_EQ(std::string(e.what()), "audit trail " + other.string() + ": not an audit trail (no audit table)");
    }
    // A text file is no SQLite database at all.
    const auto text = hgtest::writeFile(dir / "notes.txt", "not a database, just some text of a length\n");
    try {
        AuditLog log(text, true);
        FAIL() << "a text file opened as an audit trail";
    } catch (const sqlite::Error& e) {
        EXPECT_EQ(std::string(e.what()).rfind("audit trail " + text.string() + ": ", 0), 0u) << e.what();
    }
    // Nothing was written to either.
    EXPECT_EQ(sqlite3Cli(other, "SELECT name FROM sqlite_master").out, "inspections\n");
}

TEST(AuditLog, ATrailOfANewerSchemaIsRefused)
{
    hgtest::TempDir dir;
    const auto file = dir / "audit.sqlite";
    {
        AuditLog log(file);
        fill(log);
    }
    ASSERT_EQ(sqlite3Cli(file, "PRAGMA user_version = 2").status, 0);
    for (const bool readOnly : {false, true}) {
        try {
            AuditLog log(file, readOnly);
            FAIL() << "a version 2 trail opened" << (readOnly ? " read-only" : "");
        } catch (const sqlite::Error& e) {
            EXPECT_EQ(std::string(e.what()),
                      "audit trail " + file.string() + ": audit schema version 2 is newer than 1");
        }
    }
    EXPECT_EQ(sqlite3Cli(file, "SELECT count(*) FROM audit").out, "6\n");
}

TEST(AuditLog, AWatchedFileKeepsItsStateWithItsEntry)
{
    hgtest::TempDir dir;
    AuditLog log(dir / "audit.sqlite");
    EXPECT_FALSE(log.watched("/etc/hullgauge/station.yaml"));
    auto first = entry(kT0, "hullgauged", "file.recorded");
    first.after = "a: 1\n";
    EXPECT_EQ(log.recordFileChange("/etc/hullgauge/station.yaml", {"d1", "a: 1\n"}, first), 1);
    auto kept = log.watched("/etc/hullgauge/station.yaml");
    ASSERT_TRUE(kept);
    EXPECT_EQ(kept->sha256, "d1");
    EXPECT_EQ(kept->content, "a: 1\n");
    auto second = entry(kT0 + 1000, "hullgauged", "file.changed");
    second.before = "a: 1\n";
    second.after = "a: 2\n";
    EXPECT_EQ(log.recordFileChange("/etc/hullgauge/station.yaml", {"d2", "a: 2\n"}, second), 2);
    kept = log.watched("/etc/hullgauge/station.yaml");
    ASSERT_TRUE(kept);
    EXPECT_EQ(kept->sha256, "d2");
    EXPECT_EQ(kept->content, "a: 2\n");
    EXPECT_EQ(ids(log.select({})), (std::vector<std::int64_t>{2, 1}));

    // One transaction: when the state cannot be stored, the entry is not either.
    ASSERT_EQ(sqlite3Cli(log.file(), "CREATE TRIGGER refuse BEFORE UPDATE ON watched_files "
                                     "BEGIN SELECT RAISE(ABORT, 'refused for the test'); END")
                  .status,
              0);
    EXPECT_THROW(log.recordFileChange("/etc/hullgauge/station.yaml", {"d3", "a: 3\n"},
                                      entry(kT0 + 2000, "hullgauged", "file.changed")),
                 sqlite::Error);
    EXPECT_EQ(ids(log.select({})), (std::vector<std::int64_t>{2, 1}));
    EXPECT_EQ(log.watched("/etc/hullgauge/station.yaml")->sha256, "d2");
}

TEST(AuditLog, CsvIsRfc4180WithTheDocumentedColumns)
{
    AuditEntry plain = entry(kT0 + 250, "anna", "program.release");
    plain.id = 7;
    AuditEntry quoted = entry(kT0 + 61'000, "olga", "program.landmark.change", "refused");
    quoted.id = 8;
    quoted.role = "operator";
    quoted.detail = "needs an engineer, or administrator";
    quoted.before = "name: \"a\"\nx: 1";
    quoted.after = "";
    const std::string expected = "id,time,who,role,source,action,object,outcome,detail,before,after\r\n"
                                 "7,2026-05-28T20:26:40.250Z,anna,engineer,hmi 127.0.0.1,program.release,block,done,,,"
                                 "\r\n"
                                 "8,2026-05-28T20:27:41.000Z,olga,operator,hmi 127.0.0.1,program.landmark.change,block,"
                                 "refused,\"needs an engineer, or administrator\",\"name: \"\"a\"\"\nx: 1\",\r\n";
    EXPECT_EQ(auditCsv({plain, quoted}), expected);
    EXPECT_EQ(auditCsv({}), "id,time,who,role,source,action,object,outcome,detail,before,after\r\n");
}

} // namespace
} // namespace hg::store
