// Seeded defects against hand-computed geometry: the volume a defect adds or
// removes is its box's share (2w)²·d on a face, w·d² … on an edge, and the
// surface along the landmark's normal line lies exactly at ±depth.
#include "hullgauge/commission/defects.h"
#include "hullgauge/model/csg.h"
#include "hullgauge/model/primitives.h"
#include "hullgauge/model/solid.h"

#include <cmath>
#include <gtest/gtest.h>

namespace hg::commission {
namespace {

using Eigen::Vector3d;

const model::TriangleMesh kCube = model::makeBox(Vector3d(0, 0, 0), Vector3d(20, 20, 20));

/// Where the surface crosses the line landmark + s·normal: the first hit
/// from far outside along −normal, as a signed s.
double surfaceAlongNormal(const model::TriangleMesh& mesh, const Vector3d& landmark, const Vector3d& normal)
{
    const model::Solid solid(mesh);
    const Vector3d from = landmark + 5.0 * normal;
    const auto hit = solid.firstHit(from, -normal);
    EXPECT_TRUE(hit.has_value());
    return hit ? 5.0 - (hit->point - from).norm() : std::nan("");
}

TEST(SeededDefect, MaterialRemovedFromAFaceIsAFlatPocketOfTheBoxsVolume)
{
    const Vector3d p(10, 7, 20), n(0, 0, 1);
    const SeededDefect d{DefectKind::Removed, 0.2};
    const model::TriangleMesh m = seedDefect(kCube, p, n, d, 0.5);
    EXPECT_NEAR(kCube.signedVolume() - m.signedVolume(), 1.0 * 1.0 * 0.2, 1e-9);
    EXPECT_NEAR(surfaceAlongNormal(m, p, n), -0.2, 1e-9);
    EXPECT_DOUBLE_EQ(d.trueDeviationMm(), -0.2);
}

TEST(SeededDefect, MaterialRemovedAlongALineOfSightIsAGrooveAcrossThePart)
{
    // Seen along x, the face z = 20 is cut low along the whole 20 mm of the
    // cube: a groove 1 mm wide (±w across the line of sight) and 0.2 mm deep.
    const Vector3d p(10, 7, 20), n(0, 0, 1);
    const SeededDefect d{DefectKind::Removed, 0.2};
    const Vector3d sight =
        Vector3d(1, 0, -0.1).normalized(); // slightly down onto the face: only its tangent part counts
    const model::TriangleMesh m = seedDefect(kCube, p, n, d, 0.5, {sight});
    EXPECT_NEAR(kCube.signedVolume() - m.signedVolume(), 20.0 * 1.0 * 0.2, 1e-9);
    EXPECT_NEAR(surfaceAlongNormal(m, p, n), -0.2, 1e-9);
    // Two lines of sight, along x and along y: a cross, the square where they meet counted once.
    const model::TriangleMesh cross = seedDefect(kCube, p, n, d, 0.5, {Vector3d::UnitX(), Vector3d::UnitY()});
    EXPECT_NEAR(kCube.signedVolume() - cross.signedVolume(), (20.0 + 20.0 - 1.0) * 1.0 * 0.2, 1e-9);
}

TEST(SeededDefect, MaterialAddedOnAFaceIsABumpOfTheBoxsVolume)
{
    const Vector3d p(3, 20, 11), n(0, 1, 0);
    const SeededDefect d{DefectKind::Added, 0.3};
    const model::TriangleMesh m = seedDefect(kCube, p, n, d, 0.5);
    // Only the part of the box outside the cube adds: (2w)² · depth.
    EXPECT_NEAR(m.signedVolume() - kCube.signedVolume(), 1.0 * 1.0 * 0.3, 1e-9);
    EXPECT_NEAR(surfaceAlongNormal(m, p, n), 0.3, 1e-9);
    EXPECT_DOUBLE_EQ(d.trueDeviationMm(), 0.3);
}

TEST(SeededDefect, MaterialRemovedAcrossAnEdgeCutsAChamferAtTheDepthAlongTheBisector)
{
    // The edge x = 20, y = 20; bisector normal (1, 1, 0)/√2. A plane at
    // depth d along it cuts a right isosceles prism of legs d·√2, area d²,
    // along the box's 2w of edge.
    const Vector3d p(20, 20, 10), n = Vector3d(1, 1, 0).normalized();
    const double depth = 0.25, w = 0.5;
    const model::TriangleMesh m = seedDefect(kCube, p, n, {DefectKind::Removed, depth}, w);
    EXPECT_NEAR(kCube.signedVolume() - m.signedVolume(), depth * depth * 2.0 * w, 1e-9);
    EXPECT_NEAR(surfaceAlongNormal(m, p, n), -depth, 1e-9);
}

TEST(SeededDefect, MaterialRemovedInABoreWidensItWithoutReachingTheFarWall)
{
    // A block with a square through-hole [8, 12]² along z; a landmark on the
    // hole's wall x = 8, its normal out of the material into the hole (+x).
    const model::TriangleMesh block = model::difference(model::makeBox(Vector3d(0, 0, 0), Vector3d(20, 20, 10)),
                                                        model::makeBox(Vector3d(8, 8, -1), Vector3d(12, 12, 11)));
    const Vector3d p(8, 10, 5), n(1, 0, 0);
    const SeededDefect d{DefectKind::Removed, 0.1};
    const model::TriangleMesh m = seedDefect(block, p, n, d, 0.5);
    // Only the pocket in the wall: the box reaches max(w, 2·depth) = 0.5 mm
    // into the hole, far from the wall opposite at x = 12.
    EXPECT_NEAR(block.signedVolume() - m.signedVolume(), 1.0 * 1.0 * 0.1, 1e-9);
    const model::TriangleMesh b = defectBox(p, n, d, 0.5);
    EXPECT_NEAR(b.bounds().min().x(), 7.9, 1e-12);
    EXPECT_NEAR(b.bounds().max().x(), 8.5, 1e-12);
}

} // namespace
} // namespace hg::commission
