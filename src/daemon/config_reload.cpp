#include "config_reload.h"

#include "hullgauge/common/error.h"

#include <sys/eventfd.h>
#include <unistd.h>

namespace hg::daemon {

ConfigReload::ConfigReload(Load load) : load_(std::move(load)), fd_(eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK))
{
    if (fd_ < 0) throw FaultError("reload: cannot create its eventfd");
    worker_.start([this](std::stop_token stop) { run(stop); }, wakeOn(mutex_, wake_));
}

ConfigReload::~ConfigReload()
{
    worker_.stop();
    close(fd_);
}

void ConfigReload::request(const std::filesystem::path& file)
{
    {
        std::lock_guard lock(mutex_);
        wanted_ = file;
    }
    wake_.notify_all();
}

bool ConfigReload::busy() const
{
    std::lock_guard lock(mutex_);
    return wanted_ || running_ || finished_;
}

std::optional<Result<ConfigPtr>> ConfigReload::take()
{
    std::uint64_t count = 0;
    // Drained before the result is taken: a result finished after this read raises the count again.
    [[maybe_unused]] auto n = read(fd_, &count, sizeof count);
    std::lock_guard lock(mutex_);
    auto taken = std::move(finished_);
    finished_.reset();
    return taken;
}

void ConfigReload::run(std::stop_token stop)
{
    std::unique_lock lock(mutex_);
    for (;;) {
        wake_.wait(lock, [&] { return stop.stop_requested() || wanted_; });
        if (stop.stop_requested()) return;
        const auto file = *wanted_;
        wanted_.reset();
        running_ = true;
        lock.unlock();
        std::optional<Result<ConfigPtr>> result;
        try {
            result = Result<ConfigPtr>(load_(file));
        } catch (const InputError& e) {
            result = Result<ConfigPtr>(Status::failure(StatusCode::Error, e.what()));
        } catch (const std::exception& e) {
            // Nothing escapes the worker: what the checks missed refuses the reload too, named.
            result = Result<ConfigPtr>(Status::failure(StatusCode::Error, file.string() + ": " + e.what()));
        }
        lock.lock();
        running_ = false;
        // A newer request replaces an unread result: only the latest file counts.
        finished_ = std::move(result);
        const std::uint64_t one = 1;
        [[maybe_unused]] auto n = write(fd_, &one, sizeof one);
    }
}

} // namespace hg::daemon
