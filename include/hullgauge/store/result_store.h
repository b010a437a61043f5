// The station's result database (SQLite, WAL): one row per inspection, never
// lost once committed. commit() returns only after the row is durable
// (journal_mode=WAL with synchronous=FULL: the WAL is fsynced at every
// commit), and the daemon shows DONE to the PLC only after commit() returned,
// so every result the PLC saw survives a power cut or kill -9. The writer is
// the one connection that creates the database and migrates an older one
// (docs/daemon.md, "Result store").
#pragma once

#include "hullgauge/station/result_record.h"
#include "hullgauge/store/sqlite.h"

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

namespace hg::store {

class ResultStore {
  public:
    /// Opens or creates the database (and its folder) and brings an older
    /// schema to the current one. Throws hg::FaultError with SQLite's message
    /// when the file cannot be opened or is not ours.
    explicit ResultStore(const std::filesystem::path& file);
    ResultStore(const ResultStore&) = delete;
    ResultStore& operator=(const ResultStore&) = delete;

    /// Inserts the record durably and returns its row id; throws hg::FaultError on failure.
    std::int64_t commit(const station::InspectionRecord& record, const std::string& imagesDir = {});
    /// The newest `limit` records, newest first, as JSON objects.
    nlohmann::json recent(int limit) const;
    std::int64_t count() const;
    /// The production parts of `program` judged (pass or fail) with the correction set
    /// `correctionId`, those started at or after `sinceMs` when given: re-mastering
    /// due's counts across a restart (docs/mastering.md, "Due in the daemon").
    /// Throws hg::FaultError when SQLite fails.
    std::int64_t productionJudged(int program, const std::string& correctionId,
                                  std::optional<std::int64_t> sinceMs = std::nullopt) const;
    const std::filesystem::path& file() const { return file_; }

  private:
    std::filesystem::path file_;
    sqlite::Connection db_;
};

/// A new cycle id: a random UUID (version 4) in lower-case hex, the id a
/// result keeps in the store and in every message that carries it (docs/mqtt.md).
std::string newCycleId();

} // namespace hg::store
