// The result store's reader against databases written here with plain SQL in
// the layouts of docs/daemon.md ("Result store"), not by the daemon's writer.
#include "hullgauge/common/error.h"
#include "hullgauge/store/result_reader.h"

#include <gtest/gtest.h>
#include <hgtest/paths.h>
#include <sqlite3.h>

namespace {

using hg::store::ResultQuery;
using hg::store::ResultReader;

/// Schema version 1: no seat columns and no purpose.
constexpr const char* kSchemaV1 = R"(
CREATE TABLE inspections (
    id INTEGER PRIMARY KEY AUTOINCREMENT, started_utc TEXT NOT NULL, started_unix_ms INTEGER NOT NULL,
    trigger_seq INTEGER NOT NULL, manual INTEGER NOT NULL, serial TEXT NOT NULL, program INTEGER NOT NULL,
    part TEXT NOT NULL, verdict TEXT NOT NULL, fault_code INTEGER NOT NULL, cycle_ms INTEGER NOT NULL,
    landmarks_failed INTEGER NOT NULL, landmarks_total INTEGER NOT NULL, landmarks_json TEXT NOT NULL,
    timing_json TEXT NOT NULL, images_dir TEXT NOT NULL DEFAULT '');
)";

void exec(sqlite3* db, const std::string& sql)
{
    char* error = nullptr;
    ASSERT_EQ(sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &error), SQLITE_OK) << (error ? error : "") << sql;
}

/// A database at `file` with `schema` and the rows `inserts` (SQL).
void makeStore(const std::filesystem::path& file, const std::string& schema, const std::string& inserts)
{
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(file.c_str(), &db), SQLITE_OK);
    exec(db, schema);
    exec(db, inserts);
    sqlite3_close(db);
}

std::string v3Schema()
{
    return std::string(kSchemaV1) + "ALTER TABLE inspections ADD COLUMN alignment_json TEXT NOT NULL DEFAULT 'null';"
                                    "ALTER TABLE inspections ADD COLUMN simulation_json TEXT NOT NULL DEFAULT 'null';"
                                    "ALTER TABLE inspections ADD COLUMN purpose TEXT NOT NULL DEFAULT 'production';";
}

/// Row `i` (1-based): serial SN-<i>, every third fails, program 1 or 2 by parity, started at i seconds.
std::string rows(int n, bool withPurpose)
{
    std::string sql;
    for (int i = 1; i <= n; ++i) {
        const std::string verdict = i % 3 == 0 ? "fail" : "pass";
        sql += "INSERT INTO inspections (started_utc, started_unix_ms, trigger_seq, manual, serial, program, part, "
               "verdict, fault_code, cycle_ms, landmarks_failed, landmarks_total, landmarks_json, timing_json" +
               std::string(withPurpose ? ", purpose" : "") + ") VALUES ('t', " + std::to_string(i * 1000) + ", " +
               std::to_string(i) + ", 0, 'SN-" + std::to_string(i) + "', " + std::to_string(1 + i % 2) +
               ", 'block', '" + verdict + "', 0, 100, 0, 1, '[{\"id\":\"a\",\"error_mm\":0.0" + std::to_string(i) +
               "}]', '{}'" + (withPurpose ? (i == 4 ? ", 'master'" : ", 'production'") : "") + ");";
    }
    return sql;
}

std::vector<std::string> serials(const std::vector<nlohmann::json>& rows)
{
    std::vector<std::string> out;
    for (const auto& r : rows) out.push_back(r.at("serial").get<std::string>());
    return out;
}

TEST(ResultReader, FiltersPagesAndOrdersAsAsked)
{
    hgtest::TempDir dir;
    makeStore(dir / "r.db", v3Schema(), rows(10, true));
    const ResultReader reader(dir / "r.db");
    EXPECT_EQ(reader.count({}), 10);

    ResultQuery fails;
    fails.verdicts = {"fail"};
    EXPECT_EQ(serials(reader.select(fails)), (std::vector<std::string>{"SN-9", "SN-6", "SN-3"}));

    ResultQuery page;
    page.limit = 3;
    page.beforeId = 8;
    EXPECT_EQ(serials(reader.select(page)), (std::vector<std::string>{"SN-7", "SN-6", "SN-5"}));

    ResultQuery window; // started in [3 s, 6 s), program 2 (odd rows), oldest first
    window.sinceMs = 3000;
    window.untilMs = 6000;
    window.program = 2;
    window.newestFirst = false;
    EXPECT_EQ(serials(reader.select(window)), (std::vector<std::string>{"SN-3", "SN-5"}));

    ResultQuery search;
    search.serialContains = "N-1";
    EXPECT_EQ(serials(reader.select(search)), (std::vector<std::string>{"SN-10", "SN-1"}));

    ResultQuery production;
    production.purpose = "production";
    EXPECT_EQ(reader.count(production), 9);
    const auto one = reader.byId(4);
    ASSERT_TRUE(one);
    EXPECT_EQ(one->at("purpose"), "master");
    EXPECT_DOUBLE_EQ(one->at("landmarks")[0].at("error_mm").get<double>(), 0.04);
    EXPECT_EQ(one->at("started_unix_ms"), 4000);
    EXPECT_FALSE(reader.byId(11));
}

