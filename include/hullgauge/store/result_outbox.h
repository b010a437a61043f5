// The result store as the plant link's outbox (docs/mqtt.md, "Outbox"): a
// result is in it from its commit until the broker acknowledged it.
#pragma once

#include "hullgauge/store/sqlite.h"

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace hg::store {

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

/// The outbox's own read-write connection (the store is WAL: the cycle's
/// commit never waits for a read, and a mark is one short write), for one
/// thread, the publisher's.
class ResultOutbox {
  public:
    /// Opens the store the daemon created; throws hg::FaultError naming it.
    explicit ResultOutbox(const std::filesystem::path& file);
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
    std::filesystem::path file_;
    sqlite::Connection db_;
};

} // namespace hg::store
