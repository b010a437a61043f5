// The systemd service protocol (Type=notify) over libsystemd's sd_notify:
// READY=1 once the drivers are active, WATCHDOG=1 from the main loop only
// while the daemon is healthy, STATUS= lines, RELOADING=1 / READY=1 around a
// SIGHUP reload, STOPPING=1 on the way out. Outside systemd (no
// NOTIFY_SOCKET) every call does nothing.
#pragma once

#include <chrono>
#include <optional>
#include <string>

namespace hg::daemon {

class Notifier {
  public:
    Notifier();
    /// True when a NOTIFY_SOCKET was given (running under systemd or a test harness).
    bool active() const { return active_; }
    /// The watchdog interval systemd asked for (WATCHDOG_USEC), if any.
    std::optional<std::chrono::microseconds> watchdogInterval() const { return watchdog_; }

    void ready(const std::string& status);
    void reloading();
    void watchdog();
    void status(const std::string& text);
    void stopping(const std::string& status);

  private:
    void send(const std::string& message);
    bool active_ = false;
    std::optional<std::chrono::microseconds> watchdog_;
    std::string lastStatus_;
};

} // namespace hg::daemon
