#include "notify.h"

#include "hullgauge/common/log.h"

#include <cstdint>
#include <cstdlib>
#include <systemd/sd-daemon.h>

namespace hg::daemon {

Notifier::Notifier()
{
    const char* socket = std::getenv("NOTIFY_SOCKET");
    active_ = socket && *socket;
    std::uint64_t usec = 0;
    // sd_watchdog_enabled checks WATCHDOG_PID against our pid, so a child never pings for us.
    if (sd_watchdog_enabled(0, &usec) > 0 && usec > 0) watchdog_ = std::chrono::microseconds(usec);
}

void Notifier::send(const std::string& message)
{
    if (!active_) return;
    int rc = sd_notify(0, message.c_str());
    if (rc < 0) hg::log::category("daemon")->warn("sd_notify failed: {}", rc);
}

void Notifier::ready(const std::string& status)
{
    lastStatus_ = status;
    send("READY=1\nSTATUS=" + status);
}

void Notifier::reloading()
{
    send("RELOADING=1\nSTATUS=reloading configuration");
}

void Notifier::watchdog()
{
    send("WATCHDOG=1");
}

void Notifier::status(const std::string& text)
{
    // Only changes go out: the main loop calls this every turn.
    if (text == lastStatus_) return;
    lastStatus_ = text;
    send("STATUS=" + text);
}

void Notifier::stopping(const std::string& status)
{
    send("STOPPING=1\nSTATUS=" + status);
}

} // namespace hg::daemon
