// The quality-data exports of the result store (docs/export.md), in the
// formats plants load into their SPC systems: AQDEF (the Q-DAS ASCII transfer
// format, one .dfq file), CSV (RFC 4180, one row per landmark measurement) and
// JSON (the stored rows). Formatting on values only: the caller selects the
// rows (ResultReader::select, oldest first) and writes the file — `hullgauge
// export` atomically, the web HMI as a download (docs/hmi.md).
//
// A row is the object ResultReader::select returns (docs/daemon.md, "Results"); the
// writers read id, started_unix_ms, serial, program, part, verdict, purpose,
// manual, simulation, landmarks and (CSV) program_version and program_sha256. The value of a landmark is its
// `deviation_mm` when the row has one, else its `error_mm` (the middle of the
// voxel bracket); a landmark `not_found`, `not_observable` or `not_inspected`
// has none. Its tolerance zone is study::zoneOf's (limits_mm or ±tolerance_mm).
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <ostream>
#include <string_view>
#include <vector>

#include "hullgauge/common/enum_names.h"

namespace hg::store {

enum class ExportFormat { Aqdef, Csv, Json };
constexpr auto nameTable(ExportFormat)
{
    using enum ExportFormat;
    return std::to_array<EnumName<ExportFormat>>({{Aqdef, "aqdef"}, {Csv, "csv"}, {Json, "json"}});
}

/// "aqdef", "csv" or "json"; anything else is hg::InputError (field "format")
/// naming the text and the formats there are.
ExportFormat parseExportFormat(std::string_view text);
/// One CSV field: quoted when it holds a comma, a quote, CR or LF, quotes doubled (RFC 4180, 2.6–2.7).
std::string csvField(const std::string& text);
/// The HTTP Content-Type of a download: text/plain; charset=ISO-8859-1 for
/// AQDEF (8-bit text, docs/export.md), text/csv; charset=utf-8, application/json.
std::string_view contentType(ExportFormat format);
/// "dfq", "csv", "json".
std::string_view fileExtension(ExportFormat format);

/// What the writers decide beyond the rows (docs/export.md).
struct ExportSettings {
    /// Cycles of the simulated line count as measurements (the demo's data tried in an SPC
    /// program): not excluded for being simulated, and marked so in AQDEF's value text
    /// (K0009). Off by default: the simulated line is no production.
    bool includeSimulated = false;
};

/// Writes `rows` in `format`, in their order. AQDEF is written in ISO 8859-1,
/// CSV and JSON in UTF-8 (docs/export.md). JSON's `exported` is
/// `exportedUnixMs`; the overload without it takes the system clock. Throws
/// hg::InputError naming the result and landmark when a row's landmarks are
/// malformed (no id, no tolerance zone); `out` then holds a part of the export,
/// so write to a buffer (std::ostringstream) and copy it to the file or the
/// response once this returns.
void writeExport(std::ostream& out, ExportFormat format, const std::vector<nlohmann::json>& rows,
                 const ExportSettings& settings = {});
void writeExport(std::ostream& out, ExportFormat format, const std::vector<nlohmann::json>& rows,
                 std::int64_t exportedUnixMs, const ExportSettings& settings = {});

} // namespace hg::store
