#include "hullgauge/common/clock.h"

#include <algorithm>
#include <thread>

namespace hg {
namespace {

/// The only place the programs read the machine's clocks (docs/style.md point 9).
class SteadyClock final : public Clock {
  public:
    time_point now() const override { return std::chrono::steady_clock::now(); }
    wall_time wallNow() const override { return std::chrono::system_clock::now(); }

    void sleepUntil(time_point until, const std::function<bool()>& stop) override
    {
        while (now() < until && !stop())
            std::this_thread::sleep_for(std::min<duration>(std::chrono::milliseconds(5), until - now()));
    }

    bool waitUntil(std::unique_lock<std::mutex>& lock, std::condition_variable& changed, time_point until,
                   const std::function<bool()>& ready) override
    {
        return changed.wait_until(lock, until, ready);
    }
};

} // namespace

Clock& Clock::steady()
{
    static SteadyClock clock;
    return clock;
}

} // namespace hg
