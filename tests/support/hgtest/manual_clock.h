// A clock only the test moves (hg::Clock, include/hullgauge/common/clock.h;
// docs/style.md point 9), shared by the driver, daemon and plant-link tests.
// The steady time starts an hour in (0 means "idle" to the cycle runner), the
// wall time at 2026-03-02T08:00:00Z, and both move only by advance().
//
// Its waits behave one of two ways, chosen at construction:
// - EndAtOnce: a wait ends at once at its deadline, the clock jumping there
//   (a sleep never waits for a stop). For one thread under test that sleeps
//   between steps (the cycle runner's settle and recovery waits): timeouts
//   and rates are tested without waiting.
// - WaitForTheHand: a wait lasts until the test moves the clock past its
//   deadline (or the code's own stop or wake-up ends it). For threads that
//   wait in the background (a reconnect back-off, a blink timer): the test
//   moves the clock step by step and sees what happens at each step and not
//   before. nextWake() tells it when such a thread waits again.
#pragma once

#include "hullgauge/common/clock.h"

#include <atomic>
#include <chrono>
#include <cstdint>
#include <list>
#include <optional>

namespace hgtest {

class ManualClock final : public hg::Clock {
  public:
    enum class Sleeps { EndAtOnce, WaitForTheHand };

    explicit ManualClock(Sleeps sleeps = Sleeps::EndAtOnce) : sleeps_(sleeps) {}

    time_point now() const override { return time_point(std::chrono::nanoseconds(ns_.load())); }
    wall_time wallNow() const override;
    void sleepUntil(time_point until, const std::function<bool()>& stop) override;
    bool waitUntil(std::unique_lock<std::mutex>& lock, std::condition_variable& changed, time_point until,
                   const std::function<bool()>& ready) override;

    /// Moves the steady and the wall time on by `d`; waits whose deadline is passed end.
    void advance(duration d);

    /// WaitForTheHand: waits, up to `deadline` of real time, until a thread
    /// waits on this clock having seen its current time (it found its deadline
    /// not reached yet), and answers the earliest such deadline; nullopt when
    /// none did by then. After advance(), the threads it woke have either done
    /// what was due and waited again, or are still on their way.
    std::optional<time_point> nextWake(std::chrono::milliseconds deadline = std::chrono::seconds(60)) const;

  private:
    struct Waiter {
        time_point until;
        std::uint64_t seen = 0; ///< the epoch_ it last found its deadline ahead in
    };
    /// Registers a waiter for its lifetime (WaitForTheHand).
    class Registration;

    const Sleeps sleeps_;
    std::atomic<std::int64_t> ns_{std::chrono::nanoseconds(std::chrono::hours(1)).count()};
    mutable std::mutex mutex_;               ///< guards epoch_ and waiters_; advance() takes it to move ns_
    std::condition_variable hand_;           ///< notified by advance(): a sleeping waiter looks again
    mutable std::condition_variable turned_; ///< notified by a waiter that saw a new time: nextWake() looks again
    std::uint64_t epoch_ = 1;                ///< counts advance() calls
    std::list<Waiter*> waiters_;
};

} // namespace hgtest
