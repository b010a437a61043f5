// The web HMI's listener (docs/hmi.md, "Bounded"): one thread accepts every
// connection and reads its request through a RequestGate under one deadline
// for the whole request — head and body, not per line — holding at most
// `maxPending` unfinished requests (the longest-waiting one is answered 408
// and closed for a newcomer). A refused request is answered by the gate
// itself; only a whole, checked request is handed to `answer`, which runs it
// on one of the HTTP library's threads. So a slow client costs its own slot,
// never a thread: four clients sending a header line every 2 s once held every
// HMI thread and the HMI did not answer for as long as they lasted.
#pragma once

#include "hmi/request_gate.h"

#include "hullgauge/common/clock.h"
#include "hullgauge/common/worker.h"

#include <chrono>
#include <functional>
#include <string>

namespace hg::daemon {

/// A connection whose request the gate passed: its socket (blocking, the
/// receiver closes it), the request's bytes and the peer.
struct GatedRequest {
    int fd = -1;
    std::string bytes;
    std::string peerIp;
    int peerPort = 0;
};

class GateListener {
  public:
    struct Options {
        GateLimits limits;
        std::chrono::milliseconds requestTimeout{5000}; ///< `http.request_timeout_s`
        /// An upload gets this long per byte on top of requestTimeout (1 MiB/s: a busy 10 Mbit/s link).
        std::uint64_t uploadBytesPerSecond = 1 << 20;
        std::size_t maxPending = 64; ///< `http.max_pending_requests`
    };
    using Answer = std::function<void(GatedRequest)>;

    /// Serves the listening socket `listenFd` (owned by the caller) until stop().
    GateListener(int listenFd, Options options, Answer answer, Clock& clock);
    ~GateListener();
    GateListener(const GateListener&) = delete;
    GateListener& operator=(const GateListener&) = delete;

    void stop();
    /// Requests refused by the gate or its deadline, for the status page.
    std::uint64_t refused() const { return refused_.load(); }

  private:
    void run(std::stop_token stop);

    int listenFd_;
    Options options_;
    Answer answer_;
    Clock& clock_;
    int wakeFd_ = -1;
    std::atomic<std::uint64_t> refused_{0};
    Worker worker_;
};

} // namespace hg::daemon
