#include "cycle/image_writer.h"

#include "hullgauge/common/error.h"

namespace hg::daemon {

ImageWriter::ImageWriter(std::size_t capacity) : capacity_(capacity)
{
    if (capacity_ == 0) throw ArgumentError("ImageWriter: capacity must be at least 1, found 0");
    worker_ = std::thread([this] { work(); });
}

ImageWriter::~ImageWriter()
{
    drain();
    {
        std::lock_guard lock(mutex_);
        stop_ = true;
    }
    changed_.notify_all();
    worker_.join();
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

void ImageWriter::work()
{
    std::unique_lock lock(mutex_);
    while (true) {
        changed_.wait(lock, [this] { return stop_ || !queue_.empty(); });
        if (queue_.empty()) return; // stop_, and nothing left to write
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
