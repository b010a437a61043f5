// What the Parts page draws (display.h) and where a placed point lands
// (placement.h), on analytic shapes: a box's sharp edges and corners counted
// by hand, a UV sphere of 39 600 triangles simplified under 25 000 and still
// closed, a view's camera as the station poses it, and the twin's frame of a
// box seen from its side, where a landmark on the near top edge lies on the
// outline and one in the middle of the face towards the camera lies far
// inside it (off the outline: orange).
#include "hgtest/station.h"
#include "hullgauge/model/mesh_io.h"
#include "hullgauge/workbench/display.h"
#include "hullgauge/workbench/placement.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace hg::workbench {
namespace {

model::TriangleMesh box(double x, double y, double z)
{
    model::TriangleMesh m;
    m.vertices = {{0, 0, 0}, {x, 0, 0}, {x, y, 0}, {0, y, 0}, {0, 0, z}, {x, 0, z}, {x, y, z}, {0, y, z}};
    const int quads[6][4] = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4}, {2, 3, 7, 6}, {1, 2, 6, 5}, {3, 0, 4, 7}};
    for (const auto& q : quads) {
        m.triangles.push_back({q[0], q[1], q[2]});
        m.triangles.push_back({q[0], q[2], q[3]});
    }
    return m;
}

/// A UV sphere of radius r: `slices` round, `stacks` from pole to pole.
model::TriangleMesh sphere(double r, int slices, int stacks)
{
    model::TriangleMesh m;
    m.vertices.emplace_back(0, 0, r);
    for (int i = 1; i < stacks; ++i) {
        const double theta = std::numbers::pi * i / stacks;
        for (int j = 0; j < slices; ++j) {
            const double phi = 2 * std::numbers::pi * j / slices;
            m.vertices.emplace_back(r * std::sin(theta) * std::cos(phi), r * std::sin(theta) * std::sin(phi),
                                    r * std::cos(theta));
        }
    }
    m.vertices.emplace_back(0, 0, -r);
    const int south = static_cast<int>(m.vertices.size()) - 1;
    const auto at = [&](int ring, int j) { return 1 + ring * slices + (j % slices); };
    for (int j = 0; j < slices; ++j) m.triangles.push_back({0, at(0, j), at(0, j + 1)});
    for (int ring = 0; ring + 1 < stacks - 1; ++ring)
        for (int j = 0; j < slices; ++j) {
            m.triangles.push_back({at(ring, j), at(ring + 1, j), at(ring + 1, j + 1)});
            m.triangles.push_back({at(ring, j), at(ring + 1, j + 1), at(ring, j + 1)});
        }
    for (int j = 0; j < slices; ++j) m.triangles.push_back({south, at(stacks - 2, j + 1), at(stacks - 2, j)});
    return m;
}

TEST(Placement, ABoxHasTwelveSharpEdgesAndEightCorners)
{
    const SharpFeatures f = sharpFeatures(box(40, 30, 20));
    EXPECT_EQ(f.edges.size(), 12u);
    EXPECT_EQ(f.corners.size(), 8u);
    EXPECT_NEAR(snapDistanceMm(box(40, 30, 20).bounds()), 0.02 * std::sqrt(40.0 * 40 + 30 * 30 + 20 * 20), 1e-12);
    const Snapped onEdge = snapToFeature({20, 1, 20}, f, 1.077);
    EXPECT_EQ(onEdge.on, Placement::Edge);
    EXPECT_EQ(onEdge.position, Eigen::Vector3d(20, 0, 20));
    EXPECT_EQ(snapToFeature({20, 15, 20}, f, 1.077).on, Placement::Face);
    EXPECT_EQ(classify({40, 30, 0}, f, 1e-6), Placement::Corner);
    EXPECT_EQ(classify({40, 15, 0}, f, 1e-6), Placement::Edge);
    EXPECT_EQ(classify({39, 15, 0}, f, 1e-6), Placement::Face);
}

TEST(Placement, ASmoothSphereHasNoSharpEdge)
{
    const SharpFeatures f = sharpFeatures(sphere(10, 64, 32));
    EXPECT_TRUE(f.edges.empty());
    EXPECT_TRUE(f.corners.empty());
}

