// The one way numbers are written into messages and reports: as a stream
// writes them with `precision` significant digits (6 by default: 0.125,
// 1e+300, 2448), so every message names a value the same way.
//
// A value with a text of its own (a camera region, a fixture pose, a
// calibration target, a network) has an fmt::formatter beside its type, so a
// message or a log line names it as "{}": fmt::format("region {}", roi). Its
// formatter derives from hg::ValueFormatter: the value takes no format spec
// (fmt refuses "{:>8}" for it), it always reads the same.
#pragma once

#include <string>

#include <spdlog/fmt/fmt.h>

namespace hg {

std::string formatNumber(double v, int precision = 6);

/// The base of the fmt::formatter of a value with a text of its own: it
/// reads no format spec, so "{}" is the only way to write the value.
struct ValueFormatter {
    constexpr fmt::format_parse_context::iterator parse(fmt::format_parse_context& ctx) const { return ctx.begin(); }
};

class Clock;

/// The wall time of `clock` (the steady clock's by default) now as local time
/// in ISO 8601 with the zone's offset ("2026-12-06T13:05:12+01:00"): when a
/// program was released (docs/commissioning.md, "Release").
std::string localTimestamp();
std::string localTimestamp(const Clock& clock);

} // namespace hg
