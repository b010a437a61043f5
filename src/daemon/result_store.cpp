#include "result_store.h"

#include "hullgauge/common/error.h"
#include "hullgauge/common/json.h"
#include "hullgauge/common/log.h"
#include "hullgauge/store/result_reader.h"

#include <algorithm>
#include <array>
#include <random>
#include <sqlite3.h>

namespace hg::daemon {
namespace {

// 2: alignment_json and simulation_json (the measured and the simulated seat).
// 3: purpose (production, master, study: docs/study.md).
// 4: cycle_id and published_unix_ms, the plant link's outbox (docs/mqtt.md).
// 5: program_version and program_sha256, the release the part was judged with (docs/commissioning.md).
constexpr int kSchemaVersion = 5;

constexpr const char* kSchema = R"(
CREATE TABLE IF NOT EXISTS inspections (
    id               INTEGER PRIMARY KEY AUTOINCREMENT,
    started_utc      TEXT    NOT NULL,
    started_unix_ms  INTEGER NOT NULL,
    trigger_seq      INTEGER NOT NULL,
    manual           INTEGER NOT NULL,
    serial           TEXT    NOT NULL,
    program          INTEGER NOT NULL,
    part             TEXT    NOT NULL,
    verdict          TEXT    NOT NULL CHECK (verdict IN ('pass', 'fail', 'aborted', 'error')),
    fault_code       INTEGER NOT NULL,
    cycle_ms         INTEGER NOT NULL,
    landmarks_failed INTEGER NOT NULL,
    landmarks_total  INTEGER NOT NULL,
    landmarks_json   TEXT    NOT NULL,
    timing_json      TEXT    NOT NULL,
    images_dir       TEXT    NOT NULL DEFAULT '',
    alignment_json   TEXT    NOT NULL DEFAULT 'null',
    simulation_json  TEXT    NOT NULL DEFAULT 'null',
    purpose          TEXT    NOT NULL DEFAULT 'production' CHECK (purpose IN ('production', 'master', 'study')),
    cycle_id         TEXT    NOT NULL DEFAULT '',
    published_unix_ms INTEGER,
    program_version  INTEGER,
    program_sha256   TEXT    NOT NULL DEFAULT ''
);
CREATE INDEX IF NOT EXISTS inspections_serial ON inspections (serial);
CREATE INDEX IF NOT EXISTS inspections_started ON inspections (started_unix_ms);
)";

struct Statement {
    sqlite3_stmt* stmt = nullptr;
    Statement(sqlite3* db, const char* sql)
    {
        if (sqlite3_prepare_v2(db, sql, -1, &stmt, nullptr) != SQLITE_OK)
            throw FaultError(std::string("result store: ") + sqlite3_errmsg(db));
    }
    ~Statement() { sqlite3_finalize(stmt); }
    Statement(const Statement&) = delete;
    Statement& operator=(const Statement&) = delete;
};

} // namespace

std::string newCycleId()
{
    // A random (version 4) UUID: unique across stations and across a store that was replaced,
    // so the plant's receiver can drop the duplicates of a redelivery by it (docs/mqtt.md).
    // std::random_device reads the kernel's random source (getrandom) on Linux.
    std::random_device random;
    std::array<std::uint8_t, 16> b{};
    for (std::size_t i = 0; i < b.size(); i += 4) {
        const auto r = random();
        for (std::size_t k = 0; k < 4; ++k) b[i + k] = static_cast<std::uint8_t>(r >> (8 * k));
    }
    b[6] = static_cast<std::uint8_t>((b[6] & 0x0F) | 0x40);
    b[8] = static_cast<std::uint8_t>((b[8] & 0x3F) | 0x80);
    std::string id;
    static constexpr char kHex[] = "0123456789abcdef";
    for (std::size_t i = 0; i < b.size(); ++i) {
        if (i == 4 || i == 6 || i == 8 || i == 10) id += '-';
        id += kHex[b[i] >> 4];
        id += kHex[b[i] & 0x0F];
    }
    return id;
}

