// The one thread owner (include/hullgauge/common/worker.h): the stop is
// requested and the thread joined when the owner goes, and a stop callback
// ends a wait the token cannot reach. Every wait here is on a condition, none
// on the time.
#include "hullgauge/common/worker.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <thread>

namespace {

using namespace std::chrono_literals;

/// A flag one thread raises and another waits for (under a generous deadline, never a sleep).
class Flag {
  public:
    void raise()
    {
        {
            std::lock_guard lock(mutex_);
            raised_ = true;
        }
        changed_.notify_all();
    }
    bool waitRaised()
    {
        std::unique_lock lock(mutex_);
        return changed_.wait_for(lock, 60s, [this] { return raised_; });
    }

  private:
    std::mutex mutex_;
    std::condition_variable changed_;
    bool raised_ = false;
};

TEST(Worker, TheDestructorRequestsTheStopAndJoins)
{
    std::atomic<bool> sawStop{false};
    std::atomic<bool> returned{false};
    Flag waiting;
    {
        hg::Worker worker;
        worker.start([&](std::stop_token stop) {
            // condition_variable_any waits on the token itself: only the stop ends this wait.
            std::mutex mutex;
            std::condition_variable_any never;
            std::unique_lock lock(mutex);
            waiting.raise();
            never.wait(lock, stop, [] { return false; });
            sawStop = stop.stop_requested();
            returned = true;
        });
        EXPECT_TRUE(worker.running());
        ASSERT_TRUE(waiting.waitRaised());
        EXPECT_FALSE(worker.stopRequested());
    }
    // Joined: the body has returned by the time the destructor did.
    EXPECT_TRUE(returned);
    EXPECT_TRUE(sawStop);
}

TEST(Worker, AStopCallbackWakesABodyWaitingOnAConditionVariable)
{
    std::mutex mutex;
    std::condition_variable changed;
    Flag waiting;
    std::atomic<bool> wokenByStop{false};
    std::thread::id wokenOn;
    hg::Worker worker;
    worker.start(
        [&](std::stop_token stop) {
            std::unique_lock lock(mutex);
            waiting.raise();
            // A plain condition variable does not know the token: without the
            // callback's notification this wait would last its whole minute.
            wokenByStop = changed.wait_for(lock, 60s, [&] { return stop.stop_requested(); });
        },
        [&] {
            wokenOn = std::this_thread::get_id();
            hg::wakeOn(mutex, changed)();
        });
    ASSERT_TRUE(waiting.waitRaised());
    const auto t0 = std::chrono::steady_clock::now();
    worker.stop();
    EXPECT_FALSE(worker.running());
    EXPECT_TRUE(wokenByStop);
    EXPECT_LT(std::chrono::steady_clock::now() - t0, 30s) << "the stop waited for the body's own timeout";
    // The callback runs on the thread that asks for the stop.
    EXPECT_EQ(wokenOn, std::this_thread::get_id());
}

TEST(Worker, StartsAgainAfterAStopAndStopIsIdempotent)
{
    hg::Worker worker;
    worker.stop(); // never started: nothing
    std::atomic<int> runs{0};
    for (int i = 0; i < 2; ++i) {
        worker.start([&](std::stop_token stop) {
            ++runs;
            std::mutex mutex;
            std::condition_variable_any never;
            std::unique_lock lock(mutex);
            never.wait(lock, stop, [] { return false; });
        });
        EXPECT_FALSE(worker.stopRequested());
        worker.stop();
        EXPECT_TRUE(worker.stopRequested());
        worker.stop();
    }
    EXPECT_EQ(runs, 2);
}

} // namespace
