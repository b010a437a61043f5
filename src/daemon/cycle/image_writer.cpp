#include "cycle/image_writer.h"

#include "hullgauge/common/error.h"

namespace hg::daemon {

ImageWriter::ImageWriter(std::size_t capacity) : capacity_(capacity)
{
    if (capacity_ == 0) throw ArgumentError("ImageWriter: capacity must be at least 1, found 0");
    worker_.start([this](std::stop_token stop) { work(stop); }, wakeOn(mutex_, changed_));
}

ImageWriter::~ImageWriter()
{
    drain();
    worker_.stop();
}

void ImageWriter::post(std::function<void()> job)
{
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [this] { return queue_.size() < capacity_; });
    queue_.push_back(std::move(job));
    changed_.notify_all();
}

void ImageWriter::drain()
{
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [this] { return queue_.empty() && !busy_; });
}

void ImageWriter::work(std::stop_token stop)
{
    std::unique_lock lock(mutex_);
    while (true) {
        changed_.wait(lock, [&] { return stop.stop_requested() || !queue_.empty(); });
        if (queue_.empty()) return; // the stop, and nothing left to write
        auto job = std::move(queue_.front());
        queue_.pop_front();
        busy_ = true;
        changed_.notify_all(); // room in the queue
        lock.unlock();
        job();
        job = nullptr; // the part's frames go here, outside the lock
        lock.lock();
        busy_ = false;
        changed_.notify_all();
    }
}

} // namespace hg::daemon
