// The one clock (include/hullgauge/common/clock.h) and the tests' hand-moved
// twin (hgtest/manual_clock.h): a stopwatch reads the clock it is given, the
// wall time moves with the steady time, and a thread that waits on a clock
// held by the hand wakes when the hand passes its deadline and not before.
#include "hullgauge/common/clock.h"

#include <gtest/gtest.h>
#include <hgtest/manual_clock.h>

#include <atomic>
#include <thread>

namespace {

using namespace std::chrono_literals;
using hgtest::ManualClock;

TEST(Clock, AStopwatchReadsTheClockItIsGiven)
{
    ManualClock clock;
    hg::Stopwatch watch(clock);
    EXPECT_EQ(watch.ms(), 0.0);
    clock.advance(250ms);
    EXPECT_DOUBLE_EQ(watch.ms(), 250.0);
    EXPECT_DOUBLE_EQ(watch.seconds(), 0.25);
    watch.restart();
    EXPECT_EQ(watch.started(), clock.now());
    EXPECT_EQ(watch.ms(), 0.0);
}

TEST(Clock, TheWallTimeMovesWithTheSteadyTime)
{
    ManualClock clock;
    EXPECT_EQ(clock.wallMs(), 1'772'438'400'000); // 2026-03-02T08:00:00Z
    clock.advance(1500ms);
    EXPECT_EQ(clock.wallMs(), 1'772'438'401'500);
    EXPECT_EQ(clock.nowNs(), std::chrono::nanoseconds(1h + 1500ms).count());
}

TEST(Clock, ASleepEndsAtOnceAtItsDeadlineUnlessStopped)
{
    ManualClock clock; // EndAtOnce
    const auto t0 = clock.now();
    clock.sleepUntil(t0 + 3s, [] { return false; });
    EXPECT_EQ(clock.now(), t0 + 3s);
    clock.sleepUntil(t0 + 5s, [] { return true; });
    EXPECT_EQ(clock.now(), t0 + 3s);
}

TEST(Clock, TheSteadyClockWaitEndsWhenReady)
{
    std::mutex mutex;
    std::condition_variable changed;
    std::unique_lock lock(mutex);
    auto& clock = hg::Clock::steady();
    EXPECT_TRUE(clock.waitUntil(lock, changed, clock.now() + 60s, [] { return true; }));
    EXPECT_FALSE(clock.waitUntil(lock, changed, clock.now(), [] { return false; }));
    clock.sleepUntil(clock.now() + 60s, [] { return true; }); // the stop ends it at once
}

TEST(Clock, AThreadWaitingOnTheHandWakesAtItsDeadlineAndNotBefore)
{
    ManualClock clock(ManualClock::Sleeps::WaitForTheHand);
    const auto t0 = clock.now();
    std::atomic<bool> woke{false};
    std::thread sleeper([&] {
        clock.sleepUntil(t0 + 1s, [] { return false; });
        woke = true;
    });
    ASSERT_EQ(clock.nextWake(), t0 + 1s);
    clock.advance(999ms);
    // It saw t0 + 999 ms and waits on: nothing happened before the deadline.
    EXPECT_EQ(clock.nextWake(), t0 + 1s);
    EXPECT_FALSE(woke);
    clock.advance(1ms);
    sleeper.join();
    EXPECT_TRUE(woke);
    EXPECT_EQ(clock.nextWake(0ms), std::nullopt);
}

TEST(Clock, AConditionWaitOnTheHandEndsWhenReadyOrAtItsDeadline)
{
    ManualClock clock(ManualClock::Sleeps::WaitForTheHand);
    std::mutex mutex;
    std::condition_variable changed;
    bool ready = false;
    std::atomic<int> outcome{-1};
    auto wait = [&] {
        std::unique_lock lock(mutex);
        outcome = clock.waitUntil(lock, changed, clock.now() + 2s, [&] { return ready; }) ? 1 : 0;
    };
    std::thread readyFirst(wait);
    ASSERT_TRUE(clock.nextWake());
    {
        std::lock_guard lock(mutex);
        ready = true;
    }
    changed.notify_all();
    readyFirst.join();
    EXPECT_EQ(outcome, 1);

    ready = false;
    std::thread timesOut(wait);
    const auto until = clock.nextWake();
    ASSERT_TRUE(until);
    clock.advance(*until - clock.now());
    timesOut.join();
    EXPECT_EQ(outcome, 0);
}

} // namespace
