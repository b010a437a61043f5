// A clock only the test moves (the daemon's Clock, src/daemon/clock.h): sleeps
// end at once, at their deadline, so timeouts and rate limits are tested
// without waiting.
#pragma once

#include "clock.h"

#include <atomic>
#include <chrono>

namespace hg::daemon {

class ManualClock : public Clock {
  public:
    time_point now() const override { return time_point(std::chrono::nanoseconds(ns_.load())); }
    void sleepUntil(time_point until, const std::function<bool()>& stop) override
    {
        if (stop()) return;
        auto target = std::chrono::duration_cast<std::chrono::nanoseconds>(until.time_since_epoch()).count();
        auto current = ns_.load();
        while (current < target && !ns_.compare_exchange_weak(current, target)) {}
    }
    void advance(std::chrono::milliseconds d) { ns_ += std::chrono::nanoseconds(d).count(); }

  private:
    // Starts an hour in: 0 means "idle" to the runner.
    std::atomic<std::int64_t> ns_{std::chrono::nanoseconds(std::chrono::hours(1)).count()};
};

} // namespace hg::daemon
