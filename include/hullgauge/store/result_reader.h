// Reading the station's result store (SQLite; the daemon writes it, see
// docs/daemon.md "Result store"): one query type and one row shape for every
// reader — `hullgauge ctl results`, the gauge studies, the exports and the web
// HMI's JSON API (docs/hmi.md). A row is the JSON object of docs/daemon.md
// ("results"): id, time, started_unix_ms, trigger_seq, manual, serial, program,
// part, verdict, fault_code, cycle_ms, landmarks_failed, landmarks_total,
// landmarks, timing, images, alignment, simulation, purpose, program_version,
// program_sha256 (the release the part was judged with; null for a draft).
//
// Stores of every schema version are read: a column an older version lacks
// reads as its default (alignment and simulation null, purpose production,
// program_version and program_sha256 null), a table it lacks as empty (health).
#pragma once

#include "hullgauge/store/sqlite.h"

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

namespace hg::store {

/// Which rows: every set field narrows the selection (AND).
struct ResultQuery {
    std::optional<int> program;
    std::string serial;                   ///< exactly this serial
    std::string serialContains;           ///< a substring of the serial (the HMI's search)
    std::vector<std::string> verdicts;    ///< any of these (pass, fail, aborted, error); empty = any
    std::string purpose;                  ///< production, master or study; empty = any
    std::optional<bool> manual;           ///< maintenance-triggered cycles (ctl trigger) or PLC cycles
    std::optional<std::int64_t> sinceMs;  ///< started at or after (Unix ms, UTC)
    std::optional<std::int64_t> untilMs;  ///< started before
    std::optional<std::int64_t> beforeId; ///< paging: rows with a smaller id
    std::optional<std::int64_t> afterId;  ///< paging: rows with a larger id
    int limit = 0;                        ///< at most this many rows; 0 = all
    bool newestFirst = true;              ///< order by id descending (else ascending)
};

/// Which rows of the table `health` (docs/health.md, "In the daemon"): the
/// station's health figures per cycle, by the cycle's start time.
struct HealthQuery {
    std::optional<std::int64_t> sinceMs; ///< cycles started at or after (Unix ms, UTC)
    std::optional<std::int64_t> untilMs; ///< started before
    int limit = 0;                       ///< the newest this many of the window; 0 = all
};

/// "2026-12-02", "2026-12-02T10:30", "2026-12-02T10:30:05" (optionally with
/// a space for the T and a trailing Z), UTC, to ms since 1970 — the form of
/// every --since/--until and of the JSON API's since/until. Throws
/// hg::InputError naming `field` otherwise (a date that does not exist too).
std::int64_t parseUtc(const std::string& text, const std::string& field);

/// The filters of a result selection as the user writes them: the web HMI's
/// query parameters (docs/hmi.md, "JSON API") and `hullgauge export`'s options
/// (docs/export.md, "The command") — the same names, values and refusals. An
/// absent filter selects every row.
struct SelectionFilters {
    std::optional<std::string> program; ///< a part program number 1..65535
    std::optional<std::string> serial;  ///< a part of the serial, at most 64 characters
    std::optional<std::string> verdict; ///< any, pass, fail, aborted or error
    std::optional<std::string> purpose; ///< any, production, master or study
    std::optional<std::string> since;   ///< parseUtc's forms
    std::optional<std::string> until;
};

/// The query of `filters`. A value that is none of the above is hg::InputError
/// naming the filter as `prefix` + its name ("verdict" for the HMI, "--verdict"
/// on the command line) and the value.
ResultQuery parseSelection(const SelectionFilters& filters, const std::string& prefix);

/// ms since 1970 as the store writes `started_utc`: "2026-12-02T10:30:05.250Z"
/// (ISO 8601, UTC, milliseconds).
std::string formatUtc(std::int64_t unixMs);

/// A result store opened read-only (SQLite's WAL lets it read while the
/// daemon commits). Not thread-safe: one reader per thread.
class ResultReader {
  public:
    /// Throws hg::InputError naming the file when there is no database there
    /// or it cannot be opened read-only.
    explicit ResultReader(const std::filesystem::path& file);
    ResultReader(const ResultReader&) = delete;
    ResultReader& operator=(const ResultReader&) = delete;

    /// The rows of `query`. Throws hg::FaultError when SQLite fails and
    /// hg::InputError when the file is not a result store or a row is damaged.
    std::vector<nlohmann::json> select(const ResultQuery& query) const;
    std::int64_t count(const ResultQuery& query) const;
    /// The row with this id, if any.
    std::optional<nlohmann::json> byId(std::int64_t id) const;
    /// The health rows of `query`, oldest first: `inspection_id`, `time` (the
    /// cycle's start, as `started_utc`), `unix_ms`, `backlight`, `uniformity`,
    /// `dust_specks`, `edge_width_px`, `contrast`, `noise`,
    /// `predicted_sigma_px` (null where not measured) and `warnings` (the
    /// figures' names). None from a store older than schema version 7.
    std::vector<nlohmann::json> health(const HealthQuery& query) const;
    const std::filesystem::path& file() const { return file_; }

  private:
    std::filesystem::path file_;
    sqlite::Connection db_;
};

} // namespace hg::store