ResultStore::ResultStore(const std::filesystem::path& file) : file_(file)
{
    std::error_code ec;
    if (file.has_parent_path()) std::filesystem::create_directories(file.parent_path(), ec);
    if (sqlite3_open_v2(file.c_str(), &db_, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_FULLMUTEX,
                        nullptr) != SQLITE_OK) {
        std::string why = db_ ? sqlite3_errmsg(db_) : "out of memory";
        sqlite3_close(db_);
        db_ = nullptr;
        throw FaultError("result store " + file.string() + ": " + why);
    }
    // Another reader (the maintenance tool, sqlite3) may hold a lock briefly.
    sqlite3_busy_timeout(db_, 2000);
    try {
        exec("PRAGMA journal_mode=WAL");
        exec("PRAGMA synchronous=FULL");
        exec(kSchema);
        Statement version(db_, "PRAGMA user_version");
        int found = sqlite3_step(version.stmt) == SQLITE_ROW ? sqlite3_column_int(version.stmt, 0) : 0;
        if (found > kSchemaVersion)
            throw FaultError("result store " + file.string() + ": schema version " + std::to_string(found) +
                             " is newer than this daemon's (" + std::to_string(kSchemaVersion) + ")");
        // A version 1 database gains the seat's columns; its rows read null there.
        if (found == 1) {
            exec("ALTER TABLE inspections ADD COLUMN alignment_json TEXT NOT NULL DEFAULT 'null'");
            exec("ALTER TABLE inspections ADD COLUMN simulation_json TEXT NOT NULL DEFAULT 'null'");
        }
        // A version 1 or 2 database gains the cycles' purpose; its rows were production.
        if (found == 1 || found == 2)
            exec("ALTER TABLE inspections ADD COLUMN purpose TEXT NOT NULL DEFAULT 'production' "
                 "CHECK (purpose IN ('production', 'master', 'study'))");
        // A version 1 to 3 database gains the outbox's columns; its rows predate the plant link
        // and are never published (published_unix_ms 0, docs/mqtt.md "Outbox").
        if (found >= 1 && found <= 3) {
            exec("ALTER TABLE inspections ADD COLUMN cycle_id TEXT NOT NULL DEFAULT ''");
            exec("ALTER TABLE inspections ADD COLUMN published_unix_ms INTEGER");
            exec("UPDATE inspections SET published_unix_ms = 0");
        }
        // A version 1 to 4 database gains the program's release; its rows name none (a draft's NULL and '').
        if (found >= 1 && found <= 4) {
            exec("ALTER TABLE inspections ADD COLUMN program_version INTEGER");
            exec("ALTER TABLE inspections ADD COLUMN program_sha256 TEXT NOT NULL DEFAULT ''");
        }
        // The outbox: the rows still to publish, in id order, without scanning the published ones.
        exec("CREATE INDEX IF NOT EXISTS inspections_outbox ON inspections (id) WHERE published_unix_ms IS NULL");
        exec(("PRAGMA user_version=" + std::to_string(kSchemaVersion)).c_str());
    } catch (...) {
        sqlite3_close(db_);
        db_ = nullptr;
        throw;
    }
    hg::log::category("store")->info("result store {} ({} records)", file.string(), count());
}

ResultStore::~ResultStore()
{
    if (db_) sqlite3_close(db_);
}

void ResultStore::exec(const char* sql) const
{
    char* message = nullptr;
    if (sqlite3_exec(db_, sql, nullptr, nullptr, &message) != SQLITE_OK) {
        std::string why = message ? message : sqlite3_errmsg(db_);
        sqlite3_free(message);
        throw FaultError("result store " + file_.string() + ": " + why);
    }
}

