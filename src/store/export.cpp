// The exports of docs/export.md: every field written and its meaning there.
#include "hullgauge/store/export.h"

#include "hullgauge/common/clock.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/json.h"
#include "hullgauge/store/result_reader.h"
#include "hullgauge/study/gauge_study.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <optional>
#include <string>
#include <utility>

namespace hg::store {

using nlohmann::json;

ExportFormat parseExportFormat(std::string_view text)
{
    if (auto format = parseEnum<ExportFormat>(text)) return *format;
    throw InputError("", "format",
                     "'" + std::string(text) + "' is not an export format (" + enumNameList<ExportFormat>() + ")");
}

std::string_view contentType(ExportFormat format)
{
    switch (format) {
    case ExportFormat::Aqdef:
        return "text/plain; charset=ISO-8859-1";
    case ExportFormat::Csv:
        return "text/csv; charset=utf-8";
    case ExportFormat::Json:
        return "application/json";
    }
    return "application/json";
}

std::string_view fileExtension(ExportFormat format)
{
    switch (format) {
    case ExportFormat::Aqdef:
        return "dfq";
    case ExportFormat::Csv:
        return "csv";
    case ExportFormat::Json:
        return "json";
    }
    return "json";
}

/// A field quoted when it holds a comma, a quote, CR or LF; quotes doubled (RFC 4180, 2.6–2.7).
std::string csvField(const std::string& text)
{
    if (text.find_first_of(",\"\r\n") == std::string::npos) return text;
    std::string quoted = "\"";
    for (char c : text) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
    return quoted + "\"";
}

namespace {

// ---------------------------------------------------------------- the rows

/// One landmark of one cycle as every format takes it.
struct Measurement {
    std::string id;
    std::optional<inspect::LandmarkStatus> status; ///< none when the entry names none
    std::optional<inspect::Decision> decision;
    study::Zone zone;
    std::optional<double> value;                               ///< none for a landmark the cycle could not place
    study::ValueSource source = study::ValueSource::Deviation; ///< where `value` comes from
    const json* entry = nullptr;                               ///< the stored entry (deviation_mm, ... for CSV)
};

std::string resultName(const json& row)
{
    return "result " + std::to_string(row.value("id", std::int64_t{0}));
}

bool isNumber(const json& entry, const char* key)
{
    return entry.contains(key) && entry[key].is_number();
}

/// The measurements of a row in its order; malformed landmarks are bad input naming the result.
std::vector<Measurement> measurementsOf(const json& row)
{
    const auto field = resultName(row) + ".landmarks";
    std::vector<Measurement> out;
    if (!row.contains("landmarks")) return out;
    const auto& landmarks = row.at("landmarks");
    if (!landmarks.is_array()) throw InputError("", field, "expected a JSON array of landmarks");
    for (const auto& entry : landmarks) {
        if (!entry.is_object() || !entry.contains("id") || !entry["id"].is_string())
            throw InputError("", field, "a landmark without a string \"id\"");
        Measurement m;
        m.id = entry["id"].get<std::string>();
        m.status = study::statusOf(entry, field + "." + m.id);
        m.decision = study::decisionOf(entry, field + "." + m.id);
        m.zone = study::zoneOf(entry, field + "." + m.id);
        m.entry = &entry;
        // A landmark the bracket could not place, or one the traversal never
        // reached, has no value (docs/inspection.md "Result JSON extensions").
        using enum inspect::LandmarkStatus;
        const bool placed = m.status != NotFound && m.status != NotObservable && m.status != NotInspected;
        if (placed && isNumber(entry, "deviation_mm")) {
            m.value = entry["deviation_mm"].get<double>();
        } else if (placed && isNumber(entry, "error_mm")) {
            m.value = entry["error_mm"].get<double>();
            m.source = study::ValueSource::BracketMiddle;
        }
        out.push_back(std::move(m));
    }
    return out;
}

bool isSimulated(const json& row)
{
    return row.contains("simulation") && !row["simulation"].is_null();
}

/// Why a cycle stays out of quality statistics (docs/export.md), empty when it counts:
/// aborted and error verdicts, master and study cycles (docs/study.md), the simulated
/// line (unless the settings include it) and maintenance-triggered cycles.
std::string exclusionReason(const json& row, const ExportSettings& settings)
{
    std::string reasons;
    auto add = [&](const std::string& r) { reasons += (reasons.empty() ? "" : ", ") + r; };
    const auto verdict = row.value("verdict", std::string("error"));
    if (verdict != "pass" && verdict != "fail") add("verdict " + verdict);
    const auto purpose = row.value("purpose", std::string("production"));
    if (purpose != "production") add("purpose " + purpose);
    if (isSimulated(row) && !settings.includeSimulated) add("simulated");
    if (row.value("manual", false)) add("manual trigger");
    return reasons;
}

std::int64_t startedMs(const json& row)
{
    return row.value("started_unix_ms", std::int64_t{0});
}

// ---------------------------------------------------------------- CSV (RFC 4180)

// The release columns come last, so every earlier column keeps its place (docs/export.md).
constexpr const char* kCsvColumns[] = {"result_id",      "time",     "serial",           "program",
                                       "part",           "purpose",  "verdict",          "landmark",
                                       "status",         "value_mm", "value_source",     "deviation_mm",
                                       "uncertainty_mm", "error_mm", "lower_mm",         "upper_mm",
                                       "decision",       "excluded", "exclusion_reason", "program_version",
                                       "program_sha256", "simulated"};

/// A number as JSON writes it: the shortest text that reads back as the same double.
std::string csvNumber(const json& v)
{
    return v.is_number() ? v.dump() : std::string();
}

std::string csvNumber(std::optional<double> v)
{
    return v ? json(*v).dump() : std::string();
}

void writeCsvLine(std::ostream& out, const std::vector<std::string>& cells)
{
    for (std::size_t i = 0; i < cells.size(); ++i) out << (i ? "," : "") << csvField(cells[i]);
    out << "\r\n";
}

void writeCsv(std::ostream& out, const std::vector<json>& rows, const ExportSettings& settings)
{
    writeCsvLine(out, {std::begin(kCsvColumns), std::end(kCsvColumns)});
    for (const auto& row : rows) {
        const auto reason = exclusionReason(row, settings);
        const std::vector<std::string> cycle{std::to_string(row.value("id", std::int64_t{0})),
                                             formatUtc(startedMs(row)),
                                             row.value("serial", std::string()),
                                             std::to_string(row.value("program", 0)),
                                             row.value("part", std::string()),
                                             row.value("purpose", std::string("production")),
                                             row.value("verdict", std::string())};
        // The program's release the part was judged with: empty for a draft (docs/commissioning.md).
        const json version = row.value("program_version", json());
        const json digest = row.value("program_sha256", json());
        const std::vector<std::string> tail{reason.empty() ? "false" : "true", reason,
                                            version.is_number_integer() ? version.dump() : std::string(),
                                            digest.is_string() ? digest.get<std::string>() : std::string(),
                                            // Whatever the selection: a simulated cycle included is marked as such.
                                            isSimulated(row) ? "true" : "false"};
        const auto measurements = measurementsOf(row);
        // A cycle without landmarks (an aborted one, mostly) still has its row,
        // the ten landmark cells (landmark ... decision) empty.
        if (measurements.empty()) {
            auto cells = cycle;
            cells.resize(cycle.size() + 10);
            cells.insert(cells.end(), tail.begin(), tail.end());
            writeCsvLine(out, cells);
        }
        for (const auto& m : measurements) {
            const auto& e = *m.entry;
            auto cells = cycle;
            cells.insert(cells.end(),
                         {m.id, m.status ? std::string(enumName(*m.status)) : std::string(), csvNumber(m.value),
                          m.value ? std::string(enumName(m.source)) : std::string(),
                          csvNumber(e.value("deviation_mm", json())), csvNumber(e.value("uncertainty_mm", json())),
                          csvNumber(e.value("error_mm", json())), csvNumber(json(m.zone.lower)),
                          csvNumber(json(m.zone.upper)),
                          m.decision ? std::string(enumName(*m.decision)) : std::string()});
            cells.insert(cells.end(), tail.begin(), tail.end());
            writeCsvLine(out, cells);
        }
    }
}

// ---------------------------------------------------------------- JSON

void writeJson(std::ostream& out, const std::vector<json>& rows, std::int64_t exportedUnixMs)
{
    const json doc{
        {"format", "hullgauge-results"}, {"version", 1}, {"exported", formatUtc(exportedUnixMs)}, {"results", rows}};
    // A serial that is not UTF-8 is written with U+FFFD rather than refused.
    out << dumpJson(doc) << "\n";
}

// ---------------------------------------------------------------- AQDEF (Q-DAS DFQ)

/// Field lengths of the Q-DAS ASCII transfer format's definitions (docs/export.md).
constexpr std::size_t kPartNumberChars = 30;      // K1001
constexpr std::size_t kPartDescriptionChars = 80; // K1002
constexpr std::size_t kCharNumberChars = 40;      // K2001
constexpr std::size_t kCharDescriptionChars = 80; // K2002
constexpr std::size_t kPartIdentChars = 40;       // K0014
constexpr std::size_t kTextChars = 255;           // K0009

/// K0002: 0 a valid value, 129 a value shown but left out of every calculation,
/// 255 a placeholder where a cycle has no value.
constexpr int kAttributeValid = 0;
constexpr int kAttributeExcluded = 129;
constexpr int kAttributePlaceholder = 255;
/// K0015: 0 ongoing (production) measurement, 10 special measurement.
constexpr int kReasonProduction = 0;
constexpr int kReasonSpecial = 10;

/// UTF-8 text as ISO 8859-1, the 8-bit text of the transfer format, at most `maxChars`
/// characters: a control character becomes a space (a line break would end the
/// K-field line), a character outside Latin-1 or a byte that is not UTF-8 '?'.
std::string dfqText(const std::string& text, std::size_t maxChars)
{
    std::string out;
    for (std::size_t i = 0; i < text.size() && out.size() < maxChars;) {
        const auto c = static_cast<unsigned char>(text[i]);
        std::size_t length = c < 0x80 ? 1 : (c >= 0xC2 && c <= 0xDF ? 2 : (c >= 0xE0 && c <= 0xEF ? 3 : 4));
        if (c >= 0x80 && (c < 0xC2 || c > 0xF4)) length = 0;
        std::uint32_t cp = length == 1 ? c : (c & (0xFFu >> (length + 1)));
        for (std::size_t k = 1; k < length; ++k) {
            const auto next = i + k < text.size() ? static_cast<unsigned char>(text[i + k]) : 0;
            if ((next & 0xC0) != 0x80) length = 0;
            cp = (cp << 6) | (next & 0x3Fu);
        }
        if (length == 0) {
            out += '?';
            ++i;
            continue;
        }
        if (cp < 0x20 || (cp >= 0x7F && cp < 0xA0))
            out += ' ';
        else
            out += cp <= 0xFF ? static_cast<char>(cp) : '?';
        i += length;
    }
    return out;
}

/// A value in mm, fixed point to 1 nm (no exponent: the format's F fields), trailing zeros dropped.
std::string dfqNumber(double v)
{
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.6f", v);
    std::string s = buf;
    s.erase(s.find_last_not_of('0') + 1);
    if (s.back() == '.') s.pop_back();
    return s == "-0" ? "0" : s;
}

/// K0004: dd.mm.yyyy/hh:mm:ss, here in UTC as the store keeps its times.
std::string dfqTime(std::int64_t unixMs)
{
    const auto seconds = static_cast<std::time_t>((unixMs - ((unixMs % 1000) + 1000) % 1000) / 1000);
    std::tm tm{};
    gmtime_r(&seconds, &tm);
    char buf[32];
    std::strftime(buf, sizeof buf, "%d.%m.%Y/%H:%M:%S", &tm);
    return buf;
}

void kLine(std::ostream& out, const char* key, std::size_t index, const std::string& value)
{
    out << key << '/' << index << ' ' << value << "\r\n";
}

/// One characteristic: a landmark with one tolerance zone. Its values come from
/// either method, the method recorded with each value (K0009).
struct Characteristic {
    std::string landmark;
    study::Zone zone;
    std::string number; ///< K2001
};

/// One AQDEF part: the cycles of one program and part name.
struct Part {
    int program = 0;
    std::string name;
    std::vector<const json*> rows;
    std::vector<std::vector<Measurement>> measurements; ///< per row
    std::vector<Characteristic> characteristics;
};

bool sameCharacteristic(const Characteristic& c, const Measurement& m)
{
    return c.landmark == m.id && c.zone == m.zone;
}

/// Per landmark, in the order the landmarks first appear, one characteristic
/// for each tolerance zone its values come with (whatever their method); a
/// landmark never measured gets one of its first zone, all placeholders.
std::vector<Characteristic> characteristicsOf(const Part& part)
{
    std::vector<std::string> ids;
    std::vector<Characteristic> found;
    std::vector<std::pair<std::string, study::Zone>> firstZone;
    for (const auto& row : part.measurements)
        for (const auto& m : row) {
            if (std::find(ids.begin(), ids.end(), m.id) == ids.end()) {
                ids.push_back(m.id);
                firstZone.emplace_back(m.id, m.zone);
            }
            if (!m.value) continue;
            const auto same = [&](const Characteristic& c) { return sameCharacteristic(c, m); };
            if (std::none_of(found.begin(), found.end(), same)) found.push_back({m.id, m.zone, m.id});
        }
    std::vector<Characteristic> out;
    for (std::size_t i = 0; i < ids.size(); ++i) {
        std::vector<Characteristic> mine;
        for (const auto& c : found)
            if (c.landmark == ids[i]) mine.push_back(c);
        if (mine.empty()) mine.push_back({ids[i], firstZone[i].second, ids[i]});
        // Several zones of one landmark (an edited program): "id~1", "id~2", ... (the number must be unique).
        for (std::size_t k = 0; mine.size() > 1 && k < mine.size(); ++k)
            mine[k].number = ids[i] + "~" + std::to_string(k + 1);
        out.insert(out.end(), mine.begin(), mine.end());
    }
    return out;
}

/// The rows grouped into parts by program and part name, in the order they first appear.
std::vector<Part> partsOf(const std::vector<json>& rows)
{
    std::vector<Part> parts;
    for (const auto& row : rows) {
        const int program = row.value("program", 0);
        const auto name = row.value("part", std::string());
        auto it = std::find_if(parts.begin(), parts.end(),
                               [&](const Part& p) { return p.program == program && p.name == name; });
        if (it == parts.end()) it = parts.insert(parts.end(), Part{program, name, {}, {}, {}});
        it->rows.push_back(&row);
        it->measurements.push_back(measurementsOf(row));
    }
    for (auto& p : parts) p.characteristics = characteristicsOf(p);
    return parts;
}

std::string describe(const Characteristic& c)
{
    return c.landmark + ": deviation along the outward normal; each value's method in K0009";
}

/// K0009 of a value: its method (docs/export.md), why the cycle is excluded, and
/// that a simulated cycle was included on request; empty when there is nothing to say.
std::string valueText(const json& row, const Measurement* m, const ExportSettings& settings)
{
    std::string text;
    const auto add = [&](const std::string& part) { text += (text.empty() ? "" : "; ") + part; };
    if (m)
        add(m->source == study::ValueSource::Deviation ? "method deviation_mm (sub-voxel)"
                                                       : "method error_mm (middle of the voxel bracket)");
    if (const auto reason = exclusionReason(row, settings); !reason.empty()) add("excluded: " + reason);
    if (isSimulated(row) && settings.includeSimulated) add("simulated, included (--include-simulated)");
    return text;
}

void writeCharacteristic(std::ostream& out, const Characteristic& c, std::size_t i)
{
    kLine(out, "K2001", i, dfqText(c.number, kCharNumberChars));
    kLine(out, "K2002", i, dfqText(describe(c), kCharDescriptionChars));
    kLine(out, "K2004", i, "0"); // a variable (measured) characteristic
    kLine(out, "K2101", i, "0"); // nominal: the values are deviations from the CAD surface
    kLine(out, "K2110", i, dfqNumber(c.zone.lower));
    kLine(out, "K2111", i, dfqNumber(c.zone.upper));
    kLine(out, "K2142", i, "mm");
}

/// One cycle's value of characteristic `i`: its measurement when the cycle has
/// one in this characteristic's zone, else a placeholder.
void writeValue(std::ostream& out, const json& row, const std::vector<Measurement>& measurements,
                const Characteristic& c, std::size_t i, const ExportSettings& settings)
{
    const auto it = std::find_if(measurements.begin(), measurements.end(),
                                 [&](const Measurement& m) { return m.value && sameCharacteristic(c, m); });
    const auto reason = exclusionReason(row, settings);
    const int attribute =
        it == measurements.end() ? kAttributePlaceholder : (reason.empty() ? kAttributeValid : kAttributeExcluded);
    kLine(out, "K0001", i, it == measurements.end() ? "0" : dfqNumber(*it->value));
    kLine(out, "K0002", i, std::to_string(attribute));
    kLine(out, "K0004", i, dfqTime(startedMs(row)));
    const auto serial = dfqText(row.value("serial", std::string()), kPartIdentChars);
    if (!serial.empty()) kLine(out, "K0014", i, serial);
    const bool production = row.value("purpose", std::string("production")) == "production";
    kLine(out, "K0015", i, std::to_string(production ? kReasonProduction : kReasonSpecial));
    const auto text = valueText(row, it == measurements.end() ? nullptr : &*it, settings);
    if (!text.empty()) kLine(out, "K0009", i, dfqText(text, kTextChars));
}

/// The K-field form of a DFQ file: K0100, then per part its part fields, its
/// characteristics and the values of its cycles, oldest first; characteristic
/// indices run over the whole file.
void writeAqdef(std::ostream& out, const std::vector<json>& rows, const ExportSettings& settings)
{
    const auto parts = partsOf(rows);
    std::size_t total = 0;
    for (const auto& p : parts) total += p.characteristics.size();
    out << "K0100 " << total << "\r\n";
    std::size_t first = 1;
    for (std::size_t p = 0; p < parts.size(); ++p) {
        const auto& part = parts[p];
        kLine(out, "K1001", p + 1, dfqText(std::to_string(part.program), kPartNumberChars));
        if (!part.name.empty()) kLine(out, "K1002", p + 1, dfqText(part.name, kPartDescriptionChars));
        for (std::size_t k = 0; k < part.characteristics.size(); ++k)
            writeCharacteristic(out, part.characteristics[k], first + k);
        for (std::size_t r = 0; r < part.rows.size(); ++r)
            for (std::size_t k = 0; k < part.characteristics.size(); ++k)
                writeValue(out, *part.rows[r], part.measurements[r], part.characteristics[k], first + k, settings);
        first += part.characteristics.size();
    }
}

} // namespace

void writeExport(std::ostream& out, ExportFormat format, const std::vector<json>& rows, std::int64_t exportedUnixMs,
                 const ExportSettings& settings)
{
    switch (format) {
    case ExportFormat::Aqdef:
        writeAqdef(out, rows, settings);
        return;
    case ExportFormat::Csv:
        writeCsv(out, rows, settings);
        return;
    case ExportFormat::Json:
        writeJson(out, rows, exportedUnixMs);
        return;
    }
}

void writeExport(std::ostream& out, ExportFormat format, const std::vector<json>& rows, const ExportSettings& settings)
{
    writeExport(out, format, rows, Clock::steady().wallMs(), settings);
}

} // namespace hg::store
