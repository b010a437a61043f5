// The display meshes and the views the Parts page draws (display.h). CGAL
// stays in this translation unit.
#include "hullgauge/workbench/display.h"

#include "hullgauge/commission/twin.h"
#include "hullgauge/common/error.h"
#include "hullgauge/geometry/json.h"
#include "hullgauge/sim/renderer.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/Count_stop_predicate.h>
#include <CGAL/Surface_mesh_simplification/edge_collapse.h>

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <limits>

namespace hg::workbench {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using SurfaceMesh = CGAL::Surface_mesh<Kernel::Point_3>;
namespace SMS = CGAL::Surface_mesh_simplification;

SurfaceMesh toSurfaceMesh(const model::TriangleMesh& mesh)
{
    SurfaceMesh m;
    for (const auto& v : mesh.vertices) m.add_vertex(Kernel::Point_3(v.x(), v.y(), v.z()));
    for (const auto& t : mesh.triangles) {
        const auto f = m.add_face(SurfaceMesh::Vertex_index(static_cast<SurfaceMesh::size_type>(t[0])),
                                  SurfaceMesh::Vertex_index(static_cast<SurfaceMesh::size_type>(t[1])),
                                  SurfaceMesh::Vertex_index(static_cast<SurfaceMesh::size_type>(t[2])));
        if (f == SurfaceMesh::null_face())
            throw FaultError("display mesh: the part's mesh is not a 2-manifold CGAL's surface mesh takes");
    }
    return m;
}

model::TriangleMesh fromSurfaceMesh(const SurfaceMesh& m)
{
    model::TriangleMesh out;
    std::vector<int> index(m.number_of_vertices() + m.number_of_removed_vertices(), -1);
    for (auto v : m.vertices()) {
        index[v] = static_cast<int>(out.vertices.size());
        const auto& p = m.point(v);
        out.vertices.emplace_back(p.x(), p.y(), p.z());
    }
    for (auto f : m.faces()) {
        const auto h = m.halfedge(f);
        out.triangles.push_back({index[m.source(h)], index[m.target(h)], index[m.target(m.next(h))]});
    }
    return out;
}

const cv::Scalar kOnOutline(60, 200, 60);  // BGR: green
const cv::Scalar kOffOutline(0, 140, 255); // BGR: orange

/// The outline of the rendered silhouette: the boundary pixels of the
/// coverage thresholded at one half (pixel centres, the camera's convention).
std::vector<Eigen::Vector2d> outlinePoints(const cv::Mat& coverage)
{
    cv::Mat mask;
    cv::compare(coverage, 0.5, mask, cv::CMP_GE);
    std::vector<std::vector<cv::Point>> contours;
    cv::findContours(mask, contours, cv::RETR_LIST, cv::CHAIN_APPROX_NONE);
    std::vector<Eigen::Vector2d> points;
    for (const auto& c : contours)
        for (const cv::Point& p : c) points.emplace_back(p.x, p.y);
    return points;
}

DrawnLandmark locate(const ViewLandmark& l, const geometry::CameraModel& camera,
                     const std::vector<Eigen::Vector2d>& outline)
{
    DrawnLandmark d;
    d.id = l.id;
    d.projection = camera.project(l.position);
    if (!d.projection || outline.empty()) return d;
    double best = std::numeric_limits<double>::infinity();
    for (const Eigen::Vector2d& p : outline) {
        const double dist = (p - *d.projection).norm();
        if (dist < best) {
            best = dist;
            d.silhouettePoint = p;
        }
    }
    d.offPx = best;
    d.offOutline = best > kOffOutlinePx;
    return d;
}

cv::Point pixel(const Eigen::Vector2d& p)
{
    return {static_cast<int>(std::lround(p.x())), static_cast<int>(std::lround(p.y()))};
}

void draw(cv::Mat& image, const ViewLandmark& l, const DrawnLandmark& d, const geometry::CameraModel& camera)
{
    if (!d.projection) return;
    const cv::Scalar colour = d.offOutline ? kOffOutline : kOnOutline;
    const cv::Point at = pixel(*d.projection);
    cv::circle(image, at, 5, colour, 2, cv::LINE_AA);
    if (d.silhouettePoint) {
        const cv::Point s = pixel(*d.silhouettePoint);
        cv::drawMarker(image, s, colour, cv::MARKER_CROSS, 10, 2, cv::LINE_AA);
        cv::line(image, at, s, colour, 1, cv::LINE_AA);
    }
    // The measuring direction: the normal projected into the image, 40 px long.
    if (const auto tip = camera.project(l.position + l.normal); tip) {
        const Eigen::Vector2d dir = *tip - *d.projection;
        if (dir.norm() > 1e-6)
            cv::arrowedLine(image, at, pixel(*d.projection + 40.0 * dir.normalized()), colour, 2, cv::LINE_AA, 0, 0.25);
    }
    cv::putText(image, l.id, at + cv::Point(8, -8), cv::FONT_HERSHEY_SIMPLEX, 0.5, colour, 1, cv::LINE_AA);
}

} // namespace

