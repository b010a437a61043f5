#include "hullgauge/common/worker.h"

#include <cassert>
#include <utility>

namespace hg {

void Worker::start(Body body, Wake wake)
{
    assert(!running());
    thread_ = std::jthread(std::move(body));
    token_ = thread_.get_stop_token();
    // Registered after the thread exists: only the owner requests the stop, and not before start() returns.
    if (wake) wake_.emplace(token_, std::move(wake));
}

void Worker::stop()
{
    if (!thread_.joinable()) return;
    thread_.request_stop();
    thread_.join();
    wake_.reset();
}

} // namespace hg
