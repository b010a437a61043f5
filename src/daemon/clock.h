// The time the cycle runner reads and waits on: the steady clock in the
// daemon, a clock the test moves by hand in the runner's tests, so settle
// times, recovery waits and the cycle-time breakdown are tested without sleeps.
#pragma once

#include <algorithm>
#include <chrono>
#include <functional>
#include <thread>

namespace hg::daemon {

class Clock {
  public:
    using time_point = std::chrono::steady_clock::time_point;
    using duration = std::chrono::steady_clock::duration;

    virtual ~Clock() = default;
    virtual time_point now() const = 0;
    /// Waits until `until`, or less when `stop()` turns true (asked every few ms).
    virtual void sleepUntil(time_point until, const std::function<bool()>& stop) = 0;

    /// Nanoseconds on this clock, for the atomics other threads read.
    std::int64_t nowNs() const
    {
        return std::chrono::duration_cast<std::chrono::nanoseconds>(now().time_since_epoch()).count();
    }
    double msSince(time_point t) const { return std::chrono::duration<double, std::milli>(now() - t).count(); }

    /// The steady clock; its waits sleep in 5 ms slices so an abort is not delayed by them.
    static Clock& steady()
    {
        struct Steady : Clock {
            time_point now() const override { return std::chrono::steady_clock::now(); }
            void sleepUntil(time_point until, const std::function<bool()>& stop) override
            {
                while (now() < until && !stop())
                    std::this_thread::sleep_for(std::min<duration>(std::chrono::milliseconds(5), until - now()));
            }
        };
        static Steady clock;
        return clock;
    }
};

} // namespace hg::daemon
