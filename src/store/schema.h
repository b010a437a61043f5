// The result store's schema and its migrations (docs/daemon.md, "Result
// store"): the tables `inspections` and `health` of the current version, and
// the columns and tables an older database gains when the daemon's writer opens it. Private to the store
// module: only the writer creates or migrates a database.
#pragma once

#include "hullgauge/store/sqlite.h"

namespace hg::store {

// The version this build writes (PRAGMA user_version); each added columns:
// 2: alignment_json and simulation_json (the measured and the simulated seat).
// 3: purpose (production, master, study: docs/study.md).
// 4: cycle_id and published_unix_ms, the plant link's outbox (docs/mqtt.md).
// 5: program_version and program_sha256, the release the part was judged with (docs/commissioning.md).
// 6: correction_id and temperature_c, the master's correction and the part's temperature (docs/mastering.md).
// 7: the table `health`, the station's health figures of each cycle (docs/health.md, "In the daemon").
constexpr int kSchemaVersion = 8;

/// Creates the schema in a new database, or brings one of an older version to kSchemaVersion
/// keeping its rows; a database of a newer version is refused (sqlite::Error naming it).
void createOrMigrate(const sqlite::Connection& db);

} // namespace hg::store
