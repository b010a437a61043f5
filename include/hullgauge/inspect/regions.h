// The pixels an inspection needs (docs/inspection.md, "Pixels in proportion
// to the goal"): per view, the frame rectangles the voxels it may test project
// to — each inspected landmark's network, `adjacency` 26-neighbour layers
// around its voxel, widened in space by the seat's margin when the part is
// aligned — and, when the sub-voxel deviation is measured, the pixels its
// edge search reads beside each landmark. Segmentation, the threshold's
// statistics, the voxel test and the sub-pixel edges touch nothing else.
//
// A pure function of the map, the view's camera and the query: the daemon can
// compute it once per planned view, e.g. to set each camera's own region of
// interest to `bounds`.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include <opencv2/core.hpp>

#include "hullgauge/geometry/camera.h"
#include "hullgauge/inspect/inspection_map.h"

namespace hg::inspect {

/// What an inspection asks of the frames.
struct RegionQuery {
    int level = -1;     ///< inspection level; -1 = the map's depth
    int adjacency = -1; ///< layers around each landmark voxel; -1 = the map's adjacency depth
    /// Per landmark (map order), non-zero when inspected; empty = all.
    std::vector<std::uint8_t> active;
    /// How far the seat may move any point of the part (mm): the aligner's
    /// margin, `max_shift_mm` + lever × `max_rotation_deg` (docs/alignment.md); 0 unaligned.
    double marginMm = 0.0;
    /// The sub-voxel step's edge reads beside each landmark (docs/inspection.md).
    bool edges = false;
};

/// One view's regions of interest, in frame pixels, clipped to the frame.
struct ViewRegions {
    /// Segmented and indexed for the voxel test: merged until none overlap,
    /// so every footprint the inspection can ask for lies in one of them.
    std::vector<cv::Rect> voxels;
    /// Grey pixels only read (the sub-pixel edges beside the landmarks; the
    /// aligner's search band along the CAD outline when the part is aligned),
    /// merged until none overlap. They may overlap `voxels`.
    std::vector<cv::Rect> edges;
    /// The bounding box of all of them (empty when there are none): the
    /// window a camera must deliver.
    cv::Rect bounds;
    /// Pixels in `voxels` (what is segmented and indexed).
    std::int64_t voxelPixels() const;
};

/// The pixels a box's footprint may touch: the bounding box of its 8
/// projected corners (pixel (c, r) covers c ± ½, r ± ½), one pixel more all
/// round (lens distortion bends the box's edges between its corners), clipped
/// to the frame. nullopt when a corner is behind the camera or nothing of it
/// is in the frame.
std::optional<cv::Rect> footprintRect(const geometry::CameraModel& camera, const Eigen::AlignedBox3d& box);

/// `rects` with every overlapping pair replaced by its bounding box, until
/// none overlap (rectangles that only touch stay apart).
std::vector<cv::Rect> mergeOverlapping(const std::vector<cv::Rect>& rects);

/// The regions of one view. Throws ArgumentError for a level or
/// adjacency the map does not have.
ViewRegions viewRegions(const InspectionMap& map, const geometry::CameraModel& camera, const RegionQuery& query);

/// The regions of every view, in order.
std::vector<ViewRegions> viewRegions(const InspectionMap& map, const std::vector<geometry::CameraModel>& cameras,
                                     const RegionQuery& query);

} // namespace hg::inspect
