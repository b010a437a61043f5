// The result store's schema and its migrations (docs/daemon.md, "Result
// store"): the table `inspections` of the current version, and the columns an
// older database gains when the daemon's writer opens it. Private to the store
// module: only the writer creates or migrates a database.
#pragma once

#include "hullgauge/store/sqlite.h"

namespace hg::store {

// The version this build writes (PRAGMA user_version); each added columns:
// 2: alignment_json and simulation_json (the measured and the simulated seat).
// 3: purpose (production, master, study: docs/study.md).
// 4: cycle_id and published_unix_ms, the plant link's outbox (docs/mqtt.md).
// 5: program_version and program_sha256, the release the part was judged with (docs/commissioning.md).
constexpr int kSchemaVersion = 6;

/// Creates the schema in a new database, or brings one of an older version to kSchemaVersion
/// keeping its rows; a database of a newer version is refused (sqlite::Error naming it).
void createOrMigrate(const sqlite::Connection& db);

} // namespace hg::store
