// The daemon's main loop as the web HMI's tests need it: a thread answering
// the command mailbox (tests/daemon/hmi/test_hmi_server.cpp, test_access.cpp).
#pragma once

#include "command_mailbox.h"

#include <atomic>
#include <mutex>
#include <nlohmann/json.hpp>
#include <poll.h>
#include <thread>
#include <vector>

namespace hg::daemon {

/// The daemon's main loop as far as the HMI sees it: answers the mailbox
/// with a status and records every maintenance command it was handed.
class FakeLoop {
  public:
    explicit FakeLoop(CommandMailbox& mailbox) : mailbox_(mailbox), thread_([this] { run(); }) {}
    ~FakeLoop()
    {
        stop_ = true;
        thread_.join();
    }
    std::vector<nlohmann::json> commands()
    {
        std::lock_guard lock(mutex_);
        return commands_;
    }
    /// What `status` answers from now on.
    void setStatus(nlohmann::json status)
    {
        std::lock_guard lock(mutex_);
        status_ = std::move(status);
    }

  private:
    void run()
    {
        while (!stop_) {
            pollfd fd{mailbox_.fd(), POLLIN, 0};
            if (poll(&fd, 1, 20) > 0) mailbox_.serve([this](const nlohmann::json& request) { return answer(request); });
        }
    }
    nlohmann::json answer(const nlohmann::json& request)
    {
        std::lock_guard lock(mutex_);
        commands_.push_back(request);
        if (request.at("command") == "status") return status_;
        return {{"ok", true}, {"did", request.at("command")}};
    }

    CommandMailbox& mailbox_;
    std::atomic<bool> stop_{false};
    std::mutex mutex_;
    std::vector<nlohmann::json> commands_;
    nlohmann::json status_{{"ok", true},
                           {"pid", 1},
                           {"sequencer", {{"state", "ready"}, {"cycles", 3}, {"faults", 0}}},
                           {"plc", {{"status", 1}, {"done_seq", 3}}},
                           {"lamps", {{"green", "on"}, {"amber", "off"}, {"red", "off"}}}};
    std::thread thread_;
};

} // namespace hg::daemon
