#include "hullgauge/common/format.h"
#include "hullgauge/common/clock.h"

#include <chrono>
#include <ctime>
#include <sstream>

namespace hg {

std::string formatNumber(double v, int precision)
{
    std::ostringstream s;
    s.precision(precision);
    s << v;
    return s.str();
}

std::string localTimestamp()
{
    return localTimestamp(Clock::steady());
}

std::string localTimestamp(const Clock& clock)
{
    const std::time_t now = std::chrono::system_clock::to_time_t(clock.wallNow());
    std::tm tm{};
    localtime_r(&now, &tm);
    char b[40];
    std::strftime(b, sizeof b, "%Y-%m-%dT%H:%M:%S%z", &tm);
    std::string text = b;
    // strftime writes the offset as +hhmm; ISO 8601's extended form is +hh:mm.
    if (text.size() >= 5) text.insert(text.size() - 2, ":");
    return text;
}

} // namespace hg
