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
// cycle of 8 views costs well under 0.2 ms (tools/bench, docs/health.md).
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
};

constexpr auto nameTable(HealthFigure)
{
    using enum HealthFigure;
    return std::to_array<EnumName<HealthFigure>>({{Backlight, "backlight"},
                                                  {Uniformity, "uniformity"},
                                                  {Dust, "dust"},
                                                  {Focus, "focus"},
                                                  {Contrast, "contrast"},
                                                  {Noise, "noise"}});
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
    int views = 0;  ///< views examined
    int probes = 0; ///< edge profiles measured
};

/// Limits per figure (docs/health.md, "Limits"); a figure beyond its limit is a warning.
struct HealthLimits {
    double minBacklight = 0.80;
    double maxUniformity = 0.10;
    double maxDustSpecks = 5.0;
    double maxEdgeWidthPx = 3.0;
    double minContrast = 0.40;
    double maxNoise = 0.02;
};

/// The figures beyond their limits, in the enum's order; NaN figures never warn.
std::vector<HealthFigure> healthWarnings(const HealthFigures& figures, const HealthLimits& limits);
/// Bit k set for the k-th figure of HealthFigure among `warnings` (PLC HEALTH_WARNINGS).
std::uint16_t healthWarningBits(std::span<const HealthFigure> warnings);

/// Watches a station's frames cycle after cycle (docs/health.md).
class HealthMonitor {
  public:
    /// Without a reference (empty) the backlight, uniformity and dust are not measured.
    explicit HealthMonitor(FlatField reference = {});

    const FlatField& reference() const { return reference_; }

    /// A new cycle: forgets the views of the last.
    void beginCycle();
    /// View `view` of the cycle: its frame (the whole sensor or a region of it,
    /// EdgeImage's origin) and the landmarks' edges in it. Cheap by design (the
    /// file comment); the frame is read, never kept.
    void addView(std::size_t view, const EdgeImage& image, std::span<const EdgeProbe> probes);
    /// The cycle's figures.
    HealthFigures endCycle();

  private:
    struct ViewFigures {
        double backlight = kNoFigure;
        double uniformity = kNoFigure;
        double edgeWidthPx = kNoFigure;
        double contrast = kNoFigure;
        double noise = kNoFigure;
        int probes = 0;
    };
    FlatField reference_;
    std::uint64_t cycle_ = 0;
    std::vector<ViewFigures> views_;
    /// The dust survey: specks found in each band of the sensor when it was last examined.
    std::map<int, int> bandSpecks_;
};

} // namespace hg::vision
