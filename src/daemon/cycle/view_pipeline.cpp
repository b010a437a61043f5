#include "cycle/view_pipeline.h"

#include "hullgauge/common/error.h"
#include "hullgauge/common/log.h"

#include <algorithm>
#include <utility>

namespace hg::daemon {
namespace {

/// A prepared view without its silhouette index: the camera, the frame's grey levels, the alignment's
/// and the deviation's shares (shared, not copied) — what measuring the seat and examining the view read.
inspect::SilhouetteView withoutIndex(const inspect::SilhouetteView& v)
{
    inspect::SilhouetteView out{v.camera, {}, v.grey, v.threshold, v.objectIsDark, v.alignment};
    out.outlines = v.outlines;
    out.origin = v.origin; // a region of the sensor: where its grey levels lie
    return out;
}

} // namespace

ViewPipeline::ViewPipeline(std::size_t capacity, Clock& clock) : capacity_(capacity), clock_(clock)
{
    if (capacity_ == 0) throw ArgumentError("ViewPipeline: capacity must be at least 1, found 0");
    worker_.start([this](std::stop_token stop) { work(stop); }, wakeOn(mutex_, changed_));
}

ViewPipeline::~ViewPipeline()
{
    {
        std::unique_lock lock(mutex_);
        dropLocked(lock);
    }
    worker_.stop();
}

void ViewPipeline::dropLocked(std::unique_lock<std::mutex>& lock)
{
    queue_.clear();
    ++cycle_;
    changed_.notify_all(); // a submit() waiting for room has room now
    changed_.wait(lock, [this] { return !busy_ && !examining_; });
    slots_.clear();
}

void ViewPipeline::begin(PrepareFn prepare, ExamineFn examine)
{
    std::unique_lock lock(mutex_);
    dropLocked(lock);
    prepare_ = std::move(prepare);
    examine_ = std::move(examine);
}

void ViewPipeline::waitExamined()
{
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [this] { return queue_.empty() && !busy_ && !examining_; });
}

void ViewPipeline::submit(inspect::CapturedView view)
{
    const auto submitted = clock_.now();
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [this] { return queue_.size() < capacity_; });
    Slot slot;
    slot.id = view.id;
    slot.timing.id = view.id;
    slot.timing.submitted = submitted;
    slots_.push_back(std::move(slot));
    queue_.push_back({cycle_, slots_.size() - 1, std::move(view)});
    changed_.notify_all();
}

ViewPipeline::Prepared ViewPipeline::wait()
{
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [this] {
        if (!queue_.empty() || busy_) return false;
        for (const auto& s : slots_)
            if (!s.done) return false;
        return true;
    });
    Prepared out;
    for (auto& s : slots_) {
        out.timings.push_back(s.timing);
        out.prepareTime += s.timing.finished - s.timing.started;
        if (!s.error.empty()) {
            if (out.error.empty()) out.error = s.error;
            continue;
        }
        out.views.push_back(std::move(*s.view));
        out.ids.push_back(s.id);
    }
    slots_.clear();
    ++cycle_;
    return out;
}

std::optional<std::vector<inspect::SilhouetteView>> ViewPipeline::firstPrepared(std::size_t count)
{
    std::unique_lock lock(mutex_);
    if (slots_.size() < count) return std::nullopt;
    const std::uint64_t cycle = cycle_;
    changed_.wait(lock, [&] {
        return cycle_ != cycle || std::all_of(slots_.begin(), slots_.begin() + static_cast<std::ptrdiff_t>(count),
                                              [](const Slot& s) { return s.done; });
    });
    if (cycle_ != cycle) return std::nullopt;
    std::vector<inspect::SilhouetteView> out;
    for (std::size_t k = 0; k < count; ++k) {
        const Slot& s = slots_[k];
        if (!s.error.empty() || !s.view) return std::nullopt;
        out.push_back(withoutIndex(*s.view));
    }
    return out;
}

std::size_t ViewPipeline::queued()
{
    std::lock_guard lock(mutex_);
    return queue_.size();
}

void ViewPipeline::cancel()
{
    std::unique_lock lock(mutex_);
    dropLocked(lock);
}

void ViewPipeline::work(std::stop_token stop)
{
    std::unique_lock lock(mutex_);
    while (true) {
        changed_.wait(lock, [&] { return stop.stop_requested() || !queue_.empty(); });
        if (stop.stop_requested()) return;
        Job job = std::move(queue_.front());
        queue_.pop_front();
        busy_ = true;
        PrepareFn prepare = prepare_;
        const auto started = clock_.now();
        changed_.notify_all(); // room in the queue
        lock.unlock();

        std::optional<inspect::SilhouetteView> prepared;
        std::string error;
        if (!prepare) {
            error = "view '" + job.view.id + "': no preparation set for the cycle";
        } else {
            try {
                prepared = prepare(job.view);
            } catch (const std::exception& e) {
                // prepareView's own messages name the view; anything else gets the name here.
                error = e.what();
                if (error.rfind("view '" + job.view.id + "'", 0) != 0) error = "view '" + job.view.id + "': " + error;
            }
        }
        const auto finished = clock_.now();
        // The frame is the caller's (it keeps it for the failed-part images); drop our reference outside the lock.
        job.view.frame.release();

        lock.lock();
        busy_ = false;
        std::optional<inspect::SilhouetteView> examined;
        const ExamineFn examine = examine_;
        if (job.cycle == cycle_ && job.slot < slots_.size()) {
            if (examine && prepared) examined = withoutIndex(*prepared);
            Slot& slot = slots_[job.slot];
            slot.view = std::move(prepared);
            slot.error = std::move(error);
            slot.timing.started = started;
            slot.timing.finished = finished;
            slot.done = true;
        }
        // Marked prepared before it is examined: the verdict's wait() is free to go.
        examining_ = examined.has_value();
        changed_.notify_all();
        if (!examined) continue;
        lock.unlock();
        try {
            examine(job.slot, *examined);
        } catch (const std::exception& e) {
            hg::log::category("inspect")->warn("view '{}' not examined for the station's health: {}", job.view.id,
                                               e.what());
        }
        examined.reset();
        lock.lock();
        examining_ = false;
        changed_.notify_all();
    }
}

} // namespace hg::daemon
