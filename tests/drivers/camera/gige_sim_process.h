// Test helpers for the GigE Vision integration tests: a private network
// namespace per test process (so the fixed GVCP port 3956 on 127.0.0.1 never
// collides with another test or another user of the machine) and the
// hullgauge-gige-sim process with bounded start and stop.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace hgtest {

/// Moves this process into a fresh network namespace with loopback up.
/// Returns an empty string on success, else why not (the caller skips).
std::string isolateNetwork();

/// hullgauge-gige-sim as a child process.
class GigeSim {
  public:
    GigeSim() = default;
    ~GigeSim();
    GigeSim(const GigeSim&) = delete;
    GigeSim& operator=(const GigeSim&) = delete;

    /// Starts the simulator with `args` and waits (at most `timeoutMs`) for its
    /// "ready" line; throws std::runtime_error with its stderr otherwise. The
    /// deadline only bounds a simulator that hangs: it starts in well under a
    /// second, but a machine loaded by other builds (and a driver hammering it
    /// with reconnects) has been seen to take more than 5 s.
    void start(const std::vector<std::string>& args, int timeoutMs = 60000);
    /// SIGKILL, as a camera losing power: no goodbye on the wire.
    void kill();
    /// SIGTERM and wait (bounded); SIGKILL if it hangs.
    void stop();
    bool running() const { return pid_ > 0; }
    const std::string& readyLine() const { return ready_; }

  private:
    int pid_ = -1;
    std::string ready_;
    std::filesystem::path errFile_;
};

} // namespace hgtest
