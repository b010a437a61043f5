// Failed parts' images, written on a thread of their own: the cycle runner
// hands a part's frames over once its result is shown and serves the next
// trigger at once, while the whole-frame segmentation and PNG encoding run
// here, one part after the other (docs/daemon.md, "Results").
//
// One worker thread, owned by the writer and joined by its destructor after
// the queued parts are written (nothing the daemon promised is dropped at
// stop). A bounded queue: post() waits while `capacity` parts wait, so the
// frames held in memory stay bounded when parts fail faster than their
// images can be written.
#pragma once

#include "hullgauge/common/worker.h"

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <functional>
#include <mutex>
#include <stop_token>

namespace hg::daemon {

class ImageWriter {
  public:
    explicit ImageWriter(std::size_t capacity = 2);
    /// Writes what is queued, then joins the worker.
    ~ImageWriter();
    ImageWriter(const ImageWriter&) = delete;
    ImageWriter& operator=(const ImageWriter&) = delete;

    /// Queues `job` (it must not throw); waits while `capacity` jobs wait.
    void post(std::function<void()> job);
    /// Waits until every posted job has run.
    void drain();

  private:
    void work(std::stop_token stop);

    const std::size_t capacity_;
    std::mutex mutex_;
    std::condition_variable changed_;
    std::deque<std::function<void()>> queue_;
    bool busy_ = false;
    Worker worker_; ///< work(); last, so it ends before what it uses
};

} // namespace hg::daemon
