#include "hullgauge/store/result_reader.h"

#include "hullgauge/common/error.h"
#include "hullgauge/common/file_kind.h"
#include "result_rows.h"

#include <algorithm>
#include <array>
#include <charconv>
#include <cstdio>
#include <ctime>
#include <set>

namespace hg::store {
namespace {

using nlohmann::json;

std::set<std::string> columnsOf(const sqlite::Connection& db, const std::string& file)
{
    auto info = db.prepare("PRAGMA table_info(inspections)");
    std::set<std::string> columns;
    while (info.step()) columns.insert(info.text(1));
    if (columns.empty()) throw InputError(file, "", "holds no inspections table: not a result store");
    return columns;
}

/// The SELECT list of one row; columns of later schema versions read as
/// their defaults in older stores (docs/daemon.md, "Result store").
std::string selectList(const std::set<std::string>& columns)
{
    // In rowJson's order, each with what a store without the column reads.
    static constexpr std::array<std::pair<const char*, const char*>, 23> kColumns{{
        {"id", "0"},
        {"started_utc", "''"},
        {"started_unix_ms", "0"},
        {"trigger_seq", "0"},
        {"manual", "0"},
        {"serial", "''"},
        {"program", "0"},
        {"part", "''"},
        {"verdict", "'error'"},
        {"fault_code", "0"},
        {"cycle_ms", "0"},
        {"landmarks_failed", "0"},
        {"landmarks_total", "0"},
        {"landmarks_json", "'[]'"},
        {"timing_json", "'{}'"},
        {"images_dir", "''"},
        {"alignment_json", "'null'"},
        {"simulation_json", "'null'"},
        {"purpose", "'production'"},
        {"program_version", "NULL"},
        {"program_sha256", "''"},
        {"correction_id", "''"},
        {"temperature_c", "NULL"},
    }};
    std::string list;
    for (const auto& [column, fallback] : kColumns)
        list += (list.empty() ? "" : ", ") + std::string(columns.count(column) ? column : fallback);
    return list;
}

/// The WHERE clause of `q` and its parameters, bound as text in order.
std::string whereClause(const ResultQuery& q, const std::set<std::string>& columns, std::vector<std::string>& params)
{
    std::string sql = " WHERE 1";
    auto add = [&](const char* clause, std::string value) {
        sql += clause;
        params.push_back(std::move(value));
    };
    if (q.program) add(" AND program = CAST(? AS INTEGER)", std::to_string(*q.program));
    if (!q.serial.empty()) add(" AND serial = ?", q.serial);
    // instr() rather than LIKE: a serial's own % or _ is no wildcard.
    if (!q.serialContains.empty()) add(" AND instr(serial, ?) > 0", q.serialContains);
    if (!q.verdicts.empty()) {
        sql += " AND verdict IN (";
        for (std::size_t i = 0; i < q.verdicts.size(); ++i) {
            sql += i ? ", ?" : "?";
            params.push_back(q.verdicts[i]);
        }
        sql += ")";
    }
    // A store before schema version 3 knows production cycles only.
    if (!q.purpose.empty() && columns.count("purpose"))
        add(" AND purpose = ?", q.purpose);
    else if (!q.purpose.empty() && q.purpose != "production")
        sql += " AND 0";
    if (q.manual) add(" AND manual = CAST(? AS INTEGER)", *q.manual ? "1" : "0");
    if (q.sinceMs) add(" AND started_unix_ms >= CAST(? AS INTEGER)", std::to_string(*q.sinceMs));
    if (q.untilMs) add(" AND started_unix_ms < CAST(? AS INTEGER)", std::to_string(*q.untilMs));
    if (q.beforeId) add(" AND id < CAST(? AS INTEGER)", std::to_string(*q.beforeId));
    if (q.afterId) add(" AND id > CAST(? AS INTEGER)", std::to_string(*q.afterId));
    return sql;
}

void bindText(sqlite::Statement& s, const std::vector<std::string>& params)
{
    for (std::size_t i = 0; i < params.size(); ++i) s.bind(static_cast<int>(i + 1), params[i]);
}

/// A stored JSON column; a value that does not parse is a damaged row, named.
json parsed(const sqlite::Statement& s, int i, const std::string& file, const char* column)
{
    auto value = json::parse(s.text(i), nullptr, false);
    if (value.is_discarded())
        throw InputError(file, "inspection " + std::to_string(s.int64(0)) + "." + column, "not valid JSON");
    return value;
}

json rowJson(const sqlite::Statement& s, const std::string& file)
{
    return {{"id", s.int64(0)},
            {"time", s.text(1)},
            {"started_unix_ms", s.int64(2)},
            {"trigger_seq", s.integer(3)},
            {"manual", s.integer(4) != 0},
            {"serial", s.text(5)},
            {"program", s.integer(6)},
            {"part", s.text(7)},
            {"verdict", s.text(8)},
            {"fault_code", s.integer(9)},
            {"cycle_ms", s.int64(10)},
            {"landmarks_failed", s.integer(11)},
            {"landmarks_total", s.integer(12)},
            {"landmarks", parsed(s, 13, file, "landmarks_json")},
            {"timing", parsed(s, 14, file, "timing_json")},
            {"images", s.text(15)},
            {"alignment", parsed(s, 16, file, "alignment_json")},
            {"simulation", parsed(s, 17, file, "simulation_json")},
            {"purpose", s.text(18)},
            {"program_version", s.isNull(19) ? json() : json(s.integer(19))},
            {"program_sha256", s.text(20).empty() ? json() : json(s.text(20))},
            {"correction_id", s.text(21).empty() ? json() : json(s.text(21))},
            {"temperature_c", s.isNull(22) ? json() : json(s.real(22))}};
}

} // namespace

std::int64_t parseUtc(const std::string& text, const std::string& field)
{
    std::tm tm{};
    int consumed = 0;
    const int fields = std::sscanf(text.c_str(), "%4d-%2d-%2d%n", &tm.tm_year, &tm.tm_mon, &tm.tm_mday, &consumed);
    std::string rest = fields == 3 ? text.substr(static_cast<std::size_t>(consumed)) : std::string("?");
    if (!rest.empty() && (rest[0] == 'T' || rest[0] == ' ')) {
        int more = 0;
        if (std::sscanf(rest.c_str() + 1, "%2d:%2d%n:%2d%n", &tm.tm_hour, &tm.tm_min, &more, &tm.tm_sec, &more) < 2)
            rest = "?";
        else
            rest = rest.substr(static_cast<std::size_t>(more) + 1);
    }
    if (rest == "Z") rest.clear();
    const std::tm asWritten = tm;
    tm.tm_year -= 1900;
    tm.tm_mon -= 1;
    const std::time_t t = timegm(&tm);
    // timegm normalises 2026-02-30 to March: a date that does not round-trip is no date.
    const bool valid = rest.empty() && tm.tm_year + 1900 == asWritten.tm_year && tm.tm_mon + 1 == asWritten.tm_mon &&
                       tm.tm_mday == asWritten.tm_mday && tm.tm_hour == asWritten.tm_hour &&
                       tm.tm_min == asWritten.tm_min && tm.tm_sec == asWritten.tm_sec;
    if (!valid) throw InputError("", field, "'" + text + "' is not a UTC time YYYY-MM-DD[THH:MM[:SS]][Z]");
    return static_cast<std::int64_t>(t) * 1000;
}

namespace {

/// `value` when it is one of `allowed`, else InputError naming the field and the allowed values.
const std::string& oneOf(const std::string& value, const std::vector<std::string>& allowed, const std::string& field)
{
    if (std::find(allowed.begin(), allowed.end(), value) != allowed.end()) return value;
    std::string list;
    for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
    throw InputError("", field, "'" + value + "' is not one of " + list);
}

} // namespace

ResultQuery parseSelection(const SelectionFilters& filters, const std::string& prefix)
{
    ResultQuery q;
    if (const auto& text = filters.program) {
        int number = 0;
        const auto [end, ec] = std::from_chars(text->data(), text->data() + text->size(), number);
        if (ec != std::errc() || end != text->data() + text->size() || number < 1 || number > 65535)
            throw InputError("", prefix + "program", "'" + *text + "' is not a whole number in 1..65535");
        q.program = number;
    }
    if (filters.serial) {
        if (filters.serial->size() > 64) throw InputError("", prefix + "serial", "longer than 64 characters");
        q.serialContains = *filters.serial;
    }
    if (filters.verdict &&
        oneOf(*filters.verdict, {"any", "pass", "fail", "aborted", "error"}, prefix + "verdict") != "any")
        q.verdicts = {*filters.verdict};
    if (filters.purpose &&
        oneOf(*filters.purpose, {"any", "production", "master", "study"}, prefix + "purpose") != "any")
        q.purpose = *filters.purpose;
    if (filters.since) q.sinceMs = parseUtc(*filters.since, prefix + "since");
    if (filters.until) q.untilMs = parseUtc(*filters.until, prefix + "until");
    return q;
}

std::string formatUtc(std::int64_t unixMs)
{
    // Floor division: a time before 1970 keeps its milliseconds in 0..999.
    const std::int64_t ms = ((unixMs % 1000) + 1000) % 1000;
    const auto seconds = static_cast<std::time_t>((unixMs - ms) / 1000);
    std::tm tm{};
    gmtime_r(&seconds, &tm);
    char date[32];
    std::strftime(date, sizeof date, "%Y-%m-%dT%H:%M:%S", &tm);
    char out[48];
    std::snprintf(out, sizeof out, "%s.%03dZ", date, static_cast<int>(ms));
    return out;
}

std::vector<json> selectResults(const sqlite::Connection& db, const std::string& file, const ResultQuery& query)
{
    const auto columns = columnsOf(db, file);
    std::vector<std::string> params;
    std::string sql = "SELECT " + selectList(columns) + " FROM inspections" + whereClause(query, columns, params) +
                      (query.newestFirst ? " ORDER BY id DESC" : " ORDER BY id ASC");
    if (query.limit > 0) sql += " LIMIT " + std::to_string(query.limit);
    auto select = db.prepare(sql);
    bindText(select, params);
    std::vector<json> rows;
    while (select.step()) rows.push_back(rowJson(select, file));
    return rows;
}

std::int64_t countResults(const sqlite::Connection& db, const std::string& file, const ResultQuery& query)
{
    const auto columns = columnsOf(db, file);
    std::vector<std::string> params;
    auto count = db.prepare("SELECT COUNT(*) FROM inspections" + whereClause(query, columns, params));
    bindText(count, params);
    if (!count.step()) db.fail();
    return count.int64(0);
}

ResultReader::ResultReader(const std::filesystem::path& file) : file_(file)
{
    if (auto problem = notARegularFile(file); !problem.empty())
        throw InputError(file.string(), "", "no database at " + file.string() + ": " + problem);
    try {
        // Read-only: a reader never migrates an older store, it reads its columns' defaults (selectList).
        db_ = sqlite::open(file, sqlite::Access::Read, "result store " + file.string());
    } catch (const sqlite::Error& e) {
        // The file is the user's (--store, docs/export.md): one SQLite cannot open is bad input.
        throw InputError(file.string(), "", e.reason());
    }
}

namespace {

/// A figure of the table `health`: null where it was not measured.
json figure(const sqlite::Statement& s, int i)
{
    return s.isNull(i) ? json() : json(s.real(i));
}

} // namespace

std::vector<json> selectHealth(const sqlite::Connection& db, const std::string& file, const HealthQuery& query)
{
    // A store before schema version 7 has no health table: nothing was watched.
    auto table = db.prepare("SELECT count(*) FROM sqlite_master WHERE type = 'table' AND name = 'health'");
    if (!table.step() || table.integer(0) == 0) return {};
    // A version 7 store read as it is (a reader never migrates) has no edge bias and no
    // capability figure: null, not measured.
    auto column = db.prepare("SELECT count(*) FROM pragma_table_info('health') WHERE name = 'edge_bias_px'");
    const bool withBias = column.step() && column.integer(0) > 0;
    std::string sql = "SELECT inspection_id, unix_ms, backlight, uniformity, dust_specks, edge_width_px, contrast, "
                      "noise, predicted_sigma_px, warnings, " +
                      std::string(withBias ? "edge_bias_px, capability" : "NULL, NULL") + " FROM health WHERE 1";
    std::vector<std::string> params;
    if (query.sinceMs) {
        sql += " AND unix_ms >= CAST(? AS INTEGER)";
        params.push_back(std::to_string(*query.sinceMs));
    }
    if (query.untilMs) {
        sql += " AND unix_ms < CAST(? AS INTEGER)";
        params.push_back(std::to_string(*query.untilMs));
    }
    // The newest `limit` of the window, then turned oldest first (a chart's order).
    sql += " ORDER BY unix_ms DESC, inspection_id DESC";
    if (query.limit > 0) sql += " LIMIT " + std::to_string(query.limit);
    auto select = db.prepare(sql);
    bindText(select, params);
    std::vector<json> rows;
    while (select.step()) {
        auto warnings = json::parse(select.text(9), nullptr, false);
        if (!warnings.is_array())
            throw InputError(file, "health " + std::to_string(select.int64(0)) + ".warnings", "not a JSON list");
        const std::int64_t unixMs = select.int64(1);
        rows.push_back({{"inspection_id", select.int64(0)},
                        {"time", formatUtc(unixMs)},
                        {"unix_ms", unixMs},
                        {"backlight", figure(select, 2)},
                        {"uniformity", figure(select, 3)},
                        {"dust_specks", figure(select, 4)},
                        {"edge_width_px", figure(select, 5)},
                        {"contrast", figure(select, 6)},
                        {"noise", figure(select, 7)},
                        {"predicted_sigma_px", figure(select, 8)},
                        {"edge_bias_px", figure(select, 10)},
                        {"capability", figure(select, 11)},
                        {"warnings", std::move(warnings)}});
    }
    std::reverse(rows.begin(), rows.end());
    return rows;
}

std::vector<json> ResultReader::health(const HealthQuery& query) const
{
    return selectHealth(db_, file_.string(), query);
}

std::vector<json> ResultReader::select(const ResultQuery& query) const
{
    return selectResults(db_, file_.string(), query);
}

std::int64_t ResultReader::count(const ResultQuery& query) const
{
    return countResults(db_, file_.string(), query);
}

std::optional<json> ResultReader::byId(std::int64_t id) const
{
    ResultQuery q;
    q.afterId = id - 1;
    q.beforeId = id + 1;
    auto rows = select(q);
    if (rows.empty()) return std::nullopt;
    return std::move(rows.front());
}

} // namespace hg::store
