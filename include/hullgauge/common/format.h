// The one way numbers are written into messages and reports: as a stream
// writes them with `precision` significant digits (6 by default: 0.125,
// 1e+300, 2448), so every message names a value the same way.
#pragma once

#include <string>

namespace hg {

std::string formatNumber(double v, int precision = 6);

class Clock;

/// The wall time of `clock` (the steady clock's by default) now as local time
/// in ISO 8601 with the zone's offset ("2026-12-06T13:05:12+01:00"): when a
/// program was released (docs/commissioning.md, "Release").
std::string localTimestamp();
std::string localTimestamp(const Clock& clock);

} // namespace hg
