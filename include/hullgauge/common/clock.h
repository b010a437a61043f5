// The one clock of the programs (docs/style.md point 9): every reading of
// the time goes through an hg::Clock, so that a test can hand the code under
// test a clock it moves by hand (hgtest/manual_clock.h) and check settle
// times, timeouts, back-offs and time stamps without sleeping.
//
// Two times come from the same object: the steady time (now(): deadlines,
// waits, durations; it never jumps) and the wall time (wallNow(): the time
// stamps of results, file names and exports, which an operator reads as a
// date). Clock::steady() is the machine's; the programs pass it where nothing
// else is injected.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>

namespace hg {

/// A span of time in milliseconds with its fraction: the unit run times are
/// reported in (a result's `timing_ms`, docs/contracts.md §4).
using Milliseconds = std::chrono::duration<double, std::milli>;

class Clock {
  public:
    using time_point = std::chrono::steady_clock::time_point;
    using duration = std::chrono::steady_clock::duration;
    using wall_time = std::chrono::system_clock::time_point;

    virtual ~Clock() = default;

    /// The steady time: deadlines, waits and durations.
    virtual time_point now() const = 0;
    /// The wall time: time stamps an operator reads (results, file names, exports).
    virtual wall_time wallNow() const = 0;
    /// Waits until `until`, or less when `stop()` turns true (asked every few ms).
    virtual void sleepUntil(time_point until, const std::function<bool()>& stop) = 0;
    /// Waits on `changed` (with `lock` held, as std::condition_variable does)
    /// until `ready()` or until `until` on this clock; returns ready(). For a
    /// thread that other threads wake and that has a deadline of its own.
    virtual bool waitUntil(std::unique_lock<std::mutex>& lock, std::condition_variable& changed, time_point until,
                           const std::function<bool()>& ready) = 0;

    /// Nanoseconds on this clock, for the atomics other threads read.
    std::int64_t nowNs() const
    {
        return std::chrono::duration_cast<std::chrono::nanoseconds>(now().time_since_epoch()).count();
    }
    /// The time from `t` to now.
    Milliseconds since(time_point t) const { return Milliseconds(now() - t); }
    /// Milliseconds from `t` to now.
    double msSince(time_point t) const { return since(t).count(); }
    /// The wall time in milliseconds since the Unix epoch (UTC).
    std::int64_t wallMs() const
    {
        return std::chrono::duration_cast<std::chrono::milliseconds>(wallNow().time_since_epoch()).count();
    }

    /// The machine's clocks; its waits sleep in 5 ms slices so a stop is not delayed by them.
    static Clock& steady();
};

/// How long something took, read on a Clock (the steady one unless given):
/// the run times a result reports (docs/architecture.md: never an input to a decision).
class Stopwatch {
  public:
    explicit Stopwatch(const Clock& clock = Clock::steady()) : clock_(&clock), started_(clock.now()) {}

    void restart() { started_ = clock_->now(); }
    Clock::time_point started() const { return started_; }
    Milliseconds elapsed() const { return clock_->since(started_); }
    double ms() const { return elapsed().count(); }
    double seconds() const { return ms() / 1000.0; }

  private:
    const Clock* clock_;
    Clock::time_point started_;
};

} // namespace hg
