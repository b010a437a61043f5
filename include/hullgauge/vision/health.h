// Station health from the frames a cycle already grabbed (docs/health.md): the
// backlight's level and uniformity against the flat-field reference taken at
// calibration, dark specks on the backlight (dust), the edge profile's width
// across the landmarks' silhouette edges (focus), contrast and noise. A
// station degrades slowly — a dusty diffuser, an aging panel, a lens knocked
// out of focus — and each of these moves the edge-location uncertainty of
// dissertation 4.4 (vision/edge.h, edgeSigmaPx) long before a verdict goes
// wrong; the figures are watched so the warning comes first.
//
// The cost is a budget, not an afterthought: a cycle's views are examined on
// a sparse sample of the background and a few profile reads per landmark, and
// the dust search covers the frame in bands over successive cycles, so a
// cycle of 8 views costs about 0.1 ms of CPU (tools/bench, docs/health.md).
//
// Pure computation on values: no I/O, no threads, no clock. The monitor keeps
// state between cycles (the dust survey's bands); one thread at a time.
#pragma once

#include "hullgauge/common/enum_names.h"
#include "hullgauge/vision/edge.h"

#include <cstddef>
#include <cstdint>
#include <limits>
#include <map>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace hg::vision {

/// The empty fixture's backlight as calibration saw it (docs/health.md,
/// "Reference"): the level per cell × cell block of the sensor.
struct FlatField {
    cv::Size sensor{};  ///< the sensor the reference covers
    int cell = 32;      ///< px: side of the blocks `level` keeps
    cv::Mat level;      ///< CV_32FC1, ceil(sensor / cell): mean grey per block, fraction of full scale
    double noise = 0.0; ///< the empty frame's grey-level σ, fraction of full scale
    int dustSpecks = 0; ///< dark specks the reference already shows (the baseline of the dust count)
    /// Where those specks are (sensor pixels, their centroids): a speck the
    /// monitor finds within 2 px of one of them is not new (docs/health.md,
    /// "Reference"). buildFlatField lists every speck it counts.
    std::vector<cv::Point2f> dustAt;
    std::int64_t takenUnixMs = 0;

    bool empty() const { return level.empty(); }
};

/// Builds the reference from frames of the empty fixture (whole sensor,
/// CV_8UC1 or CV_16UC1), averaged. Throws hg::InputError when a frame is not
/// the size of the first, a frame is not grey, or a block is darker than half
/// the median level (something is in the fixture: naming the block's pixel
/// position).
FlatField buildFlatField(std::span<const cv::Mat> frames, std::int64_t takenUnixMs, int cell = 32);

/// One landmark's silhouette edge in a view: where to read its profile.
struct EdgeProbe {
    Eigen::Vector2d pixel;  ///< the edge's expected position (sensor pixels)
    Eigen::Vector2d normal; ///< unit, from the object to the background
};

/// The figures (docs/health.md, "Figures"); one bit each in the PLC's HEALTH_WARNINGS.
enum class HealthFigure {
    Backlight,  ///< background level against the reference (1 = as calibrated)
    Uniformity, ///< worst relative departure of a block's level from the reference's shape
    Dust,       ///< dark specks on the backlight beyond the reference's own
    Focus,      ///< 10–90 % width of the edge profile, px
    Contrast,   ///< (background − object) / full scale at the edges
    Noise,      ///< background grey-level σ, fraction of full scale
    EdgeBias,   ///< the silhouettes larger (+) or smaller than the CAD's outline all round, px (the alignment's)
    Capability, ///< the largest share of its capability bound (4 U / zone) a landmark's predicted U takes
};

constexpr auto nameTable(HealthFigure)
{
    using enum HealthFigure;
    return std::to_array<EnumName<HealthFigure>>({{Backlight, "backlight"},
                                                  {Uniformity, "uniformity"},
                                                  {Dust, "dust"},
                                                  {Focus, "focus"},
                                                  {Contrast, "contrast"},
                                                  {Noise, "noise"},
                                                  {EdgeBias, "edge_bias"},
                                                  {Capability, "capability"}});
}

inline constexpr double kNoFigure = std::numeric_limits<double>::quiet_NaN();

/// What the views of one cycle show of the station. A figure no view could
/// measure (no reference, no probe with a clean edge) is NaN.
struct HealthFigures {
    double backlight = kNoFigure;
    double uniformity = kNoFigure;
    double dustSpecks = kNoFigure; ///< specks beyond the reference's, the whole backlight (the survey's estimate)
    double edgeWidthPx = kNoFigure;
    double contrast = kNoFigure;
    double noise = kNoFigure;
    /// The edge-location standard uncertainty these figures predict (px):
    /// edgeSigmaPx(noise, contrast) widened by the blur the edge width shows
    /// (docs/health.md, "Prediction"); what the landmarks' U follows.
    double predictedSigmaPx = kNoFigure;
    /// The alignment's median (edge − outline)·outward normal (align::AlignmentResult::edgeBiasPx):
    /// set by the daemon after the inspection measured the seat, not by the monitor; NaN without one.
    double edgeBiasPx = kNoFigure;
    /// inspect::capabilityUsed at predictedSigmaPx: 1 when the worst landmark's predicted U reaches
    /// its capability bound (docs/health.md, "Capability"); set by the daemon, which knows the program.
    double capability = kNoFigure;
    int views = 0;  ///< views examined
    int probes = 0; ///< edge profiles measured
    /// Bands of the dust survey examined since the monitor began (of
    /// HealthMonitor::dustSurveyBands()): the dust figure covers these.
    int dustBandsSurveyed = 0;
};

