// What the Parts page draws (docs/workbench.md): the display meshes, the
// planned views as cameras in the part frame, and a view's frame as the twin
// renders it with the landmarks it observes.
//
// Pure computation on values; units are millimetres in the part frame and
// pixels in the image (docs/contracts.md, geometry/camera.h).
#pragma once

#include "hullgauge/geometry/station.h"
#include "hullgauge/model/mesh.h"

#include <Eigen/Core>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core/mat.hpp>

namespace hg::workbench {

/// `mesh` simplified by edge collapse (CGAL's Surface_mesh_simplification,
/// Lindstrom–Turk cost and placement) to at most `maxTriangles`; the mesh
/// itself when it has no more. The result of a closed mesh is closed.
/// FaultError when the simplification cannot get below the limit.
model::TriangleMesh simplifiedMesh(const model::TriangleMesh& mesh, std::size_t maxTriangles);

/// A view's camera as the page draws its frustum (docs/workbench.md, "Views
/// and the twin's frame"): `{centre, rotation (camera→part, rows), fx, fy,
/// cx, cy, width, height, working_distance_mm}`, the working distance the
/// depth of `target` (the part's bounding-box centre) along the optical axis.
nlohmann::json cameraJson(const geometry::CameraModel& camera, const Eigen::Vector3d& target);

/// A landmark as a view draws it.
struct ViewLandmark {
    std::string id;
    Eigen::Vector3d position = Eigen::Vector3d::Zero();
    Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
};

/// What the view shows of one landmark.
struct DrawnLandmark {
    std::string id;
    std::optional<Eigen::Vector2d> projection;      ///< none behind the camera
    std::optional<Eigen::Vector2d> silhouettePoint; ///< the outline's point nearest the projection
    double offPx = 0.0;                             ///< projection to silhouette point
    bool offOutline = false;                        ///< offPx > kOffOutlinePx (drawn in orange)
};

/// A landmark whose silhouette point lies farther than this from its
/// projection is drawn in orange: the view sees it off its outline.
inline constexpr double kOffOutlinePx = 3.0;

/// The twin's frame (commission::twinRenderOptions of the station's image
/// quality, noise seeded by `seed`) of `mesh` seated as drawn, seen through
/// `camera`, as a colour image with every landmark of `landmarks` drawn: its
/// projection (a circle), its silhouette point (a cross) and the line
/// between, its normal projected into the image as an arrow, its id; green,
/// orange when off the outline. `drawn` receives what was drawn.
cv::Mat annotatedView(const model::TriangleMesh& mesh, const geometry::Station& station,
                      const geometry::CameraModel& camera, const std::vector<ViewLandmark>& landmarks,
                      std::uint64_t seed, std::vector<DrawnLandmark>* drawn = nullptr);

} // namespace hg::workbench
