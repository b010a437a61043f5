// The inspection pipeline as the cycle runner sees it: a cycle begins with a
// part program, each grabbed view is handed over as soon as it is in (so view
// k is processed while the fixture moves to view k+1, docs/daemon.md, "The pipeline"), and
// finish() waits for the verdict.
#pragma once

#include "daemon_config.h"
#include "hullgauge/align/alignment.h"
#include "hullgauge/common/clock.h"
#include "hullgauge/common/status.h"
#include "hullgauge/geometry/fixture.h"
#include "hullgauge/station/result_record.h"
#include "hullgauge/vision/health.h"
#include "hullgauge/vision/manifest.h"
#include "hullgauge/vision/outline.h"

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <opencv2/core/mat.hpp>
#include <optional>
#include <string>
#include <vector>

namespace hg::daemon {

/// A landmark drawn on an archived part's picture: pixel position (of the
/// archived image: sensor pixels less its origin) and status.
struct LandmarkMark {
    cv::Point2d pixel;
    std::string id;
    inspect::LandmarkStatus status = inspect::LandmarkStatus::NotInspected;
    /// The measuring direction (the landmark's outward normal) in the image: unit, pixels; zero where the
    /// normal points along the line of sight.
    cv::Point2d direction{};
    /// Its outcome as the result records it (absent: the result does not hold it, e.g. masked).
    std::optional<station::LandmarkOutcome> outcome{};
};

/// What a view contributes to the part's archive (docs/daemon.md, "Archived parts").
struct ViewEvidence {
    cv::Mat image;      ///< the grabbed frame, as grabbed (the whole sensor, or a region of it)
    cv::Mat silhouette; ///< CV_8U mask, non-zero = part, of the image's size
    std::vector<LandmarkMark> landmarks;
    /// The view as the archive's manifest lists it: id, the posed camera the
    /// inspection used, the fixture pose (the archive sets the image). Absent:
    /// the archive holds the annotated picture only.
    std::optional<vision::ManifestView> capture{};
    /// How the inspection segmented the frame (the silhouette is drawn so too).
    vision::SegmentationSettings segmentation{};
    /// The station's calibration uncertainty and image quality, which the
    /// archive's manifest carries for the deviation's budget (docs/inspection.md).
    geometry::CalibrationUncertainty calibration{};
    geometry::ImageQuality imageQuality{};
    /// The nominal CAD outline at the measured seat, in the archived image's pixels (vision/outline.h); the
    /// overlay the HMI draws on the frame (docs/hmi.md, "Reject views").
    std::vector<vision::OutlinePolyline> outline{};
    /// Whether the outline is posed by a measured seat (false: the nominal seat).
    bool seatMeasured = false;
};

struct InspectionOutcome {
    bool ok = false; ///< false: the inspection could not be computed (`error` says why)
    std::string error;
    std::string part; ///< the part program's name
    /// The release of the program the part was judged with (docs/commissioning.md,
    /// "Release"); absent for a draft program.
    std::optional<station::ProgramRelease> release;
    bool pass = false;
    std::vector<station::LandmarkOutcome> landmarks;
    /// The correction set the deviations were corrected with (docs/mastering.md); empty: none.
    std::string correctionId;
    /// An inspected part's views for its archive: either `views` (ready) or `evidence`,
    /// which builds them (whole-frame segmentation) when the cycle writes the archive, after
    /// the result is shown — that work is not on the path from the last frame to the verdict.
    std::vector<ViewEvidence> views;
    std::function<std::vector<ViewEvidence>()> evidence;
    /// The part's measured seat when the program aligns (docs/alignment.md).
    std::optional<align::AlignmentResult> alignment;
    /// The seat is beyond the program's limits: nothing was inspected, the
    /// cycle ends with FAULT_CODE 32 (part-not-seated, docs/plc.md).
    bool seatingFault = false;
    /// The station's health the cycle's views showed (docs/health.md, "In the
    /// daemon"), examined beside the inspection; absent when the health is not
    /// watched or no view was examined.
    std::optional<vision::HealthFigures> health;
    Milliseconds processingTime{}; ///< preparation of every view plus the traversal
    Milliseconds prepareTime{};    ///< segmentation of the views (mostly while the fixture moved)
    Milliseconds traversalTime{};  ///< the goal-driven traversal after the last frame
};

/// A part program as the inspection loaded it: what `ctl status` shows of the
/// program it serves (docs/daemon.md, "Maintenance socket").
struct LoadedProgramInfo {
    std::uint16_t number = 0;
    std::string part; ///< the part program's name
    /// Its release (docs/commissioning.md, "Release"); absent for a draft.
    std::optional<station::ProgramRelease> release;
    /// The material it names (`material.name`, docs/part-program.md); '' when none: what its correction
    /// sets are kept for (docs/mastering.md).
    std::string material{};
};

class Inspector {
  public:
    virtual ~Inspector() = default;
    /// Loads (or reuses) the program's inspection map and plan; a failure
    /// with the reason when it cannot be loaded. Never throws: the cycle runs
    /// on (docs/style.md point 4).
    virtual Status begin(const station::PartProgramRef& program) = 0;
    /// The recipe changeover (docs/plc.md): loads the program's inspection map
    /// and plan now, if they are not loaded, so its first cycle need not; a
    /// failure with the reason when it cannot be loaded. Only between cycles.
    virtual Status prepare(const station::PartProgramRef& /*program*/) { return Status::success(); }
    /// Program `number` as the last successful begin() or prepare() loaded
    /// it (or found it loaded); nullopt when it is not loaded or not known.
    virtual std::optional<LoadedProgramInfo> loaded(std::uint16_t /*number*/) const { return std::nullopt; }
    /// The window of the sensor view `index` taken at `pose` needs — the
    /// bounds of every pixel its inspection reads (docs/inspection.md,
    /// "Pixels in proportion to the goal") — which the camera is asked to send
    /// (docs/daemon.md, "Regions per view"); empty: the whole frame. After begin().
    virtual cv::Rect region(std::size_t /*index*/, const geometry::FixturePose& /*pose*/) { return {}; }
    /// The part's temperature for the cycles begun from now on (docs/mastering.md,
    /// "Temperature"), with its standard uncertainty: their deviations are
    /// referred to 20 °C with the program's expansion coefficient; none: not referred.
    virtual void setPartTemperature(std::optional<double> /*temperatureC*/, double /*sigmaC*/) {}
    /// Hands over view `index` taken at `pose`: its frame and the sensor
    /// position of the frame's pixel (0, 0) (a region of the sensor, or the
    /// whole of it at (0, 0)); returns at once.
    virtual void addView(std::size_t index, const geometry::FixturePose& pose, cv::Mat image, cv::Point origin) = 0;
    /// How many first views measure the seat that corrects the planned poses
    /// of the views after them (the program's `alignment.correct_poses_after`;
    /// 0: none). Valid after begin().
    virtual std::size_t seatViews() const { return 0; }
    /// The seat measured on the first seatViews() views, waiting for their
    /// preparation; nullopt when the program does not align or a view could
    /// not be prepared (docs/alignment.md, "Poses corrected for the seat").
    virtual std::optional<align::AlignmentResult> provisionalSeat() { return std::nullopt; }
    /// Waits for every view to be processed and returns the verdict.
    virtual InspectionOutcome finish() = 0;
    /// Examines every view of the next cycles with `monitor`, after its
    /// preparation and off the path to the verdict, with the landmarks' edges
    /// in it as probes (docs/health.md, "In the daemon"); null: not watched.
    /// Between cycles only.
    virtual void watchHealth(std::unique_ptr<vision::HealthMonitor> monitor) { (void)monitor; }
    /// Drops the cycle (abort).
    virtual void cancel() = 0;
};

} // namespace hg::daemon
