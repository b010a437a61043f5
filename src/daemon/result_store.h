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
#include <vector>

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

/// A new cycle id: a random UUID (version 4) in lower-case hex, the id a
/// result keeps in the store and in every message that carries it (docs/mqtt.md).
std::string newCycleId();

/// A result waiting in the outbox: committed, not yet acknowledged by the broker.
struct OutboxEntry {
    std::int64_t id = 0;
    std::string cycleId;
    nlohmann::json row; ///< the stored row, as `ctl results --json` and the HMI's API give it
};

/// Counts of stored results by verdict (docs/mqtt.md, "Counters").
struct ResultCounters {
    std::int64_t cycles = 0;
    std::int64_t passes = 0;
    std::int64_t fails = 0;
    std::int64_t aborted = 0;
    std::int64_t faults = 0; ///< verdict error
    ResultCounters& operator+=(const ResultCounters& more);
    bool operator==(const ResultCounters& other) const = default;
};

/// The result store as the plant link's outbox (docs/mqtt.md, "Outbox"): a
/// result is in it from its commit until the broker acknowledged it. Its own
/// read-write connection (the store is WAL: the cycle's commit never waits for
/// a read, and a mark is one short write), for one thread, the publisher's.
class ResultOutbox {
  public:
    /// Opens the store the daemon created; throws hg::FaultError naming it.
    explicit ResultOutbox(const std::filesystem::path& file);
    ~ResultOutbox();
    ResultOutbox(const ResultOutbox&) = delete;
    ResultOutbox& operator=(const ResultOutbox&) = delete;

    /// At most `limit` unpublished results with an id above `afterId`, oldest first.
    std::vector<OutboxEntry> pending(std::int64_t afterId, int limit) const;
    /// How many results wait.
    std::int64_t pendingCount() const;
    /// Marks the results published at `unixMs`, all in one transaction; throws hg::FaultError.
    void markPublished(const std::vector<std::int64_t>& ids, std::int64_t unixMs);
    /// The counts of the results with an id above `afterId`; `lastId` becomes the largest id counted.
    ResultCounters countAfter(std::int64_t afterId, std::int64_t& lastId) const;

  private:
    void exec(const char* sql) const;

    std::filesystem::path file_;
    sqlite3* db_ = nullptr;
};

} // namespace hg::daemon
