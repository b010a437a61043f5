// A reload read off the main loop (docs/daemon.md, "Reload"): reading and
// checking a configuration and its part programs (meshes, maps, views) can
// take seconds, and the main loop must meanwhile keep pinging the watchdog,
// beating the heartbeat and answering the maintenance socket. The reload runs
// on a worker of its own; the main loop polls fd() and applies what take()
// gives, which is quick. A SIGHUP while a reload runs asks for one more after
// it (the file may have changed again since it was read).
#pragma once

#include "daemon_config.h"
#include "hullgauge/common/status.h"
#include "hullgauge/common/worker.h"

#include <condition_variable>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>

namespace hg::daemon {

using ConfigPtr = std::shared_ptr<const station::DaemonConfig>;

class ConfigReload {
  public:
    /// `load` reads and checks the file; it throws InputError for a configuration that does not validate.
    using Load = std::function<ConfigPtr(const std::filesystem::path&)>;

    explicit ConfigReload(Load load);
    ~ConfigReload();
    ConfigReload(const ConfigReload&) = delete;
    ConfigReload& operator=(const ConfigReload&) = delete;

    /// Reads `file` on the worker; while a reload runs, one more is run after it.
    void request(const std::filesystem::path& file);
    /// Readable (an eventfd) while a finished reload waits to be taken.
    int fd() const { return fd_; }
    /// The finished reload: the new configuration, or why it was refused. Nothing when none finished.
    std::optional<Result<ConfigPtr>> take();
    /// True from request() until the last requested reload is taken.
    bool busy() const;

  private:
    void run(std::stop_token stop);

    Load load_;
    int fd_ = -1;
    mutable std::mutex mutex_;
    std::condition_variable wake_;
    std::optional<std::filesystem::path> wanted_; ///< a reload asked for and not yet started
    bool running_ = false;                        ///< a reload is being read
    std::optional<Result<ConfigPtr>> finished_;   ///< read, not yet taken
    Worker worker_;                               ///< last: it ends before what it uses
};

} // namespace hg::daemon
