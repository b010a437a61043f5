// The station's result database (SQLite, WAL): one row per inspection, never
// lost once committed. commit() returns only after the row is durable
// (journal_mode=WAL with synchronous=FULL: the WAL is fsynced at every
// commit), and the daemon shows DONE to the PLC only after commit() returned,
// so every result the PLC saw survives a power cut or kill -9.
#pragma once

#include "hullgauge/station/result_record.h"

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

struct sqlite3;

namespace hg::daemon {

class ResultStore {
  public:
    /// Opens or creates the database (and its folder). Throws hg::FaultError
    /// with SQLite's message when the file cannot be opened or is not ours.
    explicit ResultStore(const std::filesystem::path& file);
    ~ResultStore();
    ResultStore(const ResultStore&) = delete;
    ResultStore& operator=(const ResultStore&) = delete;

    /// Inserts the record durably and returns its row id; throws hg::FaultError on failure.
    std::int64_t commit(const station::InspectionRecord& record, const std::string& imagesDir = {});
    /// The newest `limit` records, newest first, as JSON objects.
    nlohmann::json recent(int limit) const;
    std::int64_t count() const;
    const std::filesystem::path& file() const { return file_; }

  private:
    void exec(const char* sql) const;

    std::filesystem::path file_;
    sqlite3* db_ = nullptr;
};

} // namespace hg::daemon