model::TriangleMesh simplifiedMesh(const model::TriangleMesh& mesh, std::size_t maxTriangles)
{
    if (mesh.triangles.size() <= maxTriangles) return mesh;
    SurfaceMesh m = toSurfaceMesh(mesh);
    // A closed triangle mesh has 3/2 edges per face: at most 3/2 · max edges
    // is at most max faces. The predicate stops below its threshold.
    const std::size_t edges = maxTriangles * 3 / 2;
    SMS::Count_stop_predicate<SurfaceMesh> stop(edges + 1);
    SMS::edge_collapse(m, stop);
    m.collect_garbage();
    model::TriangleMesh out = fromSurfaceMesh(m);
    if (out.triangles.size() > maxTriangles)
        throw FaultError("display mesh: edge collapse left " + std::to_string(out.triangles.size()) +
                         " triangles, more than the " + std::to_string(maxTriangles) + " of the simplified mesh");
    return out;
}

nlohmann::json cameraJson(const geometry::CameraModel& camera, const Eigen::Vector3d& target)
{
    const geometry::RigidTransform& T = camera.cameraFromPart();
    const geometry::Mat3& K = camera.intrinsics().K;
    // A telecentric camera has no centre: where its optical axis leaves the
    // lens's front stands for it (docs/workbench.md).
    return {{"projection", camera.isTelecentric() ? "telecentric" : "pinhole"},
            {"centre", geometry::toJson(camera.sightOrigin(T.inverse().t))},
            {"rotation", geometry::toJson(geometry::Mat3(T.R.transpose()))},
            {"fx", K(0, 0)},
            {"fy", K(1, 1)},
            {"cx", K(0, 2)},
            {"cy", K(1, 2)},
            {"width", camera.imageSize().width},
            {"height", camera.imageSize().height},
            // The target's depth along the axis from that centre: for a telecentric camera, from its lens's front.
            {"working_distance_mm", camera.isTelecentric() ? camera.rangeTo(target) : camera.depthOf(target)}};
}

cv::Mat annotatedView(const model::TriangleMesh& mesh, const geometry::Station& station,
                      const geometry::CameraModel& camera, const std::vector<ViewLandmark>& landmarks,
                      std::uint64_t seed, std::vector<DrawnLandmark>* drawn)
{
    const sim::RenderOptions options = commission::twinRenderOptions(station.imageQuality, seed);
    const sim::SilhouetteRenderer renderer({mesh});
    const cv::Mat coverage = renderer.coverage(camera, options);
    const cv::Mat grey = sim::shadeCoverage(coverage, options);
    cv::Mat image;
    cv::cvtColor(grey, image, cv::COLOR_GRAY2BGR);
    const std::vector<Eigen::Vector2d> outline = outlinePoints(coverage);
    if (drawn) drawn->clear();
    for (const ViewLandmark& l : landmarks) {
        const DrawnLandmark d = locate(l, camera, outline);
        draw(image, l, d, camera);
        if (drawn) drawn->push_back(d);
    }
    return image;
}

} // namespace hg::workbench
