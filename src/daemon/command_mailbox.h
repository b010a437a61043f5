// Requests from other threads (the web HMI's) to the daemon's main loop, where
// the maintenance commands run (docs/daemon.md, "Maintenance socket"): one
// command table for the socket and the HMI, and nothing of the daemon's state
// touched from a web thread. The main loop polls fd() and serve()s; a caller
// waits for its answer under a deadline and gets nothing when the loop is busy
// longer (a reload) — the HMI then answers 503, the cycle never waits for it.
#pragma once

#include <chrono>
#include <deque>
#include <functional>
#include <future>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>

namespace hg::daemon {

class CommandMailbox {
  public:
    using Handler = std::function<nlohmann::json(const nlohmann::json& request)>;

    CommandMailbox();
    ~CommandMailbox();
    CommandMailbox(const CommandMailbox&) = delete;
    CommandMailbox& operator=(const CommandMailbox&) = delete;

    /// Readable (an eventfd) while requests wait.
    int fd() const { return fd_; }
    /// From any thread: the main loop's answer to `request`, or nothing when it
    /// did not come within `timeout`, the mailbox is full (kMaxWaiting) or closed.
    std::optional<nlohmann::json> call(nlohmann::json request, std::chrono::milliseconds timeout);
    /// Main loop: answers every waiting request with `handler` (an exception
    /// it throws becomes {"ok": false, "error": ...}).
    void serve(const Handler& handler);
    /// Refuses new requests and answers the waiting ones as refused.
    void close();

    static constexpr std::size_t kMaxWaiting = 64;

  private:
    struct Pending {
        nlohmann::json request;
        std::promise<nlohmann::json> answer;
    };
    int fd_ = -1;
    std::mutex mutex_;
    bool closed_ = false;
    std::deque<std::shared_ptr<Pending>> waiting_;
};

} // namespace hg::daemon
