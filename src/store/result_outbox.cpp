#include "hullgauge/store/result_outbox.h"

#include "result_rows.h"

#include <algorithm>

namespace hg::store {

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
    db_ = sqlite::open(file, sqlite::Access::Write, "result store " + file.string() + " (outbox)");
    // A mark lost to a power cut only sends that result once more (same cycle id,
    // docs/mqtt.md): the marks need no fsync of their own, unlike the results.
    db_.exec("PRAGMA synchronous=NORMAL");
}

std::vector<OutboxEntry> ResultOutbox::pending(std::int64_t afterId, int limit) const
{
    std::vector<OutboxEntry> entries;
    {
        auto select = db_.prepare("SELECT id, cycle_id FROM inspections WHERE published_unix_ms IS NULL AND id > ? "
                                  "ORDER BY id LIMIT ?");
        select.bind(1, afterId).bind(2, limit);
        while (select.step()) entries.push_back({select.int64(0), select.text(1), nullptr});
    }
    // Each row in the one shape every reader gives (hullgauge/store/result_reader.h).
    for (auto& entry : entries) {
        ResultQuery one;
        one.afterId = entry.id - 1;
        one.beforeId = entry.id + 1;
        auto rows = selectResults(db_, file_.string(), one);
        if (!rows.empty()) entry.row = std::move(rows.front());
    }
    return entries;
}

std::int64_t ResultOutbox::pendingCount() const
{
    auto query = db_.prepare("SELECT COUNT(*) FROM inspections WHERE published_unix_ms IS NULL");
    return query.step() ? query.int64(0) : 0;
}

void ResultOutbox::markPublished(const std::vector<std::int64_t>& ids, std::int64_t unixMs)
{
    if (ids.empty()) return;
    sqlite::Transaction transaction(db_);
    auto mark = db_.prepare("UPDATE inspections SET published_unix_ms = ? WHERE id = ? AND published_unix_ms IS NULL");
    for (auto id : ids) {
        mark.bind(1, unixMs).bind(2, id).step();
        mark.reset();
    }
    transaction.commit();
}

ResultCounters ResultOutbox::countAfter(std::int64_t afterId, std::int64_t& lastId) const
{
    auto query = db_.prepare("SELECT verdict, COUNT(*), MAX(id) FROM inspections WHERE id > ? GROUP BY verdict");
    query.bind(1, afterId);
    ResultCounters counts;
    lastId = afterId;
    while (query.step()) {
        const std::string verdict = query.text(0);
        const auto n = query.int64(1);
        lastId = std::max<std::int64_t>(lastId, query.int64(2));
        counts.cycles += n;
        if (verdict == "pass") counts.passes += n;
        if (verdict == "fail") counts.fails += n;
        if (verdict == "aborted") counts.aborted += n;
        if (verdict == "error") counts.faults += n;
    }
    return counts;
}

} // namespace hg::store
