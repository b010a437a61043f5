// Helpers for the daemon tests: free ports, a station + daemon configuration
// in a temp folder, the fake daemon as a child process, the PLC client.
#pragma once

#include "hgtest/paths.h"

#include <chrono>
#include <filesystem>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <sys/types.h>
#include <vector>

namespace hgdaemon {

/// A TCP port on 127.0.0.1 nobody listens on right now.
int freePort();

/// Polls `condition` until it holds or `deadline` passes (the deadline decides, never a sleep).
bool eventually(const std::function<bool()>& condition,
                std::chrono::milliseconds deadline = std::chrono::milliseconds(10000));
/// How many times `what` occurs in `text`, not overlapping.
std::size_t occurrences(const std::string& text, const std::string& what);
/// The whole of a text file as it is now (empty when it cannot be read).
std::string readText(const std::filesystem::path& file);

/// Writes station.yaml, part.yaml, views.yaml (`views` poses) and
/// hullgauged.yaml (with `extra` appended) into `dir`; returns the config path.
std::filesystem::path writeConfig(const hgtest::TempDir& dir, int port, const std::string& extra = {}, int views = 3);

/// The fake daemon (tests/hullgauged-fake) as a child process.
class DaemonProcess {
  public:
    /// `args` follow `--config FILE --log info` on the command line.
    DaemonProcess(const std::filesystem::path& config, std::map<std::string, std::string> env = {},
                  std::vector<std::string> args = {});
    ~DaemonProcess();
    pid_t pid() const { return pid_; }
    /// Sends `sig`; for SIGTERM/SIGKILL waits for the exit and returns the wait status.
    int signal(int sig);
    /// Waits for the exit; returns the wait status (or -1 after `timeout`).
    int wait(std::chrono::milliseconds timeout);
    const std::filesystem::path& log() const { return log_; }
    std::string logText() const;

  private:
    pid_t pid_ = -1;
    std::filesystem::path log_;
};

/// One request to the maintenance socket.
nlohmann::json maintenance(const std::filesystem::path& socket, const nlohmann::json& request);
/// Polls the maintenance socket until the sequencer state is `state`.
bool waitForState(const std::filesystem::path& socket, const std::string& state, std::chrono::milliseconds timeout);

/// Runs tools/plc-client with `args`.
hgtest::RunResult plcClient(int port, const std::string& args);

} // namespace hgdaemon
