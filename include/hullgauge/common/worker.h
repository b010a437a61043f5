// The one way an object owns a thread (docs/style.md point 9, docs/daemon.md
// "Threads"): a std::jthread whose body gets the thread's std::stop_token.
// stop() — and the destructor — requests the stop and joins, so no thread
// outlives its owner and none is detached.
//
// A body that blocks where the token cannot reach it (a condition variable,
// poll() on a socket, a server's accept loop) is given a `wake` at start():
// it runs once, on the thread that requests the stop, right after the token
// turns, and ends that wait: wakeOn() notifies a condition variable, other
// owners write to a wake-up pipe or stop their server.
#pragma once

#include <condition_variable>
#include <functional>
#include <mutex>
#include <optional>
#include <stop_token>
#include <thread>

namespace hg {

class Worker {
  public:
    using Body = std::function<void(std::stop_token)>;
    using Wake = std::function<void()>;

    Worker() = default;
    /// Requests the stop and joins.
    ~Worker() { stop(); }
    Worker(const Worker&) = delete;
    Worker& operator=(const Worker&) = delete;

    /// Starts `body` on a thread of its own; `wake` (optional) ends its
    /// blocking wait when the stop is requested. Not while running; after
    /// stop() it may start again (a driver activated again).
    void start(Body body, Wake wake = {});
    /// Requests the stop (the token, then `wake`) and waits for the body to
    /// return; nothing when not running. Never from the body itself.
    void stop();

    bool running() const { return thread_.joinable(); }
    /// True once the stop was requested. For the owner's thread: the body asks its own token.
    bool stopRequested() const { return token_.stop_requested(); }

  private:
    std::jthread thread_;
    std::stop_token token_;
    std::optional<std::stop_callback<Wake>> wake_;
};

/// A `wake` for a body that waits on `changed` under `mutex`: the mutex is
/// taken before the notification, so a body that has just found no stop
/// requested and is about to wait cannot miss it.
inline Worker::Wake wakeOn(std::mutex& mutex, std::condition_variable& changed)
{
    return [&mutex, &changed] {
        {
            std::lock_guard lock(mutex);
        }
        changed.notify_all();
    };
}

} // namespace hg