std::int64_t ResultStore::commit(const station::InspectionRecord& r, const std::string& imagesDir)
{
    Statement insert(db_,
                     "INSERT INTO inspections (started_utc, started_unix_ms, trigger_seq, manual, serial, "
                     "program, part, verdict, fault_code, cycle_ms, landmarks_failed, landmarks_total, "
                     "landmarks_json, timing_json, images_dir, alignment_json, simulation_json, purpose, cycle_id, "
                     "program_version, program_sha256) "
                     "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)");
    auto text = [&](int i, const std::string& s) {
        sqlite3_bind_text(insert.stmt, i, s.c_str(), static_cast<int>(s.size()), SQLITE_TRANSIENT);
    };
    text(1, store::formatUtc(r.startedUnixMs));
    sqlite3_bind_int64(insert.stmt, 2, r.startedUnixMs);
    sqlite3_bind_int(insert.stmt, 3, r.triggerSeq);
    sqlite3_bind_int(insert.stmt, 4, r.manual ? 1 : 0);
    text(5, r.serial);
    sqlite3_bind_int(insert.stmt, 6, r.program);
    text(7, r.part);
    text(8, std::string(station::toString(r.verdict)));
    sqlite3_bind_int(insert.stmt, 9, static_cast<int>(r.faultCode));
    sqlite3_bind_int64(insert.stmt, 10, r.cycleMs);
    sqlite3_bind_int64(insert.stmt, 11, static_cast<std::int64_t>(r.landmarksFailed()));
    sqlite3_bind_int64(insert.stmt, 12, static_cast<std::int64_t>(r.landmarks.size()));
    text(13, dumpJson(r.landmarksJson()));
    text(14, dumpJson(r.timingMs));
    text(15, imagesDir);
    text(16, dumpJson(r.alignment));
    text(17, dumpJson(r.simulation));
    text(18, std::string(station::toString(r.purpose)));
    text(19, newCycleId());
    // The program's release: NULL and '' for a draft (docs/daemon.md, "Result store").
    if (r.programRelease)
        sqlite3_bind_int(insert.stmt, 20, r.programRelease->version);
    else
        sqlite3_bind_null(insert.stmt, 20);
    text(21, r.programRelease ? r.programRelease->verificationSha256 : std::string());
    // A single INSERT in autocommit mode is its own transaction: durable when step() returns.
    if (sqlite3_step(insert.stmt) != SQLITE_DONE)
        throw FaultError("result store " + file_.string() + ": " + sqlite3_errmsg(db_));
    return sqlite3_last_insert_rowid(db_);
}

nlohmann::json ResultStore::recent(int limit) const
{
    store::ResultQuery query;
    query.limit = limit;
    return store::selectResults(db_, file_.string(), query);
}

std::int64_t ResultStore::count() const
{
    Statement query(db_, "SELECT COUNT(*) FROM inspections");
    return sqlite3_step(query.stmt) == SQLITE_ROW ? sqlite3_column_int64(query.stmt, 0) : 0;
}

ResultCounters& ResultCounters::operator+=(const ResultCounters& more)
{
    cycles += more.cycles;
    passes += more.passes;
    fails += more.fails;
    aborted += more.aborted;
    faults += more.faults;
    return *this;
}

ResultOutbox::ResultOutbox(const std::filesystem::path& file) : file_(file)
{
    if (sqlite3_open_v2(file.c_str(), &db_, SQLITE_OPEN_READWRITE, nullptr) != SQLITE_OK) {
        std::string why = db_ ? sqlite3_errmsg(db_) : "out of memory";
        sqlite3_close(db_);
        db_ = nullptr;
        throw FaultError("result store " + file.string() + " (outbox): " + why);
    }
    sqlite3_busy_timeout(db_, 2000);
    try {
        // A mark lost to a power cut only sends that result once more (same cycle id,
        // docs/mqtt.md): the marks need no fsync of their own, unlike the results.
        exec("PRAGMA synchronous=NORMAL");
    } catch (...) {
        sqlite3_close(db_);
        db_ = nullptr;
        throw;
    }
}

ResultOutbox::~ResultOutbox()
{
    if (db_) sqlite3_close(db_);
}