TEST(ResultReader, ASerialsOwnWildcardsAreLiteral)
{
    hgtest::TempDir dir;
    makeStore(dir / "r.db", v3Schema(), rows(2, true) + "UPDATE inspections SET serial = 'A%B' WHERE id = 2;");
    const ResultReader reader(dir / "r.db");
    ResultQuery q;
    q.serialContains = "%";
    EXPECT_EQ(serials(reader.select(q)), (std::vector<std::string>{"A%B"}));
}

TEST(ResultReader, AVersionOneStoreReadsWithTheLaterColumnsDefaults)
{
    hgtest::TempDir dir;
    makeStore(dir / "old.db", kSchemaV1, rows(4, false));
    const ResultReader reader(dir / "old.db");
    const auto all = reader.select({});
    ASSERT_EQ(all.size(), 4u);
    EXPECT_EQ(all[0].at("purpose"), "production");
    EXPECT_TRUE(all[0].at("alignment").is_null());
    EXPECT_TRUE(all[0].at("simulation").is_null());
    EXPECT_TRUE(all[0].at("program_version").is_null()); // no release recorded before schema version 5
    EXPECT_TRUE(all[0].at("program_sha256").is_null());
    ResultQuery master;
    master.purpose = "master";
    EXPECT_EQ(reader.count(master), 0); // before purposes existed every cycle was production
    ResultQuery production;
    production.purpose = "production";
    EXPECT_EQ(reader.count(production), 4);
}

// Schema version 5: the release of the program each part was judged with
// (docs/daemon.md, "Result store"): NULL and '' for a draft's result.
TEST(ResultReader, TheReleaseAPartWasJudgedWithAndNoneForADraft)
{
    hgtest::TempDir dir;
    const std::string digest(64, 'a');
    makeStore(dir / "v5.db",
              v3Schema() + "ALTER TABLE inspections ADD COLUMN cycle_id TEXT NOT NULL DEFAULT '';"
                           "ALTER TABLE inspections ADD COLUMN published_unix_ms INTEGER;"
                           "ALTER TABLE inspections ADD COLUMN program_version INTEGER;"
                           "ALTER TABLE inspections ADD COLUMN program_sha256 TEXT NOT NULL DEFAULT '';",
              rows(2, true) + "UPDATE inspections SET program_version = 7, program_sha256 = '" + digest +
                  "' WHERE id = 2;");
    const ResultReader reader(dir / "v5.db");
    const auto released = reader.byId(2);
    ASSERT_TRUE(released);
    EXPECT_EQ(released->at("program_version"), 7);
    EXPECT_EQ(released->at("program_sha256"), digest);
    const auto draft = reader.byId(1);
    ASSERT_TRUE(draft);
    EXPECT_TRUE(draft->at("program_version").is_null());
    EXPECT_TRUE(draft->at("program_sha256").is_null());
}

TEST(ResultReader, NamesWhatIsWrongWithTheFile)
{
    hgtest::TempDir dir;
    try {
        ResultReader missing(dir / "none.db");
        FAIL() << "opened a missing database";
    } catch (const hg::InputError& e) {
        EXPECT_NE(std::string(e.what()).find("no database at"), std::string::npos) << e.what();
    }
    makeStore(dir / "other.db", "CREATE TABLE t (x);", "");
    const ResultReader other(dir / "other.db");
    try {
        other.select({});
        FAIL() << "read a database without inspections";
    } catch (const hg::InputError& e) {
        EXPECT_NE(std::string(e.what()).find("not a result store"), std::string::npos) << e.what();
    }
    makeStore(dir / "damaged.db", v3Schema(),
              rows(2, true) + "UPDATE inspections SET landmarks_json = '[{' WHERE id = 2;");
    const ResultReader damaged(dir / "damaged.db");
    try {
        damaged.select({});
        FAIL() << "read a damaged row";
    } catch (const hg::InputError& e) {
        EXPECT_NE(std::string(e.what()).find("inspection 2.landmarks_json"), std::string::npos) << e.what();
    }
}

TEST(ResultReader, FormatsTimesAsTheStoreWritesThem)
{
    EXPECT_EQ(hg::store::formatUtc(0), "1970-01-01T00:00:00.000Z");
    EXPECT_EQ(hg::store::formatUtc(1'780'000'000'123), "2026-05-28T20:26:40.123Z");
    EXPECT_EQ(hg::store::formatUtc(-1), "1969-12-31T23:59:59.999Z");
    // parseUtc reads what formatUtc writes, to the second.
    EXPECT_EQ(hg::store::parseUtc("2026-05-28T20:26:40Z", "t"), 1'780'000'000'000);
}

} // namespace
