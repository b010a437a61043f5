// Regions of interest from the map (docs/inspection.md, "Pixels in proportion
// to the goal").
#include "hullgauge/inspect/regions.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "hullgauge/common/error.h"
#include "hullgauge/inspect/deviation.h"

namespace hg::inspect {
namespace {

cv::Rect boundsOf(const std::vector<cv::Rect>& a, const std::vector<cv::Rect>& b)
{
    cv::Rect out;
    for (const auto* list : {&a, &b})
        for (const cv::Rect& r : *list) out = out.empty() ? r : (out | r);
    return out;
}

/// The box of landmark l's network at the query's level: its voxel and
/// `adjacency` layers round it (inside the cube), widened by the margin.
Box3 networkBox(const InspectionMap& map, std::size_t l, int level, int adjacency, double marginMm)
{
    const VoxelFrame& voxels = map.frame();
    const double s = voxels.voxelSize(level);
    const int nmax = (1 << level) - 1;
    const Eigen::Vector3i c = keyIndex(map.nodes()[static_cast<std::size_t>(map.landmarkNode(l, level))].key);
    const Eigen::Vector3i lo = (c.array() - adjacency).max(0).matrix();
    const Eigen::Vector3i hi = (c.array() + adjacency).min(nmax).matrix() + Eigen::Vector3i::Ones();
    return Box3(voxels.origin + s * lo.cast<double>() - Vec3::Constant(marginMm),
                voxels.origin + s * hi.cast<double>() + Vec3::Constant(marginMm));
}

/// The seat's margin in pixels at the nearest depth the part cube reaches in
/// this camera (an outline point may lie anywhere in the part), and one
/// pixel for the turn of the normal's image; 0 unaligned.
double marginPixels(const InspectionMap& map, const geometry::CameraModel& camera, double marginMm)
{
    if (marginMm <= 0.0) return 0.0;
    const VoxelFrame& f = map.frame();
    const Box3 cube(f.origin, f.origin + Vec3::Constant(f.cubeSize));
    double nearest = 1e300;
    for (int i = 0; i < 8; ++i)
        nearest = std::min(nearest, camera.depthOf(cube.corner(static_cast<Box3::CornerType>(i))));
    // A camera inside the cube: the margin cannot be bounded by depth; the
    // whole frame. (A telecentric camera's scale is the same at every depth.)
    if (!camera.depthInFront(nearest) || (!camera.isTelecentric() && !(nearest > 1e-6))) return 1e6;
    return marginMm / camera.millimetresPerPixelAt(nearest).minCoeff() + 1.0;
}

} // namespace

std::int64_t ViewRegions::voxelPixels() const
{
    std::int64_t n = 0;
    for (const cv::Rect& r : voxels) n += static_cast<std::int64_t>(r.area());
    return n;
}

std::optional<cv::Rect> footprintRect(const geometry::CameraModel& camera, const Box3& box)
{
    double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
    for (int i = 0; i < 8; ++i) {
        const auto px = camera.project(box.corner(static_cast<Box3::CornerType>(i)));
        if (!px) return std::nullopt;
        x0 = std::min(x0, px->x());
        y0 = std::min(y0, px->y());
        x1 = std::max(x1, px->x());
        y1 = std::max(y1, px->y());
    }
    // Pixel (c, r) spans c ± 0.5; one pixel of margin for distortion bending.
    const int c0 = static_cast<int>(std::floor(x0 + 0.5)) - 1, r0 = static_cast<int>(std::floor(y0 + 0.5)) - 1;
    const int c1 = static_cast<int>(std::floor(x1 + 0.5)) + 1, r1 = static_cast<int>(std::floor(y1 + 0.5)) + 1;
    const cv::Rect frame(0, 0, camera.imageSize().width, camera.imageSize().height);
    if (c1 < 0 || r1 < 0 || c0 >= frame.width || r0 >= frame.height) return std::nullopt;
    const cv::Rect r = cv::Rect(cv::Point(c0, r0), cv::Point(c1 + 1, r1 + 1)) & frame;
    if (r.empty()) return std::nullopt;
    return r;
}

std::vector<cv::Rect> mergeOverlapping(const std::vector<cv::Rect>& rects)
{
    // `out` never holds two overlapping rectangles: each new one absorbs every
    // one it overlaps (growing, it may reach more), then joins them.
    std::vector<cv::Rect> out;
    for (cv::Rect r : rects) {
        if (r.empty()) continue;
        for (std::size_t j = 0; j < out.size();) {
            if ((r & out[j]).area() > 0) {
                r |= out[j];
                out.erase(out.begin() + static_cast<std::ptrdiff_t>(j));
                j = 0;
            } else {
                ++j;
            }
        }
        out.push_back(r);
    }
    return out;
}

ViewRegions viewRegions(const InspectionMap& map, const geometry::CameraModel& camera, const RegionQuery& query)
{
    const MapGeometry& g = map.geometry();
    const int level = query.level < 0 ? g.depth : query.level;
    const int adjacency = query.adjacency < 0 ? g.adjacencyDepth : query.adjacency;
    if (level < g.coarsestLevel || level > g.depth)
        throw ArgumentError("regions of interest: level " + std::to_string(level) + " is not in the map (levels " +
                            std::to_string(g.coarsestLevel) + ".." + std::to_string(g.depth) + ")");
    if (adjacency < 0 || adjacency > g.adjacencyDepth)
        throw ArgumentError("regions of interest: adjacency " + std::to_string(adjacency) + " is not within 0.." +
                            std::to_string(g.adjacencyDepth));
    const cv::Rect frame(0, 0, camera.imageSize().width, camera.imageSize().height);
    const double marginPx = query.edges ? marginPixels(map, camera, query.marginMm) : 0.0;
    std::vector<cv::Rect> voxels, edges;
    for (std::size_t l = 0; l < map.landmarks().size(); ++l) {
        if (!query.active.empty() && !query.active[l]) continue;
        if (const auto r = footprintRect(camera, networkBox(map, l, level, adjacency, query.marginMm)))
            voxels.push_back(*r);
        if (!query.edges) continue;
        if (const auto r = edgeReadRect(camera, map.landmarks()[l], marginPx); r && !(*r & frame).empty())
            edges.push_back(*r & frame);
    }
    ViewRegions out;
    out.voxels = mergeOverlapping(voxels);
    out.edges = mergeOverlapping(edges);
    out.bounds = boundsOf(out.voxels, out.edges);
    return out;
}

std::vector<ViewRegions> viewRegions(const InspectionMap& map, const std::vector<geometry::CameraModel>& cameras,
                                     const RegionQuery& query)
{
    std::vector<ViewRegions> out;
    out.reserve(cameras.size());
    for (const geometry::CameraModel& c : cameras) out.push_back(viewRegions(map, c, query));
    return out;
}

} // namespace hg::inspect