void ResultOutbox::exec(const char* sql) const
{
    char* message = nullptr;
    if (sqlite3_exec(db_, sql, nullptr, nullptr, &message) != SQLITE_OK) {
        std::string why = message ? message : sqlite3_errmsg(db_);
        sqlite3_free(message);
        throw FaultError("result store " + file_.string() + " (outbox): " + why);
    }
}

std::vector<OutboxEntry> ResultOutbox::pending(std::int64_t afterId, int limit) const
{
    std::vector<OutboxEntry> entries;
    {
        Statement select(db_, "SELECT id, cycle_id FROM inspections WHERE published_unix_ms IS NULL AND id > ? "
                              "ORDER BY id LIMIT ?");
        sqlite3_bind_int64(select.stmt, 1, afterId);
        sqlite3_bind_int(select.stmt, 2, limit);
        int rc;
        while ((rc = sqlite3_step(select.stmt)) == SQLITE_ROW) {
            const auto* cycleId = sqlite3_column_text(select.stmt, 1);
            entries.push_back(
                {sqlite3_column_int64(select.stmt, 0), cycleId ? reinterpret_cast<const char*>(cycleId) : "", nullptr});
        }
        if (rc != SQLITE_DONE) throw FaultError("result store " + file_.string() + ": " + sqlite3_errmsg(db_));
    }
    // Each row in the one shape every reader gives (hullgauge/store/result_reader.h).
    for (auto& entry : entries) {
        store::ResultQuery one;
        one.afterId = entry.id - 1;
        one.beforeId = entry.id + 1;
        auto rows = store::selectResults(db_, file_.string(), one);
        if (!rows.empty()) entry.row = std::move(rows.front());
    }
    return entries;
}

std::int64_t ResultOutbox::pendingCount() const
{
    Statement query(db_, "SELECT COUNT(*) FROM inspections WHERE published_unix_ms IS NULL");
    return sqlite3_step(query.stmt) == SQLITE_ROW ? sqlite3_column_int64(query.stmt, 0) : 0;
}

void ResultOutbox::markPublished(const std::vector<std::int64_t>& ids, std::int64_t unixMs)
{
    if (ids.empty()) return;
    exec("BEGIN IMMEDIATE");
    try {
        Statement mark(db_, "UPDATE inspections SET published_unix_ms = ? WHERE id = ? AND published_unix_ms IS NULL");
        for (auto id : ids) {
            sqlite3_bind_int64(mark.stmt, 1, unixMs);
            sqlite3_bind_int64(mark.stmt, 2, id);
            if (sqlite3_step(mark.stmt) != SQLITE_DONE)
                throw FaultError("result store " + file_.string() + ": " + sqlite3_errmsg(db_));
            sqlite3_reset(mark.stmt);
        }
        exec("COMMIT");
    } catch (...) {
        sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
        throw;
    }
}

ResultCounters ResultOutbox::countAfter(std::int64_t afterId, std::int64_t& lastId) const
{
    Statement query(db_, "SELECT verdict, COUNT(*), MAX(id) FROM inspections WHERE id > ? GROUP BY verdict");
    sqlite3_bind_int64(query.stmt, 1, afterId);
    ResultCounters counts;
    lastId = afterId;
    int rc;
    while ((rc = sqlite3_step(query.stmt)) == SQLITE_ROW) {
        const std::string verdict = reinterpret_cast<const char*>(sqlite3_column_text(query.stmt, 0));
        const auto n = sqlite3_column_int64(query.stmt, 1);
        lastId = std::max<std::int64_t>(lastId, sqlite3_column_int64(query.stmt, 2));
        counts.cycles += n;
        if (verdict == "pass") counts.passes += n;
        if (verdict == "fail") counts.fails += n;
        if (verdict == "aborted") counts.aborted += n;
        if (verdict == "error") counts.faults += n;
    }
    if (rc != SQLITE_DONE) throw FaultError("result store " + file_.string() + ": " + sqlite3_errmsg(db_));
    return counts;
}

} // namespace hg::daemon
