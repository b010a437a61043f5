// The station's audit trail (docs/audit.md): who changed what, when, and
// what it was before and after — a part program, the station file and its
// calibration, a setting of the daemon's configuration, an account — and
// every change that was refused (an operator's attempt, a wrong password).
// Its own SQLite file beside the result store (default `audit.sqlite`), never
// pruned: the result store's retention does not touch it. The daemon writes it
// (the web HMI, the maintenance socket, the configuration it loads), the tool
// too (`hullgauge users`); `hullgauge audit` and the HMI read and export it.
#pragma once

#include "hullgauge/store/sqlite.h"

#include <cstdint>
#include <filesystem>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

namespace hg::store {

/// One recorded change or refused attempt. Texts are UTF-8; `before` and
/// `after` hold what changed (a file's text, a JSON object), empty when there
/// was nothing (a file created, an account removed) or nothing is shown (a password).
struct AuditEntry {
    std::int64_t id = 0;
    std::int64_t atMs = 0; ///< when, Unix ms (UTC)
    std::string who;       ///< the account, `unix:<user>` on the socket or tool, `hullgauged` for the daemon itself
    std::string role;      ///< operator, engineer, administrator; empty where no account applies
    std::string source;    ///< where from: `hmi <address>`, `socket`, `tool`, `daemon`
    std::string action;    ///< what was done or tried, e.g. `program.release`, `calibration.run`, `file.changed`
    std::string object;    ///< what it was done to: a part, a file, an account
    std::string outcome; ///< `done`, `refused` (not allowed, never attempted) or `failed` (attempted, did not succeed)
    std::string detail;  ///< why refused or failed; what else the entry needs to be read
    std::string before;
    std::string after;
};

/// Which entries: every set field narrows the selection (AND), newest first.
struct AuditQuery {
    std::optional<std::int64_t> sinceMs;  ///< at or after
    std::optional<std::int64_t> untilMs;  ///< before
    std::string who;                      ///< exactly this
    std::string actionPrefix;             ///< `program.` matches every program action
    std::string outcome;                  ///< exactly this
    std::optional<std::int64_t> beforeId; ///< paging: entries with a smaller id
    int limit = 0;                        ///< at most this many; 0 = all
};

class AuditLog {
  public:
    /// Opens or creates the trail (and its folder); `readOnly` never writes (the tool's export).
    /// Throws sqlite::Error naming the file when it cannot be opened or is not an audit trail.
    explicit AuditLog(const std::filesystem::path& file, bool readOnly = false);

    /// Appends durably and returns the entry's id. Thread-safe.
    std::int64_t record(AuditEntry entry);
    std::vector<AuditEntry> select(const AuditQuery& query) const;

    /// The text of a watched file as last recorded (sha256 and content), to see what changed since.
    struct Watched {
        std::string sha256;
        std::string content;
    };
    std::optional<Watched> watched(const std::string& path) const;
    /// Records the watched file's new state (with the entry that says it changed, in one transaction).
    std::int64_t recordFileChange(const std::string& path, const Watched& now, AuditEntry entry);

    const std::filesystem::path& file() const { return file_; }

  private:
    std::filesystem::path file_;
    mutable std::mutex mutex_;
    sqlite::Connection db_;
};

/// How the trail names a Unix user: `unix:<name>`, `unix:uid <n>` when the uid has no name.
std::string unixUserName(unsigned uid);

nlohmann::json toJson(const AuditEntry& entry);
/// RFC 4180 CSV with a header row: id, time (UTC, ISO 8601), who, role, source, action, object, outcome,
/// detail, before, after.
std::string auditCsv(const std::vector<AuditEntry>& entries);

} // namespace hg::store
