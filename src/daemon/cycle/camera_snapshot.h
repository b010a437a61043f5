// A camera frame on demand (docs/hmi.md, "Maintenance"): the line engineer asks
// for one frame — at the fixture's current pose or at a pose given — and sees
// it with the silhouette the station's segmentation finds in it, to set up the
// backlight, exposure and focus. Queued on the maintenance socket, grabbed by
// the cycle runner between cycles (production paused for the grab as for a
// calibration: PLC STATUS 5), kept in memory as one PNG until the next.
#pragma once

#include "cycle/devices.h"
#include "daemon_config.h"
#include "hullgauge/common/clock.h"
#include "maintenance_job.h"

#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <opencv2/core/mat.hpp>
#include <optional>
#include <vector>

namespace hg::daemon {

struct SnapshotJob {
    /// Where to move first; none: the fixture stays where it is.
    std::optional<geometry::FixturePose> pose;
};

/// What the segmentation found in one frame, for the overlay's legend.
struct SnapshotFigures {
    double threshold = 0;      ///< grey level (the frame's depth) separating object and backlight
    double objectFraction = 0; ///< share of the frame's pixels that are object
    double backlightGrey = 0;  ///< median grey of the backlight pixels (saturation shows as the depth's top)
    double objectGrey = 0;     ///< median grey of the object pixels
};

/// The frame as 8-bit colour with the silhouette tinted and its outline drawn:
/// what the engineer judges the segmentation by. `grey` is the frame (8 or
/// 16 bit), `mask` its silhouette (CV_8U, 255 = object) of the same size.
cv::Mat snapshotOverlay(const cv::Mat& grey, const cv::Mat& mask);
/// The figures of `grey` segmented into `mask` at `threshold`.
SnapshotFigures snapshotFigures(const cv::Mat& grey, const cv::Mat& mask, double threshold);

class CameraSnapshot {
  public:
    /// Queues `job`; a failure saying why when one is queued or running or the station is not ready.
    Status request(SnapshotJob job, station::SequencerState state);
    bool queued() const { return queue_.queued(); }
    std::optional<SnapshotJob> take() { return queue_.take(); }
    void requeue(SnapshotJob job) { queue_.requeue(std::move(job)); }
    void refuse(const std::string& why) { queue_.refuse(why); }

    /// Moves (when the job names a pose), settles, grabs one frame, segments it
    /// with the station's segmentation and keeps the overlay. True when a frame
    /// was grabbed; false (the error in the status) when a device failed.
    bool run(const SnapshotJob& job, StationDevices& devices, const station::DaemonConfig& cfg, Clock& clock);

    /// State (queued, running, done, failed), the error, and of the last frame:
    /// `id` (counts up), `time`, `width`, `height`, `depth_bits`, `pose` (when
    /// moved), `grab_ms`, `segmentation` (method, threshold, object_is_dark),
    /// `object_fraction`, `backlight_grey`, `object_grey`.
    nlohmann::json status() const { return queue_.status(); }
    /// The last frame's overlay as PNG; null before the first.
    std::shared_ptr<const std::vector<unsigned char>> png() const;

  private:
    MaintenanceJob<SnapshotJob> queue_{"a camera snapshot"};
    mutable std::mutex pngMutex_;
    std::shared_ptr<const std::vector<unsigned char>> png_;
    std::uint64_t frames_ = 0; // runner thread only
};

} // namespace hg::daemon
