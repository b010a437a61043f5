// The nominal outline a reject picture is drawn with (docs/hmi.md, "Reject
// views"): the CAD mesh, posed by the seat the alignment measured, seen
// through a view's camera — the occluding contour of the solid, which the
// dissertation's silhouette inspection (3.3.8) compares the part's
// silhouette against — as closed polylines in the pixels of the archived
// frame.
//
// Computed by rendering, not by walking mesh edges: the simulated camera's
// renderer (sim/renderer.h) gives each pixel's exact coverage, the mask
// "coverage ≥ ½" is traced with cv::findContours and every traced pixel
// centre is moved along the coverage gradient to where the coverage crosses
// ½ (for a straight edge the coverage of a pixel is ½ plus the centre's
// distance inside the edge), which puts the vertices within a fraction of a
// pixel of the analytic outline. Holes are outlines too. Where the part
// leaves the frame the frame's border is not an outline: the polylines are
// cut there.
//
// Pure computation on values: no I/O, no threads.
#pragma once

#include "hullgauge/geometry/camera.h"
#include "hullgauge/model/mesh.h"

#include <opencv2/core/types.hpp>
#include <vector>

namespace hg::vision {

/// A polyline in pixel coordinates (camera.h's convention: pixel (c, r) is centred at (c, r)).
struct OutlinePolyline {
    std::vector<cv::Point2d> points;
    bool closed = true; ///< false: cut by the frame's border
};

struct OutlineOptions {
    /// The frame is this region of the sensor (docs/camera.md, "Regions per
    /// grab"): the polylines are in its pixels. Empty: the whole sensor.
    cv::Rect window{};
    /// Douglas–Peucker tolerance of the polylines, pixels (0: every traced pixel).
    double simplifyPx = 0.25;
};

/// The outline of the closed mesh `mesh` (part frame) as `camera`
/// (camera_from_part, e.g. align::seatedCamera of the view's) sees it. Empty
/// when the part is not in the frame. Throws ArgumentError when the window
/// leaves the sensor.
std::vector<OutlinePolyline> projectedOutline(const model::TriangleMesh& mesh, const geometry::CameraModel& camera,
                                              const OutlineOptions& options = {});

} // namespace hg::vision
