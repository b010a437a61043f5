#include "result_store.h"

#include "hullgauge/common/error.h"
#include "hullgauge/common/log.h"
#include "hullgauge/store/result_reader.h"

#include <sqlite3.h>

namespace hg::daemon {
namespace {

// 2: alignment_json and simulation_json (the measured and the simulated seat).
// 3: purpose (production, master, study: docs/study.md).
constexpr int kSchemaVersion = 3;

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
    purpose          TEXT    NOT NULL DEFAULT 'production' CHECK (purpose IN ('production', 'master', 'study'))
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
    Statement insert(db_, "INSERT INTO inspections (started_utc, started_unix_ms, trigger_seq, manual, serial, "
                          "program, part, verdict, fault_code, cycle_ms, landmarks_failed, landmarks_total, "
                          "landmarks_json, timing_json, images_dir, alignment_json, simulation_json, purpose) "
                          "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)");
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
    text(13, r.landmarksJson().dump());
    text(14, r.timingMs.dump());
    text(15, imagesDir);
    text(16, r.alignment.dump());
    text(17, r.simulation.dump());
    text(18, std::string(station::toString(r.purpose)));
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

} // namespace hg::daemon
