// Volume-source voxel test (dissertation 3.3.4, 4.4, Rule 1 of 5.3.4).
//
// A voxel is projected whole onto each view: its footprint is the convex hull
// of its 8 projected corners (4 or 6 outline vertices — the same vertices the
// dissertation's 26-region table of fig. 3.13/3.14 picks). The background
// fraction of the footprint is measured exactly, area-weighted over the pixels
// it covers: every pixel row of the footprint is a convex piece whose vertical
// chord w(x) is piecewise linear in x, and on each linear stretch the integral
// of background(x) * w(x) over the whole pixels is a·Σb + b·Σb·x, two per-row
// prefix sums of the silhouette — so each row costs O(outline vertices), and
// the partial pixels at the ends of a stretch are integrated exactly.
//
// 50 % rule: the voxel is void as soon as >= 50 % of its footprint is
// background in ANY single view (the scan of a view stops once that is
// reached); otherwise object. Part of a footprint outside the frame (or outside
// the segmented regions) is unknown: a view decides "void" when its known
// background alone reaches 50 % of the whole footprint, decides "object" when
// background plus unknown stays below 50 %, and otherwise does not decide. A
// voxel no view decides (nor any view with a corner behind the camera) is
// Undecided — the inspection reports such landmarks as not_observable.
//
// Pixel convention (camera.h): pixel (c, r) covers [c-0.5, c+0.5] x [r-0.5, r+0.5].
// With lens distortion the outline is the hull of the distorted corners (the
// voxel edges bend by far less than a pixel over one voxel).
//
// The centre-point test (project the voxel centre, read one pixel) is kept
// beside it, selectable, as the baseline the dissertation argues against.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "hullgauge/geometry/camera.h"

namespace hg::align {
struct ViewEdges;
}

namespace hg::inspect {

struct ViewOutlines;

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;
using Box3 = Eigen::AlignedBox3d;

/// Result of a voxel reconstruction. `Unknown` means "not reconstructed yet".
enum class VoxelLabel : std::uint8_t { Unknown = 0, Void = 1, Object = 2, Undecided = 3 };

/// Per-row prefix sums of a background indicator over rectangular regions of
/// one frame. count(r, k) = Σ_{c<k} b(r, c); moment(r, k) = Σ_{c<k} b(r, c)·c
/// (region-local columns), both exact integers.
class SilhouetteIndex {
  public:
    struct Region {
        cv::Rect rect;  ///< in frame pixels
        int stride = 0; ///< rect.width + 1
        std::vector<std::int32_t> count;
        std::vector<std::int64_t> moment;
        bool background(int frameRow, int frameCol) const;
    };

    SilhouetteIndex() = default;
    explicit SilhouetteIndex(cv::Size frameSize) : frameSize_(frameSize) {}

    /// Adds a region from its silhouette (CV_8U, rect-sized, non-zero = object).
    /// Regions must not overlap.
    void addRegion(const cv::Rect& rect, const cv::Mat& silhouette);
    /// The whole frame as one region.
    static SilhouetteIndex fromSilhouette(const cv::Mat& silhouette);

    cv::Size frameSize() const { return frameSize_; }
    const std::vector<Region>& regions() const { return regions_; }
    /// The region holding all of `rect`, or nullptr.
    const Region* regionContaining(const cv::Rect& rect) const;
    /// The region holding pixel (col, row), or nullptr.
    const Region* regionAt(int col, int row) const;

  private:
    cv::Size frameSize_;
    std::vector<Region> regions_;
};

/// One calibrated view: the camera and the silhouette index of its frame
/// (sensor pixels).
struct SilhouetteView {
    geometry::CameraModel camera;
    SilhouetteIndex index;
    /// The grey frame and the threshold it was segmented with (shared pixels,
    /// not a copy): what alignment measures edges on (docs/alignment.md).
    cv::Mat grey{};
    double threshold = 0.0;
    bool objectIsDark = true;
    /// The view's share of the alignment, when the inspector aligns.
    std::shared_ptr<const align::ViewEdges> alignment{};
    /// Where the CAD outline runs beside each landmark, when the inspector
    /// measures deviations (docs/inspection.md, "Sub-voxel deviation").
    std::shared_ptr<const ViewOutlines> outlines{};
    /// Sensor position of grey's pixel (0, 0) when the frame is a region of
    /// the sensor (docs/inspection.md, "Frames that are regions"); the index
    /// and the camera stay in sensor pixels.
    cv::Point origin{0, 0};
};

/// How one view sees one voxel.
struct FootprintMeasure {
    bool inFront = false;    ///< all 8 corners in front of the camera
    double area = 0.0;       ///< footprint area, pixels²
    double background = 0.0; ///< known background area (may stop early at the 50 % mark)
    double unknown = 0.0;    ///< area outside the frame or the segmented regions
    int outlineVertices = 0; ///< 4 or 6 for a generic view (fewer when degenerate)
};

/// Outline (convex hull, counter-clockwise in pixel coordinates) of points.
std::vector<Vec2> convexHull(std::vector<Vec2> points);

/// Exact area of `polygon` (convex, pixel coordinates) covered by background
/// pixels of `region`; the polygon must lie inside the region's rectangle.
/// Stops once the area reaches `stopAt`.
double backgroundArea(const std::vector<Vec2>& polygon, const SilhouetteIndex::Region& region, double stopAt = 1e300);

enum class VoxelTestMethod { VolumeSource, CentrePoint };

class VoxelTester {
  public:
    VoxelTester(const std::vector<SilhouetteView>* views, VoxelTestMethod method = VoxelTestMethod::VolumeSource);

    /// The 50 % rule over all views (see the file comment).
    VoxelLabel classify(const Box3& voxel) const;
    /// Footprint of `voxel` in view `viewIndex`; stops integrating background once
    /// it reaches `stopFraction` of the footprint area (> 1: never stops).
    FootprintMeasure measure(const Box3& voxel, std::size_t viewIndex, double stopFraction = 2.0) const;
    /// The centre-point label of one view: Void, Object or Undecided (outside).
    VoxelLabel centrePointLabel(const Box3& voxel, std::size_t viewIndex) const;

    VoxelTestMethod method() const { return method_; }
    /// Voxel tests performed (calls of classify).
    std::uint64_t testsPerformed() const { return tests_; }

  private:
    enum class Vote { None, Void, Object };
    Vote vote(const Box3& voxel, std::size_t viewIndex) const;
    void measureFootprint(std::array<Vec2, 8>& corners, std::size_t viewIndex, double stopFraction,
                          FootprintMeasure& m) const;

    /// Per view: whether its camera has no lens distortion (the corners are
    /// then projected inline), and the region the last footprint lay in
    /// (neighbouring voxels mostly share it).
    struct ViewState {
        bool undistorted = false;
        mutable const SilhouetteIndex::Region* lastRegion = nullptr;
    };
    bool projectCorners(std::size_t viewIndex, const Box3& voxel, std::array<Vec2, 8>& corners) const;
    const SilhouetteIndex::Region* regionContaining(std::size_t viewIndex, const cv::Rect& rect) const;

    const std::vector<SilhouetteView>* views_;
    VoxelTestMethod method_;
    std::vector<ViewState> state_;
    mutable std::uint64_t tests_ = 0;
};

} // namespace hg::inspect
