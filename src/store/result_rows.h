// The one query of the result store (hullgauge/store/result_reader.h) on an
// open connection: the reader's, the writer's (`ctl results`) and the
// outbox's (each result's row, docs/mqtt.md) give the same rows. Private to
// the store module.
#pragma once

#include "hullgauge/store/result_reader.h"
#include "hullgauge/store/sqlite.h"

#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace hg::store {

/// The rows of `query`; `file` names the database in errors. Throws hg::FaultError when SQLite
/// fails and hg::InputError when the file is not a result store or a row is damaged.
std::vector<nlohmann::json> selectResults(const sqlite::Connection& db, const std::string& file,
                                          const ResultQuery& query);
std::int64_t countResults(const sqlite::Connection& db, const std::string& file, const ResultQuery& query);
/// The health rows of `query` (ResultReader::health), oldest first.
std::vector<nlohmann::json> selectHealth(const sqlite::Connection& db, const std::string& file,
                                         const HealthQuery& query);

} // namespace hg::store
