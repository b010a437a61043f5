#include "command_mailbox.h"

#include "hullgauge/common/error.h"

#include <cerrno>
#include <cstring>
#include <sys/eventfd.h>
#include <unistd.h>

namespace hg::daemon {

CommandMailbox::CommandMailbox() : fd_(eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK))
{
    if (fd_ < 0) throw FaultError(std::string("command mailbox: eventfd: ") + std::strerror(errno));
}

CommandMailbox::~CommandMailbox()
{
    close();
    ::close(fd_);
}

std::optional<nlohmann::json> CommandMailbox::call(nlohmann::json request, std::chrono::milliseconds timeout)
{
    auto pending = std::make_shared<Pending>();
    pending->request = std::move(request);
    auto answer = pending->answer.get_future();
    {
        std::lock_guard lock(mutex_);
        if (closed_ || waiting_.size() >= kMaxWaiting) return std::nullopt;
        waiting_.push_back(pending);
    }
    const std::uint64_t one = 1;
    [[maybe_unused]] auto n = ::write(fd_, &one, sizeof one);
    // The loop may answer after the deadline: the promise is shared, so that is harmless.
    if (answer.wait_for(timeout) != std::future_status::ready) return std::nullopt;
    return answer.get();
}

void CommandMailbox::serve(const Handler& handler)
{
    std::uint64_t count = 0;
    [[maybe_unused]] auto n = ::read(fd_, &count, sizeof count);
    std::deque<std::shared_ptr<Pending>> batch;
    {
        std::lock_guard lock(mutex_);
        batch.swap(waiting_);
    }
    for (auto& p : batch) {
        try {
            p->answer.set_value(handler(p->request));
        } catch (const std::exception& e) {
            p->answer.set_value({{"ok", false}, {"error", e.what()}});
        }
    }
}

void CommandMailbox::close()
{
    std::deque<std::shared_ptr<Pending>> batch;
    {
        std::lock_guard lock(mutex_);
        closed_ = true;
        batch.swap(waiting_);
    }
    for (auto& p : batch) p->answer.set_value({{"ok", false}, {"error", "the daemon is stopping"}});
}

} // namespace hg::daemon
