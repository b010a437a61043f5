// The station's shifts (docs/daemon.md, `shifts`): the line view counts the
// current shift's cycles and yield (docs/hmi.md, "Line view"). A shift runs
// from its start, a time of day in the station's local time, to the next
// shift's start; the last runs past midnight into the first. The functions
// take the local time's offset from UTC as a function, so they are tested
// with any zone, never the machine's.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace hg {
class ConfigNode;
}

namespace hg::station {

struct Shift {
    std::string name;
    int startMinute = 0; ///< minutes after local midnight, 0..1439
    bool operator==(const Shift&) const = default;
};

/// Without a `shifts:` list: one shift "day" from 00:00.
std::vector<Shift> defaultShifts();

/// Parses the `shifts:` list ([{name: early, start: "06:00"}, ...]): at least
/// one shift, names unique, starts HH:MM in increasing order. Throws
/// hg::InputError naming file, line and key.
std::vector<Shift> parseShifts(const ConfigNode& node);

/// "06:00" as 360; -1 when `text` is not a time of day HH:MM (00:00..23:59).
int parseTimeOfDay(const std::string& text);

/// The local time's offset from UTC in seconds (east positive) at `unixSeconds`.
using UtcOffset = std::function<std::int64_t(std::int64_t unixSeconds)>;
/// The station's zone (localtime_r: TZ, /etc/localtime).
std::int64_t localUtcOffset(std::int64_t unixSeconds);

/// Which shift (index into `shifts`, sorted by start) a local time of day (minutes after midnight) falls in.
std::size_t shiftAt(const std::vector<Shift>& shifts, int minuteOfDay);

struct ShiftWindow {
    std::size_t index = 0;        ///< into the shifts
    std::int64_t startUnixMs = 0; ///< when the shift began (UTC)
};
/// The shift running at `nowUnixMs` and when it began: a night shift from
/// 22:00 seen at 03:00 began the evening before.
ShiftWindow currentShift(const std::vector<Shift>& shifts, std::int64_t nowUnixMs, const UtcOffset& offset);

} // namespace hg::station
