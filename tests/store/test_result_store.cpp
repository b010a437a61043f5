// The result store: WAL mode, one durable row per record, readable by the
// sqlite3 program; the schema's migrations from every older version; the
// plant link's outbox (docs/mqtt.md, "Outbox").
#include "hgtest/paths.h"
#include "hullgauge/common/error.h"
#include "hullgauge/store/result_outbox.h"
#include "hullgauge/store/result_reader.h"
#include "hullgauge/store/result_store.h"

#include <gtest/gtest.h>
#include <regex>
#include <set>
#include <thread>

namespace hg::store {
namespace {

station::InspectionRecord record(std::uint16_t seq, station::Verdict verdict)
{
    station::InspectionRecord r;
    r.startedUnixMs = 1'700'000'000'123;
    r.triggerSeq = seq;
    r.serial = "SN-" + std::to_string(seq);
    r.program = 1;
    r.part = "block";
    r.verdict = verdict;
    r.cycleMs = 1234;
    r.landmarks = {{"c1", inspect::LandmarkStatus::Ok, 0.0, 0.125, 0.0625, 0.2},
                   {"c2", inspect::LandmarkStatus::OutOfTolerance, 0.5, 0.625, 0.5625, 0.2}};
    return r;
}

/// A new store at `file` holding `r` alone, closed again.
void storeOnly(const std::filesystem::path& file, const station::InspectionRecord& r)
{
    ResultStore store(file);
    store.commit(r);
}

/// The sqlite3 program's answer to `query` on `file`: an independent reader.
std::string sql(const std::filesystem::path& file, const std::string& query)
{
    return hgtest::run("sqlite3 " + file.string() + " \"" + query + "\"").out;
}

TEST(ResultStore, CommitsInWalModeAndSqliteReadsIt)
{
    hgtest::TempDir dir;
    auto file = dir / "db" / "results.db";
    {
        ResultStore store(file);
        EXPECT_EQ(store.commit(record(5, station::Verdict::Fail), "/img/5"), 1);
        EXPECT_EQ(store.commit(record(6, station::Verdict::Pass)), 2);
        EXPECT_EQ(store.count(), 2);
        auto recent = store.recent(1);
        ASSERT_EQ(recent.size(), 1u);
        EXPECT_EQ(recent[0]["serial"], "SN-6");
        EXPECT_EQ(recent[0]["time"], "2023-11-14T22:13:20.123Z");
    }
    // An independent reader: the sqlite3 program.
    auto mode = hgtest::run("sqlite3 " + file.string() + " 'PRAGMA journal_mode'");
    EXPECT_EQ(mode.out, "wal\n");
    auto rows = hgtest::run("sqlite3 " + file.string() +
                            " \"SELECT trigger_seq, serial, verdict, landmarks_failed, landmarks_total, images_dir, "
                            "json_extract(landmarks_json, '$[1].status') FROM inspections ORDER BY id\"");
    EXPECT_EQ(rows.out, "5|SN-5|fail|1|2|/img/5|out_of_tolerance\n6|SN-6|pass|1|2||out_of_tolerance\n");
    // Reopening keeps the rows (schema creation is idempotent).
    ResultStore again(file);
    EXPECT_EQ(again.count(), 2);
}

TEST(ResultStore, ALandmarkNameThatIsNotUtf8IsStoredWithAReplacementCharacter)
{
    // A part program typed in Latin-1: "Bohrung ø" with ø = 0xF8. The row is
    // written (never lost to a JSON error) and shows where the name was wrong.
    hgtest::TempDir dir;
    auto r = record(3, station::Verdict::Pass);
    r.landmarks[0].id = std::string("Bohrung \xF8");
    storeOnly(dir / "results.db", r);
    EXPECT_EQ(sql(dir / "results.db", "SELECT json_extract(landmarks_json, '$[0].id') FROM inspections"),
              "Bohrung \xEF\xBF\xBD\n");
}

TEST(ResultStore, KeepsTheSeatAndTheSimulatedPartWithTheRecord)
{
    hgtest::TempDir dir;
    auto file = dir / "results.db";
    {
        ResultStore store(file);
        auto r = record(9, station::Verdict::Error);
        r.faultCode = station::FaultCode::PartNotSeated;
        r.alignment = {{"method", "silhouette"}, {"shift_mm", 2.0}, {"rotation_deg", 0.125}};
        r.simulation = {{"part", "nominal"}, {"seat", {{"shift_mm", 2.0}}}};
        store.commit(r);
        store.commit(record(10, station::Verdict::Pass)); // no seat: null
        auto recent = store.recent(2);
        ASSERT_EQ(recent.size(), 2u);
        EXPECT_TRUE(recent[0]["alignment"].is_null());
        EXPECT_TRUE(recent[0]["simulation"].is_null());
        EXPECT_EQ(recent[1]["fault_code"], 32);
        EXPECT_EQ(recent[1]["alignment"]["shift_mm"], 2.0);
        EXPECT_EQ(recent[1]["simulation"]["part"], "nominal");
    }
    auto rows = hgtest::run("sqlite3 " + file.string() +
                            " \"SELECT json_extract(alignment_json, '$.rotation_deg'), "
                            "json_extract(simulation_json, '$.seat.shift_mm') FROM inspections ORDER BY id\"");
    EXPECT_EQ(rows.out, "0.125|2.0\n|\n");
}

TEST(ResultStore, AVersionOneDatabaseGainsTheSeatColumns)
{
    hgtest::TempDir dir;
    auto file = dir / "v1.db";
    // The schema of version 1, as the daemon before the seat wrote it.
    hgtest::run("sqlite3 " + file.string() +
                " \"CREATE TABLE inspections (id INTEGER PRIMARY KEY AUTOINCREMENT, started_utc TEXT NOT NULL, "
                "started_unix_ms INTEGER NOT NULL, trigger_seq INTEGER NOT NULL, manual INTEGER NOT NULL, serial TEXT "
                "NOT NULL, program INTEGER NOT NULL, part TEXT NOT NULL, verdict TEXT NOT NULL, fault_code INTEGER NOT "
                "NULL, cycle_ms INTEGER NOT NULL, landmarks_failed INTEGER NOT NULL, landmarks_total INTEGER NOT NULL, "
                "landmarks_json TEXT NOT NULL, timing_json TEXT NOT NULL, images_dir TEXT NOT NULL DEFAULT ''); "
                "INSERT INTO inspections VALUES (1, 't', 0, 3, 0, 'OLD', 1, 'block', 'pass', 0, 10, 0, 0, '[]', '{}', "
                "''); PRAGMA user_version=1;\"");
    ResultStore store(file);
    auto r = record(4, station::Verdict::Pass);
    r.alignment = {{"shift_mm", 0.25}};
    store.commit(r);
    auto recent = store.recent(2);
    ASSERT_EQ(recent.size(), 2u);
    EXPECT_EQ(recent[0]["alignment"]["shift_mm"], 0.25);
    EXPECT_EQ(recent[1]["serial"], "OLD");
    EXPECT_TRUE(recent[1]["alignment"].is_null());
    EXPECT_EQ(recent[1]["purpose"], "production");
    EXPECT_EQ(hgtest::run("sqlite3 " + file.string() + " 'PRAGMA user_version'").out, "8\n");
}

TEST(ResultStore, AVersionTwoDatabaseGainsThePurposeAndItsRowsAreProduction)
{
    hgtest::TempDir dir;
    auto file = dir / "v2.db";
    // The schema of version 2, as the daemon before cycle purposes wrote it.
    hgtest::run("sqlite3 " + file.string() +
                " \"CREATE TABLE inspections (id INTEGER PRIMARY KEY AUTOINCREMENT, started_utc TEXT NOT NULL, "
                "started_unix_ms INTEGER NOT NULL, trigger_seq INTEGER NOT NULL, manual INTEGER NOT NULL, serial TEXT "
                "NOT NULL, program INTEGER NOT NULL, part TEXT NOT NULL, verdict TEXT NOT NULL, fault_code INTEGER NOT "
                "NULL, cycle_ms INTEGER NOT NULL, landmarks_failed INTEGER NOT NULL, landmarks_total INTEGER NOT NULL, "
                "landmarks_json TEXT NOT NULL, timing_json TEXT NOT NULL, images_dir TEXT NOT NULL DEFAULT '', "
                "alignment_json TEXT NOT NULL DEFAULT 'null', simulation_json TEXT NOT NULL DEFAULT 'null'); "
                "INSERT INTO inspections VALUES (1, 't', 0, 3, 0, 'OLD', 1, 'block', 'pass', 0, 10, 0, 0, '[]', '{}', "
                "'', 'null', 'null'); PRAGMA user_version=2;\"");
    {
        ResultStore store(file);
        auto r = record(4, station::Verdict::Pass);
        r.purpose = station::CyclePurpose::Master;
        store.commit(r);
        auto recent = store.recent(2);
        ASSERT_EQ(recent.size(), 2u);
        EXPECT_EQ(recent[0]["purpose"], "master");
        EXPECT_EQ(recent[1]["purpose"], "production");
        EXPECT_EQ(recent[1]["serial"], "OLD");
    }
    EXPECT_EQ(hgtest::run("sqlite3 " + file.string() + " 'PRAGMA user_version'").out, "8\n");
    EXPECT_EQ(hgtest::run("sqlite3 " + file.string() + " 'SELECT serial, purpose FROM inspections ORDER BY id'").out,
              "OLD|production\nSN-4|master\n");
    // Only the three purposes are stored, also in a migrated table.
    auto bad = hgtest::run("sqlite3 " + file.string() + " \"UPDATE inspections SET purpose = 'golden' WHERE id = 1\"");
    EXPECT_NE(bad.status, 0);
    ResultStore again(file); // reopening a migrated database changes nothing
    EXPECT_EQ(again.count(), 2);
}

std::vector<std::int64_t> idsOf(const std::vector<OutboxEntry>& entries)
{
    std::vector<std::int64_t> ids;
    for (const auto& e : entries) ids.push_back(e.id);
    return ids;
}

TEST(ResultOutbox, EveryCommittedResultWaitsInOrderWithItsOwnCycleId)
{
    hgtest::TempDir dir;
    auto file = dir / "results.db";
    ResultStore store(file);
    for (std::uint16_t seq = 1; seq <= 5; ++seq) store.commit(record(seq, station::Verdict::Pass));
    ResultOutbox outbox(file);
    const auto all = outbox.pending(0, 10);
    EXPECT_EQ(idsOf(all), (std::vector<std::int64_t>{1, 2, 3, 4, 5}));
    std::set<std::string> cycleIds;
    const std::regex uuid4("[0-9a-f]{8}-[0-9a-f]{4}-4[0-9a-f]{3}-[89ab][0-9a-f]{3}-[0-9a-f]{12}");
    for (const auto& e : all) {
        EXPECT_TRUE(std::regex_match(e.cycleId, uuid4)) << e.cycleId;
        cycleIds.insert(e.cycleId);
    }
    EXPECT_EQ(cycleIds.size(), 5u);
    // The row is the store's row as every reader gives it.
    const auto recent = store.recent(5);
    EXPECT_EQ(all[1].row, recent[3]);
    EXPECT_EQ(all[1].row["serial"], "SN-2");
    // Batches: after an id, at most a limit.
    EXPECT_EQ(idsOf(outbox.pending(2, 2)), (std::vector<std::int64_t>{3, 4}));
    EXPECT_TRUE(outbox.pending(5, 10).empty());
    EXPECT_EQ(outbox.pendingCount(), 5);
    // The cycle id is stored with the row, for the sqlite3 program too.
    EXPECT_EQ(hgtest::run("sqlite3 " + file.string() + " 'SELECT cycle_id FROM inspections WHERE id = 4'").out,
              all[3].cycleId + "\n");
}

TEST(ResultOutbox, AcknowledgedResultsLeaveTheOutboxAndStayMarkedAfterARestart)
{
    hgtest::TempDir dir;
    auto file = dir / "results.db";
    {
        ResultStore store(file);
        for (std::uint16_t seq = 1; seq <= 5; ++seq) store.commit(record(seq, station::Verdict::Fail));
        ResultOutbox outbox(file);
        // Acknowledgements may come out of order: each one marks its own result only.
        outbox.markPublished({4, 2}, 1'700'000'000'999);
        outbox.markPublished({}, 1);
        EXPECT_EQ(idsOf(outbox.pending(0, 10)), (std::vector<std::int64_t>{1, 3, 5}));
        EXPECT_EQ(outbox.pendingCount(), 3);
        // A second acknowledgement of a result (a redelivery) keeps its first time.
        outbox.markPublished({2}, 1'800'000'000'000);
    }
    // The daemon restarted (or was killed): the marks are in the file.
    ResultStore store(file);
    ResultOutbox outbox(file);
    EXPECT_EQ(idsOf(outbox.pending(0, 10)), (std::vector<std::int64_t>{1, 3, 5}));
    EXPECT_EQ(hgtest::run("sqlite3 " + file.string() +
                          " 'SELECT id, published_unix_ms FROM inspections WHERE published_unix_ms IS NOT NULL'")
                  .out,
              "2|1700000000999\n4|1700000000999\n");
    // A result committed later waits behind the older ones.
    store.commit(record(6, station::Verdict::Pass));
    EXPECT_EQ(idsOf(outbox.pending(0, 10)), (std::vector<std::int64_t>{1, 3, 5, 6}));
}

TEST(ResultOutbox, CountsByVerdictAndThenOnlyTheNewResults)
{
    hgtest::TempDir dir;
    auto file = dir / "results.db";
    ResultStore store(file);
    store.commit(record(1, station::Verdict::Pass));
    store.commit(record(2, station::Verdict::Fail));
    store.commit(record(3, station::Verdict::Pass));
    store.commit(record(4, station::Verdict::Error));
    ResultOutbox outbox(file);
    std::int64_t last = 0;
    auto counts = outbox.countAfter(0, last);
    EXPECT_EQ(last, 4);
    EXPECT_EQ(counts, (ResultCounters{4, 2, 1, 0, 1}));
    store.commit(record(5, station::Verdict::Aborted));
    counts += outbox.countAfter(last, last);
    EXPECT_EQ(last, 5);
    EXPECT_EQ(counts, (ResultCounters{5, 2, 1, 1, 1}));
    EXPECT_EQ(outbox.countAfter(last, last), ResultCounters{}) << "nothing new";
    EXPECT_EQ(last, 5);
}

TEST(ResultOutbox, RowsOfAVersionThreeStorePredateThePlantLink)
{
    hgtest::TempDir dir;
    auto file = dir / "v3.db";
    // The schema of version 3, as the daemon before the plant link wrote it.
    hgtest::run("sqlite3 " + file.string() +
                " \"CREATE TABLE inspections (id INTEGER PRIMARY KEY AUTOINCREMENT, started_utc TEXT NOT NULL, "
                "started_unix_ms INTEGER NOT NULL, trigger_seq INTEGER NOT NULL, manual INTEGER NOT NULL, serial TEXT "
                "NOT NULL, program INTEGER NOT NULL, part TEXT NOT NULL, verdict TEXT NOT NULL, fault_code INTEGER NOT "
                "NULL, cycle_ms INTEGER NOT NULL, landmarks_failed INTEGER NOT NULL, landmarks_total INTEGER NOT NULL, "
                "landmarks_json TEXT NOT NULL, timing_json TEXT NOT NULL, images_dir TEXT NOT NULL DEFAULT '', "
                "alignment_json TEXT NOT NULL DEFAULT 'null', simulation_json TEXT NOT NULL DEFAULT 'null', purpose "
                "TEXT NOT NULL DEFAULT 'production'); "
                "INSERT INTO inspections VALUES (1, 't', 0, 3, 0, 'OLD', 1, 'block', 'pass', 0, 10, 0, 0, '[]', '{}', "
                "'', 'null', 'null', 'production'); PRAGMA user_version=3;\"");
    ResultStore store(file);
    store.commit(record(4, station::Verdict::Pass));
    ResultOutbox outbox(file);
    EXPECT_EQ(idsOf(outbox.pending(0, 10)), (std::vector<std::int64_t>{2}));
    EXPECT_EQ(hgtest::run("sqlite3 " + file.string() + " 'PRAGMA user_version'").out, "8\n");
    EXPECT_EQ(hgtest::run("sqlite3 " + file.string() +
                          " \"SELECT serial, published_unix_ms, cycle_id = '' FROM inspections ORDER BY id\"")
                  .out,
              "OLD|0|1\nSN-4||0\n");
    // The counters count every stored result, the old ones too.
    std::int64_t last = 0;
    EXPECT_EQ(outbox.countAfter(0, last).cycles, 2);
}

TEST(ResultOutbox, MarksWhileTheStoreCommitsLoseNothing)
{
    hgtest::TempDir dir;
    auto file = dir / "results.db";
    ResultStore store(file);
    ResultOutbox outbox(file);
    constexpr int kResults = 200;
    // The publisher's side on its own thread and connection, as in the daemon: send in order, mark.
    std::vector<std::int64_t> seen;
    std::thread publisher([&] {
        const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
        std::int64_t last = 0;
        while (static_cast<int>(seen.size()) < kResults && std::chrono::steady_clock::now() < deadline) {
            auto batch = outbox.pending(last, 7);
            for (const auto& e : batch) seen.push_back(e.id);
            if (!batch.empty()) last = batch.back().id;
            outbox.markPublished(idsOf(batch), 1);
        }
    });
    for (int i = 1; i <= kResults; ++i) store.commit(record(static_cast<std::uint16_t>(i), station::Verdict::Pass));
    publisher.join();
    ASSERT_EQ(seen.size(), static_cast<std::size_t>(kResults));
    for (int i = 0; i < kResults; ++i) EXPECT_EQ(seen[static_cast<std::size_t>(i)], i + 1);
    EXPECT_EQ(outbox.pendingCount(), 0);
}

TEST(ResultStore, KeepsALandmarksAsymmetricLimitsForTheStudies)
{
    hgtest::TempDir dir;
    auto r = record(3, station::Verdict::Pass);
    r.landmarks[0].limitsMm = std::pair{-0.05, 0.15};
    storeOnly(dir / "results.db", r);
    // Read by the gauge studies (docs/study.md): T = upper − lower; no limits → ±tolerance_mm.
    EXPECT_EQ(sql(dir / "results.db", "SELECT json_extract(landmarks_json, '$[0].limits_mm'), "
                                      "json_type(landmarks_json, '$[1].limits_mm') IS NULL FROM inspections"),
              "[-0.05,0.15]|1\n");
}

/// A release's verification digest: 64 hex digits.
const std::string kDigest = "5f0c9d3e4b7a1c2d8e6f0a9b3c5d7e1f2a4b6c8d0e2f4a6b8c0d2e4f6a8b0c2d";

TEST(ResultStore, KeepsTheReleaseOfTheProgramThePartWasJudgedWith)
{
    hgtest::TempDir dir;
    auto file = dir / "results.db";
    {
        ResultStore store(file);
        auto released = record(1, station::Verdict::Pass);
        released.programRelease = station::ProgramRelease{3, kDigest};
        store.commit(released);
        store.commit(record(2, station::Verdict::Fail)); // a draft program: no release
        auto recent = store.recent(2);
        ASSERT_EQ(recent.size(), 2u);
        EXPECT_TRUE(recent[0]["program_version"].is_null());
        EXPECT_TRUE(recent[0]["program_sha256"].is_null());
        EXPECT_EQ(recent[1]["program_version"], 3);
        EXPECT_EQ(recent[1]["program_sha256"], kDigest);
    }
    // An independent reader: NULL and '' for the draft's result.
    EXPECT_EQ(sql(file, "SELECT serial, program_version, program_sha256, program_version IS NULL FROM inspections "
                        "ORDER BY id"),
              "SN-1|3|" + kDigest + "|0\nSN-2|||1\n");
}

TEST(ResultStore, AVersionFourDatabaseGainsTheReleaseColumnsAndKeepsItsRows)
{
    hgtest::TempDir dir;
    auto file = dir / "v4.db";
    // The schema of version 4, as the daemon before the program's release wrote it: one published row.
    hgtest::run("sqlite3 " + file.string() +
                " \"CREATE TABLE inspections (id INTEGER PRIMARY KEY AUTOINCREMENT, started_utc TEXT NOT NULL, "
                "started_unix_ms INTEGER NOT NULL, trigger_seq INTEGER NOT NULL, manual INTEGER NOT NULL, serial TEXT "
                "NOT NULL, program INTEGER NOT NULL, part TEXT NOT NULL, verdict TEXT NOT NULL CHECK (verdict IN "
                "('pass', 'fail', 'aborted', 'error')), fault_code INTEGER NOT NULL, cycle_ms INTEGER NOT NULL, "
                "landmarks_failed INTEGER NOT NULL, landmarks_total INTEGER NOT NULL, landmarks_json TEXT NOT NULL, "
                "timing_json TEXT NOT NULL, images_dir TEXT NOT NULL DEFAULT '', alignment_json TEXT NOT NULL DEFAULT "
                "'null', simulation_json TEXT NOT NULL DEFAULT 'null', purpose TEXT NOT NULL DEFAULT 'production' "
                "CHECK (purpose IN ('production', 'master', 'study')), cycle_id TEXT NOT NULL DEFAULT '', "
                "published_unix_ms INTEGER); "
                "INSERT INTO inspections VALUES (1, 't', 0, 3, 0, 'OLD', 1, 'block', 'fail', 0, 10, 1, 1, "
                "'[{\\\"id\\\": \\\"a\\\", \\\"status\\\": \\\"out_of_tolerance\\\"}]', '{}', '', 'null', 'null', "
                "'master', 'c0ffee00-0000-4000-8000-000000000001', 42); PRAGMA user_version=4;\"");
    ASSERT_EQ(sql(file, "SELECT count(*) FROM inspections"), "1\n");
    {
        ResultStore store(file);
        auto r = record(4, station::Verdict::Pass);
        r.programRelease = station::ProgramRelease{2, kDigest};
        store.commit(r);
        auto recent = store.recent(2);
        ASSERT_EQ(recent.size(), 2u);
        EXPECT_EQ(recent[0]["program_version"], 2);
        // The old row is kept as it was, naming no release.
        EXPECT_EQ(recent[1]["serial"], "OLD");
        EXPECT_EQ(recent[1]["verdict"], "fail");
        EXPECT_EQ(recent[1]["purpose"], "master");
        EXPECT_EQ(recent[1]["landmarks"][0]["status"], "out_of_tolerance");
        EXPECT_TRUE(recent[1]["program_version"].is_null());
        EXPECT_TRUE(recent[1]["program_sha256"].is_null());
    }
    EXPECT_EQ(hgtest::run("sqlite3 " + file.string() + " 'PRAGMA user_version'").out, "8\n");
    // Its outbox state too: published at 42 with its cycle id, not sent again.
    EXPECT_EQ(sql(file, "SELECT id, cycle_id, published_unix_ms, program_version IS NULL, program_sha256 FROM "
                        "inspections ORDER BY id LIMIT 1"),
              "1|c0ffee00-0000-4000-8000-000000000001|42|1|\n");
    ResultOutbox outbox(file);
    EXPECT_EQ(idsOf(outbox.pending(0, 10)), (std::vector<std::int64_t>{2}));
    ResultStore again(file); // reopening a migrated database changes nothing
    EXPECT_EQ(again.count(), 2);
}

TEST(ResultStore, AVersionFiveDatabaseGainsTheCorrectionAndTemperatureColumns)
{
    hgtest::TempDir dir;
    auto file = dir / "v5.db";
    {
        ResultStore store(file);
        store.commit(record(1, station::Verdict::Pass));
    }
    // Back to version 5 as that daemon wrote it: without the two columns (SQLite 3.35 drops columns)
    // and the index on the first.
    hgtest::run("sqlite3 " + file.string() +
                " 'DROP INDEX inspections_correction; ALTER TABLE inspections DROP COLUMN correction_id; "
                "ALTER TABLE inspections DROP COLUMN "
                "temperature_c; PRAGMA user_version=5;'");
    ASSERT_EQ(sql(file, "SELECT count(*) FROM pragma_table_info('inspections') WHERE name = 'temperature_c'"), "0\n");
    {
        ResultStore store(file);
        auto r = record(2, station::Verdict::Pass);
        r.correctionId = "p1-v3-steel-20260412T081500Z";
        r.temperatureC = 23.25;
        store.commit(r);
        auto recent = store.recent(2);
        ASSERT_EQ(recent.size(), 2u);
        EXPECT_EQ(recent[0]["correction_id"], "p1-v3-steel-20260412T081500Z");
        EXPECT_EQ(recent[0]["temperature_c"], 23.25);
        // The old row: neither corrected nor referred.
        EXPECT_TRUE(recent[1]["correction_id"].is_null());
        EXPECT_TRUE(recent[1]["temperature_c"].is_null());
    }
    EXPECT_EQ(hgtest::run("sqlite3 " + file.string() + " 'PRAGMA user_version'").out, "8\n");
    EXPECT_EQ(sql(file, "SELECT id, correction_id, temperature_c FROM inspections ORDER BY id"),
              "1||\n2|p1-v3-steel-20260412T081500Z|23.25\n");
}

/// A cycle's health as the runner records it: the figures given, NaN where not measured.
station::HealthRecord health(double backlight, double dust, std::vector<vision::HealthFigure> warnings)
{
    station::HealthRecord h;
    h.figures.backlight = backlight;
    h.figures.uniformity = 0.03125;
    h.figures.dustSpecks = dust;
    h.figures.edgeWidthPx = 1.5;
    h.figures.contrast = 0.875;
    h.figures.noise = 0.0078125;
    h.figures.predictedSigmaPx = 0.046875;
    h.figures.edgeBiasPx = -0.125;
    h.figures.capability = 0.625;
    h.figures.views = 8;
    h.figures.probes = 12;
    h.warnings = std::move(warnings);
    return h;
}

// docs/health.md, "In the daemon": a cycle's health row goes in with its
// inspection (the same id), a figure not measured as NULL, the warnings by
// name; the reader gives the rows of a time window oldest first, the newest
// `limit` of it.
TEST(ResultStore, KeepsEachCyclesHealthBesideItsInspectionAndReadsATimeWindow)
{
    hgtest::TempDir dir;
    const auto file = dir / "results.db";
    {
        ResultStore store(file);
        for (std::uint16_t seq = 1; seq <= 5; ++seq) {
            auto r = record(seq, station::Verdict::Pass);
            r.startedUnixMs = 1'800'000'000'000 + seq * 60'000; // one a minute
            if (seq == 2) r.health = health(0.75, 7.0, {vision::HealthFigure::Backlight, vision::HealthFigure::Dust});
            if (seq == 3) r.health = health(vision::kNoFigure, vision::kNoFigure, {});
            if (seq == 4 || seq == 5) r.health = health(0.96875, 0.0, {});
            store.commit(r);
        }
    }
    // The sqlite3 program reads what was written: NULL for the figures cycle 3 could not measure.
    EXPECT_EQ(sql(file, "SELECT inspection_id, unix_ms, backlight, dust_specks, edge_width_px, warnings FROM health "
                        "ORDER BY inspection_id"),
              "2|1800000120000|0.75|7.0|1.5|[\"backlight\",\"dust\"]\n"
              "3|1800000180000|||1.5|[]\n"
              "4|1800000240000|0.96875|0.0|1.5|[]\n"
              "5|1800000300000|0.96875|0.0|1.5|[]\n");
    const ResultReader reader(file);
    HealthQuery all;
    const auto rows = reader.health(all);
    ASSERT_EQ(rows.size(), 4u);
    EXPECT_EQ(rows[0]["inspection_id"], 2);
    EXPECT_EQ(rows[0]["time"], "2027-01-15T08:02:00.000Z");
    EXPECT_EQ(rows[0]["backlight"], 0.75);
    EXPECT_EQ(rows[0]["uniformity"], 0.03125);
    EXPECT_EQ(rows[0]["contrast"], 0.875);
    EXPECT_EQ(rows[0]["noise"], 0.0078125);
    EXPECT_EQ(rows[0]["predicted_sigma_px"], 0.046875);
    EXPECT_EQ(rows[0]["edge_bias_px"], -0.125);
    EXPECT_EQ(rows[0]["capability"], 0.625);
    EXPECT_EQ(rows[0]["warnings"], nlohmann::json::array({"backlight", "dust"}));
    EXPECT_TRUE(rows[1]["backlight"].is_null());
    EXPECT_TRUE(rows[1]["dust_specks"].is_null());
    EXPECT_EQ(rows[1]["edge_width_px"], 1.5);
    // [minute 3, minute 5): cycles 3 and 4.
    HealthQuery window;
    window.sinceMs = 1'800'000'180'000;
    window.untilMs = 1'800'000'300'000;
    const auto inWindow = reader.health(window);
    ASSERT_EQ(inWindow.size(), 2u);
    EXPECT_EQ(inWindow[0]["inspection_id"], 3);
    EXPECT_EQ(inWindow[1]["inspection_id"], 4);
    // The newest two of everything, oldest first.
    HealthQuery newest;
    newest.limit = 2;
    const auto last = reader.health(newest);
    ASSERT_EQ(last.size(), 2u);
    EXPECT_EQ(last[0]["inspection_id"], 4);
    EXPECT_EQ(last[1]["inspection_id"], 5);
}

// Schema 7 adds the table `health`: a version 6 store gains it, empty, its rows kept; a
// reader of a version 6 store (read-only, never migrating) finds no health rows.
TEST(ResultStore, AVersionSixDatabaseGainsTheHealthTable)
{
    hgtest::TempDir dir;
    auto file = dir / "v6.db";
    {
        ResultStore store(file);
        store.commit(record(1, station::Verdict::Pass));
    }
    // Back to version 6 as that daemon wrote it.
    hgtest::run("sqlite3 " + file.string() + " 'DROP INDEX health_time; DROP TABLE health; PRAGMA user_version=6;'");
    ASSERT_EQ(sql(file, "SELECT count(*) FROM sqlite_master WHERE name LIKE 'health%'"), "0\n");
    EXPECT_TRUE(ResultReader(file).health({}).empty());
    EXPECT_EQ(sql(file, "PRAGMA user_version"), "6\n");
    {
        ResultStore store(file);
        auto r = record(2, station::Verdict::Fail);
        r.health = health(0.5, 1.0, {vision::HealthFigure::Backlight});
        EXPECT_EQ(store.commit(r), 2);
    }
    EXPECT_EQ(sql(file, "PRAGMA user_version"), "8\n");
    EXPECT_EQ(sql(file, "SELECT id, serial FROM inspections ORDER BY id"), "1|SN-1\n2|SN-2\n");
    EXPECT_EQ(sql(file, "SELECT inspection_id, backlight, warnings FROM health"), "2|0.5|[\"backlight\"]\n");
    // The migrated table and its index are a new store's.
    const auto fresh = dir / "new.db";
    {
        ResultStore created(fresh);
    }
    for (const char* query :
         {"PRAGMA table_info(health)", "SELECT name, sql FROM sqlite_master WHERE name LIKE 'health%' ORDER BY name"})
        EXPECT_EQ(sql(file, query), sql(fresh, query)) << query;
}

// Schema 8 adds the health rows' edge bias and capability: a version 7 store gains the columns, its
// rows without one (null); read as it is (never migrated) its rows read null too.
TEST(ResultStore, AVersionSevenDatabaseGainsTheEdgeBiasAndCapability)
{
    hgtest::TempDir dir;
    auto file = dir / "v7.db";
    {
        ResultStore store(file);
        auto r = record(1, station::Verdict::Pass);
        r.health = health(0.5, 1.0, {});
        store.commit(r);
    }
    // Back to version 7 as that daemon wrote it: the table without the column.
    hgtest::run("sqlite3 " + file.string() +
                " 'ALTER TABLE health DROP COLUMN capability; ALTER TABLE health DROP COLUMN edge_bias_px; "
                "PRAGMA user_version=7;'");
    ASSERT_EQ(sql(file, "SELECT count(*) FROM pragma_table_info('health') WHERE name = 'edge_bias_px'"), "0\n");
    const auto old = ResultReader(file).health({});
    ASSERT_EQ(old.size(), 1u);
    EXPECT_TRUE(old[0]["edge_bias_px"].is_null());
    EXPECT_TRUE(old[0]["capability"].is_null());
    EXPECT_EQ(old[0]["backlight"], 0.5);
    {
        ResultStore store(file);
        auto r = record(2, station::Verdict::Pass);
        r.health = health(0.75, 0.0, {});
        store.commit(r);
    }
    EXPECT_EQ(sql(file, "PRAGMA user_version"), "8\n");
    EXPECT_EQ(sql(file, "SELECT inspection_id, backlight, edge_bias_px, capability FROM health ORDER BY inspection_id"),
              "1|0.5||\n2|0.75|-0.125|0.625\n");
    const auto fresh = dir / "new.db";
    {
        ResultStore created(fresh);
    }
    EXPECT_EQ(sql(file, "PRAGMA table_info(health)"), sql(fresh, "PRAGMA table_info(health)"));
}

// Re-mastering due's counts at start (docs/mastering.md, "Due in the daemon"):
// the production parts of one program judged with one set, from a given time.
TEST(ResultStore, CountsTheProductionPartsJudgedWithACorrectionSet)
{
    hgtest::TempDir dir;
    ResultStore store(dir / "r.db");
    const auto add = [&](station::Verdict verdict, station::CyclePurpose purpose, int program, const std::string& id,
                         std::int64_t startedUnixMs) {
        auto r = record(1, verdict);
        r.purpose = purpose;
        r.program = static_cast<std::uint16_t>(program);
        r.correctionId = id;
        r.startedUnixMs = startedUnixMs;
        store.commit(r);
    };
    using V = station::Verdict;
    using P = station::CyclePurpose;
    add(V::Pass, P::Production, 1, "set-a", 1000); // counted
    add(V::Fail, P::Production, 1, "set-a", 2000); // counted
    add(V::Pass, P::Production, 1, "set-a", 3000); // counted
    add(V::Aborted, P::Production, 1, "set-a", 3500);
    add(V::Error, P::Production, 1, "set-a", 3600);
    add(V::Pass, P::Master, 1, "set-a", 4000);
    add(V::Pass, P::Study, 1, "set-a", 4100);
    add(V::Pass, P::Production, 2, "set-a", 4200);
    add(V::Pass, P::Production, 1, "set-b", 4300);
    add(V::Pass, P::Production, 1, "", 4400);
    EXPECT_EQ(store.productionJudged(1, "set-a"), 3);
    EXPECT_EQ(store.productionJudged(1, "set-a", 2000), 2);
    EXPECT_EQ(store.productionJudged(1, "set-a", 3001), 0);
    EXPECT_EQ(store.productionJudged(1, "set-b"), 1);
    EXPECT_EQ(store.productionJudged(2, "set-a"), 1);
    EXPECT_EQ(store.productionJudged(3, "set-a"), 0);
    // SQLite's plan reads the index, not the whole table.
    EXPECT_NE(sql(store.file(), "EXPLAIN QUERY PLAN SELECT COUNT(*) FROM inspections WHERE correction_id = 'x' AND "
                                "program = 1 AND purpose = 'production'")
                  .find("inspections_correction"),
              std::string::npos);
}

TEST(ResultStore, RefusesADatabaseFromANewerDaemon)
{
    hgtest::TempDir dir;
    auto file = dir / "r.db";
    {
        ResultStore store(file);
    }
    hgtest::run("sqlite3 " + file.string() + " 'PRAGMA user_version=99'");
    EXPECT_THROW(ResultStore{file}, FaultError);
}

TEST(ResultStore, UnwritableLocationIsAFault)
{
    EXPECT_THROW(ResultStore{"/proc/hullgauge/results.db"}, FaultError);
}

TEST(ResultStore, AVersionOneStoreOpensAndMigratesToTheSchemaOfANewStore)
{
    hgtest::TempDir dir;
    const auto old = dir / "v1.db";
    // The oldest layout, written by hand as the first daemon wrote it: two rows, one of them failed.
    ASSERT_EQ(hgtest::run("sqlite3 " + old.string() +
                          " \"CREATE TABLE inspections (id INTEGER PRIMARY KEY AUTOINCREMENT, started_utc TEXT NOT "
                          "NULL, started_unix_ms INTEGER NOT NULL, trigger_seq INTEGER NOT NULL, manual INTEGER NOT "
                          "NULL, serial TEXT NOT NULL, program INTEGER NOT NULL, part TEXT NOT NULL, verdict TEXT NOT "
                          "NULL, fault_code INTEGER NOT NULL, cycle_ms INTEGER NOT NULL, landmarks_failed INTEGER NOT "
                          "NULL, landmarks_total INTEGER NOT NULL, landmarks_json TEXT NOT NULL, timing_json TEXT NOT "
                          "NULL, images_dir TEXT NOT NULL DEFAULT ''); "
                          "INSERT INTO inspections VALUES (1, 't1', 1000, 3, 0, 'OLD-1', 1, 'block', 'pass', 0, 10, 0, "
                          "1, '[]', '{}', '/img/1'); "
                          "INSERT INTO inspections VALUES (2, 't2', 2000, 4, 1, 'OLD-2', 2, 'block', 'fail', 0, 11, 1, "
                          "1, '[]', '{\\\"move\\\": 5}', ''); PRAGMA user_version=1;\"")
                  .status,
              0);
    // A reader opens it read-only and leaves it as it is: its rows read the defaults of later versions.
    ResultQuery all;
    all.newestFirst = false;
    const auto before = ResultReader(old).select(all);
    ASSERT_EQ(before.size(), 2u);
    EXPECT_EQ(sql(old, "PRAGMA user_version"), "1\n");

    // The writer opens it: version 8, the rows kept, and they read as the reader read them before.
    {
        ResultStore store(old);
        EXPECT_EQ(store.count(), 2);
    }
    EXPECT_EQ(sql(old, "PRAGMA user_version"), "8\n");
    EXPECT_EQ(ResultReader(old).select(all), before);
    EXPECT_EQ(before[1]["serial"], "OLD-2");
    EXPECT_EQ(before[1]["timing"]["move"], 5);
    EXPECT_TRUE(before[1]["alignment"].is_null());
    EXPECT_EQ(before[1]["purpose"], "production");
    EXPECT_TRUE(before[1]["program_version"].is_null());

    // Column for column and index for index, the migrated table is the one a new store creates.
    const auto fresh = dir / "new.db";
    {
        ResultStore created(fresh);
    }
    for (const char* query : {"PRAGMA table_info(inspections)", "PRAGMA table_info(health)",
                              "SELECT name, sql FROM sqlite_master WHERE type = 'index' ORDER BY name"})
        EXPECT_EQ(sql(old, query), sql(fresh, query)) << query;
    // serial, started, outbox, correction (re-mastering due's counts) and the health rows' time.
    EXPECT_EQ(sql(old, "SELECT count(*) FROM sqlite_master WHERE type = 'index'"), "5\n");

    // The outbox opens it too: the old rows predate the plant link, a new result waits.
    ResultStore store(old);
    EXPECT_EQ(store.commit(record(5, station::Verdict::Pass)), 3);
    ResultOutbox outbox(old);
    EXPECT_EQ(idsOf(outbox.pending(0, 10)), (std::vector<std::int64_t>{3}));
}

} // namespace
} // namespace hg::store
