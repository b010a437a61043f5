#include "schema.h"

#include <string>

namespace hg::store {
namespace {

// The table of kSchemaVersion, for a new database.
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
    program_sha256   TEXT    NOT NULL DEFAULT '',
    correction_id    TEXT    NOT NULL DEFAULT '',
    temperature_c    REAL
);
CREATE INDEX IF NOT EXISTS inspections_serial ON inspections (serial);
CREATE INDEX IF NOT EXISTS inspections_started ON inspections (started_unix_ms);
CREATE TABLE IF NOT EXISTS health (
    inspection_id      INTEGER PRIMARY KEY REFERENCES inspections (id),
    unix_ms            INTEGER NOT NULL,
    backlight          REAL,
    uniformity         REAL,
    dust_specks        REAL,
    edge_width_px      REAL,
    contrast           REAL,
    noise              REAL,
    predicted_sigma_px REAL,
    warnings           TEXT    NOT NULL DEFAULT '[]',
    edge_bias_px       REAL,
    capability         REAL
);
CREATE INDEX IF NOT EXISTS health_time ON health (unix_ms);
)";

int userVersion(const sqlite::Connection& db)
{
    auto version = db.prepare("PRAGMA user_version");
    return version.step() ? version.integer(0) : 0;
}

} // namespace

void createOrMigrate(const sqlite::Connection& db)
{
    db.exec(kSchema);
    const int found = userVersion(db);
    if (found > kSchemaVersion)
        throw sqlite::Error(db.label(), "schema version " + std::to_string(found) + " is newer than this daemon's (" +
                                            std::to_string(kSchemaVersion) + ")");
    // A version 1 database gains the seat's columns; its rows read null there.
    if (found == 1) {
        db.exec("ALTER TABLE inspections ADD COLUMN alignment_json TEXT NOT NULL DEFAULT 'null'");
        db.exec("ALTER TABLE inspections ADD COLUMN simulation_json TEXT NOT NULL DEFAULT 'null'");
    }
    // A version 1 or 2 database gains the cycles' purpose; its rows were production.
    if (found == 1 || found == 2)
        db.exec("ALTER TABLE inspections ADD COLUMN purpose TEXT NOT NULL DEFAULT 'production' "
                "CHECK (purpose IN ('production', 'master', 'study'))");
    // A version 1 to 3 database gains the outbox's columns; its rows predate the plant link
    // and are never published (published_unix_ms 0, docs/mqtt.md "Outbox").
    if (found >= 1 && found <= 3) {
        db.exec("ALTER TABLE inspections ADD COLUMN cycle_id TEXT NOT NULL DEFAULT ''");
        db.exec("ALTER TABLE inspections ADD COLUMN published_unix_ms INTEGER");
        db.exec("UPDATE inspections SET published_unix_ms = 0");
    }
    // A version 1 to 4 database gains the program's release; its rows name none (a draft's NULL and '').
    if (found >= 1 && found <= 4) {
        db.exec("ALTER TABLE inspections ADD COLUMN program_version INTEGER");
        db.exec("ALTER TABLE inspections ADD COLUMN program_sha256 TEXT NOT NULL DEFAULT ''");
    }
    // A version 1 to 5 database gains the master's correction and the part's temperature
    // (docs/mastering.md); its rows were neither corrected nor referred ('' and NULL).
    if (found >= 1 && found <= 5) {
        db.exec("ALTER TABLE inspections ADD COLUMN correction_id TEXT NOT NULL DEFAULT ''");
        db.exec("ALTER TABLE inspections ADD COLUMN temperature_c REAL");
    }
    // Re-mastering due's counts at start: a correction set's production rows (docs/mastering.md).
    db.exec("CREATE INDEX IF NOT EXISTS inspections_correction ON inspections (correction_id, program, purpose)");
    // A version 1 to 6 database gains the table `health` (docs/health.md, "In the daemon") from
    // kSchema above, empty: the station's health was not watched before. A version 7 one gains
    // the edge bias and the capability figure, its rows without them (NULL: not measured).
    if (found == 7) {
        db.exec("ALTER TABLE health ADD COLUMN edge_bias_px REAL");
        db.exec("ALTER TABLE health ADD COLUMN capability REAL");
    }
    // The outbox: the rows still to publish, in id order, without scanning the published ones.
    db.exec("CREATE INDEX IF NOT EXISTS inspections_outbox ON inspections (id) WHERE published_unix_ms IS NULL");
    db.exec("PRAGMA user_version=" + std::to_string(kSchemaVersion));
}

} // namespace hg::store
