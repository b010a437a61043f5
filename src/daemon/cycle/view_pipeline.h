// The inspection pipeline's worker (docs/daemon.md, "The pipeline"): view k's frame is
// segmented into its silhouette index — the per-view half of the goal-driven
// inspection, the regions of interest the volume-source voxel test of
// dissertation 3.3.4 will read — on a thread of its own while the cycle runner
// moves the fixture to view k+1. When the last frame is in, only the traversal
// (3.3.8) is left, so the verdict follows the last frame within milliseconds.
//
// One worker thread, owned by the pipeline and joined by its destructor (no
// detached threads); a bounded queue: submit() returns at once unless
// `capacity` views already wait, then it waits for room (back-pressure instead
// of unbounded frame memory). The pipeline does not know how a view is prepared:
// the caller passes the preparation with begin() (the daemon passes
// hg::inspect::Inspector::prepareView, tests a slow stand-in).
//
// Beside the preparation a cycle may examine each prepared view (the station's
// health, docs/health.md "In the daemon"): the worker runs the examination
// after it has marked the view prepared, so wait() — the verdict — never waits
// for it; waitExamined() does, once the verdict is in.
//
// Thread safety: begin/submit/wait/waitExamined/cancel are called by one
// thread (the cycle runner); the worker runs the preparation and examination
// functions, which must be safe to run beside that thread (prepareView is const
// and free of shared state; the examination's state is the caller's, read by it
// only after waitExamined()).
#pragma once

#include "hullgauge/common/clock.h"
#include "hullgauge/common/worker.h"
#include "hullgauge/inspect/inspector.h"

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <optional>
#include <stop_token>
#include <string>
#include <vector>

namespace hg::daemon {

class ViewPipeline {
  public:
    using PrepareFn = std::function<inspect::SilhouetteView(const inspect::CapturedView&)>;
    /// Examines view `index` (submission order) once prepared; the view comes
    /// without its silhouette index (camera, grey levels, threshold, origin,
    /// outlines: shared, not copied). What it throws is logged and dropped.
    using ExamineFn = std::function<void(std::size_t index, const inspect::SilhouetteView& view)>;

    /// When a view went through the pipeline (for the latency breakdown and the tests).
    struct ViewTiming {
        std::string id;
        Clock::time_point submitted; ///< submit() was called (the frame was just grabbed)
        Clock::time_point started;   ///< the worker began preparing it
        Clock::time_point finished;  ///< the worker finished (or failed) it
    };

    /// The prepared silhouettes of a cycle, in submission order.
    struct Prepared {
        std::vector<inspect::SilhouetteView> views;
        std::vector<std::string> ids;
        /// Empty, or why the first failing view (in submission order) could not be
        /// prepared, naming the view; `views` is then incomplete and must not be inspected.
        std::string error;
        Milliseconds prepareTime{}; ///< sum of the worker's preparation times
        std::vector<ViewTiming> timings;
    };

    /// Starts the worker. `capacity` >= 1: views that may wait unprepared;
    /// `clock` times the views (ViewTiming).
    explicit ViewPipeline(std::size_t capacity = 4, Clock& clock = Clock::steady());
    /// Drops queued views, lets the one in preparation end, joins the worker.
    ~ViewPipeline();
    ViewPipeline(const ViewPipeline&) = delete;
    ViewPipeline& operator=(const ViewPipeline&) = delete;

    /// A new cycle prepared with `prepare` and its views examined with
    /// `examine` (none: not examined); whatever an earlier cycle left is dropped.
    void begin(PrepareFn prepare, ExamineFn examine = nullptr);
    /// Queues a view of the current cycle. Returns at once while fewer than
    /// `capacity` views wait, else waits for the worker to take one.
    void submit(inspect::CapturedView view);
    /// Waits until every submitted view is prepared and ends the cycle.
    Prepared wait();
    /// Waits until the first `count` views of the cycle are prepared and
    /// returns them without their silhouette indexes (the cameras, the frames
    /// and the alignment's share, shared, not copied) — what measuring the seat
    /// needs while the cycle goes on (docs/daemon.md, "The pipeline").
    /// nullopt when fewer were submitted or one of them failed; the cycle's
    /// views stay for wait().
    std::optional<std::vector<inspect::SilhouetteView>> firstPrepared(std::size_t count);
    /// Waits until every view submitted is prepared and examined: after
    /// wait(), the examination of the last view may still run beside the verdict.
    void waitExamined();
    /// Drops the queued views and waits for the one in preparation or
    /// examination to end (its result is discarded), so the preparation and
    /// examination functions are no longer in use.
    void cancel();

    std::size_t capacity() const { return capacity_; }
    /// Views submitted and not yet taken by the worker.
    std::size_t queued();

  private:
    struct Job {
        std::uint64_t cycle;
        std::size_t slot;
        inspect::CapturedView view;
    };
    struct Slot {
        std::string id;
        std::optional<inspect::SilhouetteView> view;
        std::string error;
        bool done = false;
        ViewTiming timing;
    };

    void work(std::stop_token stop);
    void dropLocked(std::unique_lock<std::mutex>& lock);

    const std::size_t capacity_;
    Clock& clock_;
    std::mutex mutex_;
    std::condition_variable changed_; ///< queue, slots or busy_ changed
    std::deque<Job> queue_;
    std::vector<Slot> slots_;
    PrepareFn prepare_;
    ExamineFn examine_;
    std::uint64_t cycle_ = 0; ///< increases on begin() and cancel(): stale results are discarded
    bool busy_ = false;       ///< the worker is preparing a view (outside the lock)
    bool examining_ = false;  ///< the worker is examining a prepared view (outside the lock)
    Worker worker_;           ///< work(); last, so it ends before what it uses
};

} // namespace hg::daemon