/// Limits per figure (docs/health.md, "Limits"); a figure beyond its limit is a warning.
struct HealthLimits {
    double minBacklight = 0.80;
    double maxUniformity = 0.10;
    double maxDustSpecks = 5.0;
    double maxEdgeWidthPx = 3.0;
    double minContrast = 0.40;
    double maxNoise = 0.02;
    double maxEdgeBiasPx = 0.25; ///< judged on |edgeBiasPx|
    double maxCapability = 0.9;  ///< warns before a landmark's predicted U reaches its bound (1)
};

/// The edge-location standard uncertainty (px) that noise and contrast (both
/// in one unit: fractions of full scale, or grey levels) and the edge profile's
/// 10–90 % width predict for vision::findEdge: edgeSigmaPx(noise, contrast)
/// and the window's jitter a blurred edge adds (docs/health.md, "Prediction").
/// NaN when noise or contrast is; edgeSigmaPx alone when the width is NaN.
double predictedEdgeSigmaPx(double noise, double contrast, double edgeWidthPx);

/// The figures beyond their limits, in the enum's order; NaN figures never warn.
std::vector<HealthFigure> healthWarnings(const HealthFigures& figures, const HealthLimits& limits);
/// Bit k set for the k-th figure of HealthFigure among `warnings` (PLC HEALTH_WARNINGS).
std::uint16_t healthWarningBits(std::span<const HealthFigure> warnings);

/// Watches a station's frames cycle after cycle (docs/health.md).
class HealthMonitor {
  public:
    /// Without a reference (empty) the backlight, uniformity and dust are not
    /// measured. Throws hg::ArgumentError when a reference is not one
    /// buildFlatField could have made (levels not ceil(sensor / cell) blocks
    /// of CV_32FC1, noise outside [0, 1)).
    explicit HealthMonitor(FlatField reference = {});

    const FlatField& reference() const { return reference_; }

    /// A new cycle: forgets the views of the last.
    void beginCycle();
    /// View `view` of the cycle: its frame (the whole sensor or a region of it,
    /// EdgeImage's origin) and the landmarks' edges in it. Cheap by design (the
    /// file comment); the frame is read, never kept. Throws hg::ArgumentError
    /// naming the view when its frame is not 8- or 16-bit grey or, placed at
    /// its origin, leaves the sensor.
    void addView(std::size_t view, const EdgeImage& image, std::span<const EdgeProbe> probes);
    /// The cycle's figures.
    HealthFigures endCycle();

    /// How many horizontal bands of the sensor the dust survey goes through,
    /// one per cycle (docs/health.md, "Figures"); 0 without a reference.
    int dustSurveyBands() const { return bands_; }

  private:
    struct ViewContext; // one view's frame as health.cpp reads it

    void sampleBackground(ViewContext& view);
    void surveyBand(const ViewContext& view);

    FlatField reference_;
    std::vector<cv::Point2f> referenceSpecks_; ///< reference_.dustAt sorted by y
    cv::Mat lowestLevel_;                      ///< per block: the lowest level within it (the dust limits)
    cv::Size zones_{};                         ///< uniformity zones across the sensor
    int zoneSide_ = 0;                         ///< px
    int bands_ = 0;
    std::uint64_t cycle_ = 0;

    // The cycle's pools.
    int views_ = 0;
    std::vector<int> ratioBins_; ///< the background samples' ratios to the reference, counted in bins
    long ratioCount_ = 0;
    std::vector<double> zoneSum_;
    std::vector<int> zoneCount_;
    std::vector<double> widths_, contrasts_;
    /// |differences| of neighbouring background pixels counted in bins of grey
    /// levels of the cycle's first frame's depth (full scale stepsFull_).
    std::vector<int> stepBins_;
    long stepCount_ = 0;
    double stepsFull_ = 0.0;

    /// The last view's zones (for its dust thresholds): the sum of its samples' ratios and their count.
    std::vector<double> viewZoneSum_;
    std::vector<int> viewZoneCount_;

    /// The dust survey: this cycle's band, which of its pixels a view of the
    /// cycle showed as backlight (0 not yet, 1 surveyed), the new specks found
    /// in it, and the specks found in each band when it was last examined.
    int band_ = 0;
    bool bandExamined_ = false;
    int bandFound_ = 0;
    std::vector<std::uint8_t> bandSeen_;
    std::map<int, int> bandSpecks_;
};

} // namespace hg::vision
