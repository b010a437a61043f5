#include "shifts.h"

#include "hullgauge/common/config_node.h"

#include <algorithm>
#include <ctime>
#include <map>

namespace hg::station {
namespace {

constexpr std::int64_t kDaySeconds = 24 * 3600;

std::int64_t floorDiv(std::int64_t a, std::int64_t b)
{
    return a / b - ((a % b != 0) && ((a < 0) != (b < 0)) ? 1 : 0);
}

std::string hhmm(int minute)
{
    const auto two = [](int n) { return std::string{char('0' + n / 10), char('0' + n % 10)}; };
    return two(minute / 60) + ":" + two(minute % 60);
}

bool printableName(const std::string& name)
{
    return !name.empty() && name.size() <= 32 && std::all_of(name.begin(), name.end(), [](char c) {
        return static_cast<unsigned char>(c) >= 0x20 && c != 0x7f;
    });
}

} // namespace

std::vector<Shift> defaultShifts()
{
    return {{"day", 0}};
}

int parseTimeOfDay(const std::string& text)
{
    if (text.size() != 5 || text[2] != ':') return -1;
    for (int i : {0, 1, 3, 4})
        if (text[i] < '0' || text[i] > '9') return -1;
    const int h = (text[0] - '0') * 10 + (text[1] - '0');
    const int m = (text[3] - '0') * 10 + (text[4] - '0');
    return h < 24 && m < 60 ? h * 60 + m : -1;
}

std::vector<Shift> parseShifts(const ConfigNode& node)
{
    if (!node.isSequence() || node.size() == 0)
        node.fail("expected a list of shifts such as [{name: early, start: \"06:00\"}, {name: late, start: "
                  "\"14:00\"}]");
    std::vector<Shift> shifts;
    std::map<std::string, std::string> firstAt; // name -> where it was first given
    for (const auto& item : node.items()) {
        if (!item.isMap()) item.fail("expected a shift {name: NAME, start: \"HH:MM\"}");
        item.allowOnlyKeys({"name", "start"});
        const auto nameNode = item["name"];
        Shift s{nameNode.asString(), 0};
        if (!printableName(s.name)) nameNode.fail("a shift's name is 1 to 32 printable characters");
        if (auto it = firstAt.find(s.name); it != firstAt.end())
            nameNode.fail("shift name '" + s.name + "' given twice (first at " + it->second + ")");
        firstAt.emplace(s.name, item.path());
        const auto startNode = item["start"];
        s.startMinute = parseTimeOfDay(startNode.asString());
        if (s.startMinute < 0)
            startNode.fail("'" + startNode.asString() +
                           "' is not a time of day HH:MM from 00:00 to 23:59 (the station's local time)");
        if (!shifts.empty() && s.startMinute <= shifts.back().startMinute)
            startNode.fail("shift '" + s.name + "' starts at " + hhmm(s.startMinute) +
                           ", not after the shift before it ('" + shifts.back().name + "' at " +
                           hhmm(shifts.back().startMinute) +
                           "): list the shifts in the order of the day, from the earliest start");
        shifts.push_back(std::move(s));
    }
    return shifts;
}

std::int64_t localUtcOffset(std::int64_t unixSeconds)
{
    const std::time_t t = static_cast<std::time_t>(unixSeconds);
    std::tm tm{};
    localtime_r(&t, &tm);
    return tm.tm_gmtoff;
}

std::size_t shiftAt(const std::vector<Shift>& shifts, int minuteOfDay)
{
    // Before the first start of the day it is still the last shift of the day before.
    std::size_t index = shifts.size() - 1;
    for (std::size_t i = 0; i < shifts.size(); ++i)
        if (shifts[i].startMinute <= minuteOfDay) index = i;
    return index;
}

ShiftWindow currentShift(const std::vector<Shift>& shifts, std::int64_t nowUnixMs, const UtcOffset& offset)
{
    const std::int64_t now = floorDiv(nowUnixMs, 1000);
    const std::int64_t offsetNow = offset(now);
    const std::int64_t local = now + offsetNow;
    const std::int64_t midnight = floorDiv(local, kDaySeconds) * kDaySeconds;
    const int minute = static_cast<int>((local - midnight) / 60);
    ShiftWindow w;
    w.index = shiftAt(shifts, minute);
    std::int64_t startLocal = midnight + std::int64_t{shifts[w.index].startMinute} * 60;
    if (startLocal > local) startLocal -= kDaySeconds; // it began the day before
    // Local to UTC with the offset at the start itself: a clock change since then (summer time) counts.
    const std::int64_t startUtc = startLocal - offset(startLocal - offsetNow);
    w.startUnixMs = startUtc * 1000;
    return w;
}

} // namespace hg::station
