#include "hgtest/manual_clock.h"

#include <utility>

namespace hgtest {
namespace {

using namespace std::chrono_literals;

constexpr auto kStart = std::chrono::nanoseconds(1h);
/// 2026-03-02T08:00:00Z: the wall time at kStart.
constexpr auto kWallStart = std::chrono::sys_days{std::chrono::year{2026} / 3 / 2} + 8h;
/// How often a waiting thread asks its own stop or wake-up condition (real time): a poll, not a synchronisation.
constexpr auto kTurn = 1ms;

} // namespace

class ManualClock::Registration {
  public:
    Registration(ManualClock& clock, Waiter& waiter) : clock_(clock)
    {
        std::lock_guard lock(clock_.mutex_);
        it_ = clock_.waiters_.insert(clock_.waiters_.end(), &waiter);
    }
    ~Registration()
    {
        std::lock_guard lock(clock_.mutex_);
        clock_.waiters_.erase(it_);
    }
    Registration(const Registration&) = delete;
    Registration& operator=(const Registration&) = delete;

  private:
    ManualClock& clock_;
    std::list<Waiter*>::iterator it_;
};

hg::Clock::wall_time ManualClock::wallNow() const
{
    return std::chrono::time_point_cast<wall_time::duration>(kWallStart) +
           std::chrono::duration_cast<wall_time::duration>(now().time_since_epoch() - kStart);
}

void ManualClock::advance(duration d)
{
    {
        std::lock_guard lock(mutex_);
        ns_ += std::chrono::duration_cast<std::chrono::nanoseconds>(d).count();
        ++epoch_;
    }
    hand_.notify_all();
}

void ManualClock::sleepUntil(time_point until, const std::function<bool()>& stop)
{
    if (sleeps_ == Sleeps::EndAtOnce) {
        if (stop()) return;
        const auto target = std::chrono::duration_cast<std::chrono::nanoseconds>(until.time_since_epoch()).count();
        auto current = ns_.load();
        while (current < target && !ns_.compare_exchange_weak(current, target)) {}
        return;
    }
    Waiter waiter{until};
    Registration registered(*this, waiter);
    while (!stop()) {
        std::unique_lock lock(mutex_);
        if (now() >= until) return;
        if (std::exchange(waiter.seen, epoch_) != epoch_) turned_.notify_all();
        hand_.wait_for(lock, kTurn);
    }
}

bool ManualClock::waitUntil(std::unique_lock<std::mutex>& lock, std::condition_variable& changed, time_point until,
                            const std::function<bool()>& ready)
{
    if (sleeps_ == Sleeps::EndAtOnce) {
        if (ready()) return true;
        sleepUntil(until, [] { return false; });
        return ready();
    }
    Waiter waiter{until};
    Registration registered(*this, waiter);
    while (!ready()) {
        {
            std::lock_guard own(mutex_);
            if (now() >= until) return false;
            if (std::exchange(waiter.seen, epoch_) != epoch_) turned_.notify_all();
        }
        // The code's own wake-up comes through `changed`; the hand's is seen at the next turn.
        changed.wait_for(lock, kTurn);
    }
    return true;
}

std::optional<hg::Clock::time_point> ManualClock::nextWake(std::chrono::milliseconds deadline) const
{
    const auto giveUp = std::chrono::steady_clock::now() + deadline;
    std::unique_lock lock(mutex_);
    for (;;) {
        std::optional<time_point> earliest;
        for (const Waiter* w : waiters_)
            if (w->seen == epoch_ && (!earliest || w->until < *earliest)) earliest = w->until;
        if (earliest || std::chrono::steady_clock::now() >= giveUp) return earliest;
        turned_.wait_for(lock, kTurn);
    }
}

} // namespace hgtest