TEST(DisplayMesh, AFineSphereIsSimplifiedToAtMost25000TrianglesAndStaysClosed)
{
    const model::TriangleMesh fine = sphere(20, 200, 100);
    ASSERT_EQ(fine.triangles.size(), 39600u);
    ASSERT_TRUE(model::checkMesh(fine).ok());
    const model::TriangleMesh lod = simplifiedMesh(fine, 25000);
    EXPECT_LE(lod.triangles.size(), 25000u);
    EXPECT_GT(lod.triangles.size(), 24000u);
    const model::MeshCheck check = model::checkMesh(lod);
    EXPECT_TRUE(check.ok()) << check.problem();
    // Still the sphere: its volume within 1 % of the fine mesh's.
    EXPECT_NEAR(lod.signedVolume() / fine.signedVolume(), 1.0, 0.01);
    // A mesh within the limit is itself.
    EXPECT_EQ(simplifiedMesh(box(1, 2, 3), 25000).triangles.size(), 12u);
}

// A telecentric camera (docs/telecentric.md) has no centre: the page draws
// its box of parallel lines of sight from where the axis leaves the lens.
TEST(DisplayViews, ATelecentricCameraIsDrawnFromItsLensFront)
{
    geometry::Station station =
        hgtest::station({.cameraKeys = "  model: telecentric\n  working_distance_mm: 110\n", .distanceMm = 0});
    const geometry::CameraModel camera = station.cameraAt({0.0, 0.0, 0.0});
    // X_cam = (x, -z, y): the axis is the part's y axis, the focus plane y = 0, the lens's front y = -110.
    const nlohmann::json j = cameraJson(camera, {1, 4, 2});
    EXPECT_EQ(j["projection"], "telecentric");
    EXPECT_NEAR(j["centre"][0].get<double>(), 0.0, 1e-12);
    EXPECT_NEAR(j["centre"][1].get<double>(), -110.0, 1e-12);
    EXPECT_NEAR(j["centre"][2].get<double>(), 0.0, 1e-12);
    EXPECT_NEAR(j["working_distance_mm"].get<double>(), 114.0, 1e-12);
}

TEST(DisplayViews, TheCameraIsTheStationsAtThePoseInThePartFrame)
{
    const geometry::Station station = hgtest::station();
    const geometry::CameraModel camera = station.cameraAt({0.0, 0.0, 0.0});
    const nlohmann::json j = cameraJson(camera, {0, 0, 0});
    // The tests' station: 300 mm on the part's -y side, f = 800 px, 640 × 480.
    EXPECT_NEAR(j["centre"][1].get<double>(), -300.0, 1e-9);
    EXPECT_NEAR(j["working_distance_mm"].get<double>(), 300.0, 1e-9);
    EXPECT_EQ(j["fx"].get<double>(), 800.0);
    EXPECT_EQ(j["width"].get<int>(), 640);
    // The optical axis (the camera's z, third column of camera→part) points along +y.
    EXPECT_NEAR(j["rotation"][1][2].get<double>(), 1.0, 1e-12);
}

TEST(DisplayViews, ALandmarkOnTheOutlineIsOnItAndOneInsideTheSilhouetteIsOff)
{
    const geometry::Station station = hgtest::station();
    const geometry::CameraModel camera = station.cameraAt({0.0, 0.0, 0.0});
    const std::vector<ViewLandmark> landmarks{{"edge", {20, 0, 20}, Eigen::Vector3d(0, -1, 1).normalized()},
                                              {"face", {20, 0, 10}, {0, -1, 0}}};
    std::vector<DrawnLandmark> drawn;
    const cv::Mat image = annotatedView(box(40, 30, 20), station, camera, landmarks, 1, &drawn);
    EXPECT_EQ(image.type(), CV_8UC3);
    EXPECT_EQ(image.cols, 640);
    ASSERT_EQ(drawn.size(), 2u);
    EXPECT_LE(drawn[0].offPx, 1.0);
    EXPECT_FALSE(drawn[0].offOutline);
    // The face's middle is 10 mm below the top edge: 10 · 800 / 300 = 26.7 px from the outline.
    EXPECT_NEAR(drawn[1].offPx, 10.0 * 800.0 / 300.0, 1.0);
    EXPECT_TRUE(drawn[1].offOutline);
}

} // namespace
} // namespace hg::workbench
