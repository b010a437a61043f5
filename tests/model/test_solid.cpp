// Solid queries against independent expectations: analytic box–box overlap
// volumes, an analytic half-plane cut of a square, a Monte Carlo estimate on
// the exact polyhedron (a plain half-space test written here, not CGAL), the
// divergence-theorem volume of the whole mesh, and hand-computed distances.
#include <cmath>
#include <numbers>
#include <random>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "hullgauge/model/primitives.h"
#include "hullgauge/model/solid.h"

namespace hg::model {
namespace {

using Eigen::AlignedBox3d;
using Eigen::Vector3d;

double overlapVolume(const AlignedBox3d& a, const AlignedBox3d& b)
{
    double v = 1.0;
    for (int i = 0; i < 3; ++i) v *= std::max(0.0, std::min(a.max()[i], b.max()[i]) - std::max(a.min()[i], b.min()[i]));
    return v;
}

AlignedBox3d cubeAt(const Vector3d& lo, double edge)
{
    return {lo, lo + Vector3d::Constant(edge)};
}

TEST(SolidFraction, CubeMeshAgainstAnalyticBoxOverlap)
{
    const AlignedBox3d part(Vector3d(0, 0, 0), Vector3d(10, 8, 6));
    const Solid solid(makeBox(part.min(), part.max()));
    std::mt19937 rng(42);
    std::uniform_real_distribution<double> pos(-2.0, 11.0), size(0.05, 4.0);
    // Random boxes, then boxes snapped to the part's face planes (a voxel
    // grid aligned with a box-shaped part: the degenerate case).
    std::vector<AlignedBox3d> boxes;
    for (int i = 0; i < 300; ++i) {
        Vector3d lo(pos(rng), pos(rng), pos(rng));
        boxes.emplace_back(lo, lo + Vector3d(size(rng), size(rng), size(rng)));
    }
    for (double x : {-1.0, 0.0, 9.0, 10.0})
        for (double y : {-1.0, 0.0, 7.0, 8.0})
            for (double z : {-1.0, 0.0, 5.0, 6.0}) boxes.push_back(cubeAt(Vector3d(x, y, z), 1.0));
    boxes.emplace_back(Vector3d(0, 0, 0), Vector3d(10, 8, 6));    // the part itself
    boxes.emplace_back(Vector3d(-1, -1, -1), Vector3d(11, 9, 7)); // around it
    boxes.emplace_back(Vector3d(2, 2, 2), Vector3d(3, 3, 3));     // well inside
    for (const auto& box : boxes) {
        const double expected = overlapVolume(box, part) / box.volume();
        const InsideFraction f = solid.insideFraction(box);
        EXPECT_NEAR(f.estimate, expected, 1e-12) << box.min().transpose() << " / " << box.max().transpose();
        EXPECT_LE(f.lower, expected + 1e-15);
        EXPECT_GE(f.upper, expected - 1e-15);
        EXPECT_LT(f.upper - f.lower, 1e-9);
    }
}

TEST(SolidFraction, RotatedCubeMatchesSquareCutByADiagonalLine)
{
    // A big box turned 45° about z whose face is the plane x + y = 1 + t0.
    // The unit voxel [0,1]^3 is cut by x + y = t: inside fraction t²/2 for
    // t <= 1 and 1 - (2 - t)²/2 above (area of the square below the line).
    auto fractionBelow = [](double t) { return t <= 1.0 ? t * t / 2.0 : 1.0 - (2.0 - t) * (2.0 - t) / 2.0; };
    for (double t : {0.3, 0.98995, 1.0, 1.01005, 1.7}) {
        TriangleMesh big = makeBox(Vector3d(-40, -20, -20), Vector3d(0, 20, 20)); // face x = 0, solid at x < 0
        const double c = std::sqrt(0.5);
        Eigen::Matrix3d R;
        R << c, -c, 0, c, c, 0, 0, 0, 1;                 // face normal (1,0,0) -> (1,1,0)/√2
        big.transform(R, Vector3d(t / 2.0, t / 2.0, 0)); // plane through (t/2, t/2): x + y = t
        const Solid solid(big);
        const AlignedBox3d voxel(Vector3d(0, 0, 0), Vector3d(1, 1, 1));
        EXPECT_NEAR(solid.insideFraction(voxel).estimate, fractionBelow(t), 1e-12) << "t = " << t;
    }
}

// Exact point-in-polyhedron for a convex closed mesh, independent of CGAL:
// inside every face's half-space.
bool insideConvex(const TriangleMesh& m, const Vector3d& p)
{
    for (std::size_t i = 0; i < m.triangles.size(); ++i) {
        const Vector3d n = m.faceNormal(i);
        if (n.isZero()) continue;
        if (n.dot(p - m.vertices[m.triangles[i][0]]) > 0) return false;
    }
    return true;
}

TEST(SolidFraction, SphereVoxelsAgainstMonteCarloOnThePolyhedron)
{
    const TriangleMesh sphere = makeSphere(Vector3d(0.3, -0.2, 0.1), 4.0, 24, 12);
    const Solid solid(sphere);
    std::mt19937 rng(7);
    const int samples = 20000;
    int boundaryVoxels = 0;
    for (const Vector3d& lo : {Vector3d(3, -1, 0), Vector3d(2, 2, 1), Vector3d(-1, -1, 3.5), Vector3d(-4, 0, 0),
                               Vector3d(1.5, -3.5, -2), Vector3d(-2.5, -2.5, -2.5), Vector3d(0, 0, -4.3)}) {
        const AlignedBox3d voxel = cubeAt(lo, 1.0);
        std::uniform_real_distribution<double> u(0.0, 1.0);
        int in = 0;
        for (int s = 0; s < samples; ++s) in += insideConvex(sphere, lo + Vector3d(u(rng), u(rng), u(rng)));
        const double mc = double(in) / samples;
        const double sigma = std::sqrt(std::max(mc * (1 - mc), 1.0 / samples) / samples);
        const InsideFraction f = solid.insideFraction(voxel);
        EXPECT_NEAR(f.estimate, mc, 5 * sigma + 1e-12) << "voxel at " << lo.transpose();
        boundaryVoxels += mc > 0.02 && mc < 0.98;
    }
    EXPECT_GE(boundaryVoxels, 5); // the test exercises cut voxels, not only empty or full ones
}

TEST(SolidFraction, VoxelGridSumsToTheSphereVolumeWithinTessellationError)
{
    const double r = 5.0;
    const TriangleMesh sphere = makeSphere(Vector3d::Zero(), r, 32, 16);
    const Solid solid(sphere);
    // The inscribed polyhedron lies between the ball of radius r (all
    // vertices on it) and the ball touching its nearest face plane.
    double rIn = r;
    for (std::size_t i = 0; i < sphere.triangles.size(); ++i)
        rIn = std::min(rIn, sphere.faceNormal(i).dot(sphere.vertices[sphere.triangles[i][0]]));
    const double ball = 4.0 / 3.0 * std::numbers::pi; // volume of the unit ball
    double sum = 0.0;
    const double h = 1.25; // 8 x 8 x 8 voxels over [-5, 5]^3; the poles sit on voxel corners
    for (int i = 0; i < 8; ++i)
        for (int j = 0; j < 8; ++j)
            for (int k = 0; k < 8; ++k) {
                const AlignedBox3d voxel = cubeAt(Vector3d(-5 + i * h, -5 + j * h, -5 + k * h), h);
                sum += solid.insideFraction(voxel).estimate * voxel.volume();
            }
    EXPECT_GT(sum, ball * rIn * rIn * rIn);
    EXPECT_LT(sum, ball * r * r * r);
    EXPECT_GT(rIn, 0.99 * r); // the bound is meaningful: within 3 % in volume
    EXPECT_NEAR(sum, sphere.signedVolume(), 1e-9 * sum);
}

TEST(SolidFraction, GridSumsToMeshVolumeForAPrismWithVerticesOnVoxelPlanes)
{
    // An L-shaped prism whose corners all lie on the voxel grid planes.
    const TriangleMesh prism = makePrism({{0, 0}, {4, 0}, {4, 1}, {1, 1}, {1, 3}, {0, 3}}, 0.0, 2.0);
    const Solid solid(prism);
    double sum = 0.0;
    for (int i = -1; i < 5; ++i)
        for (int j = -1; j < 4; ++j)
            for (int k = -1; k < 3; ++k) {
                const AlignedBox3d voxel = cubeAt(Vector3d(i, j, k), 1.0);
                const double f = solid.insideFraction(voxel).estimate;
                EXPECT_NEAR(f, std::round(f), 1e-12); // every cell is wholly in or out
                sum += f;
            }
    EXPECT_NEAR(sum, 12.0, 1e-12); // 4 + 2 cells in the base, times 2 layers
}

TEST(SolidLabels, FiftyPercentRuleAtFortyNineAndFiftyOnePercent)
{
    const Solid solid(makeBox(Vector3d(0, 0, 0), Vector3d(10, 10, 10)));
    // Face plane x = 10 cuts the voxel at 51 % and 49 % inside.
    EXPECT_TRUE(solid.isObjectVoxel(AlignedBox3d(Vector3d(9.49, 2, 2), Vector3d(10.49, 3, 3))));
    EXPECT_FALSE(solid.isObjectVoxel(AlignedBox3d(Vector3d(9.51, 2, 2), Vector3d(10.51, 3, 3))));
    // A tilted plane: the rotated box of RotatedCube..., t = 2 - sqrt(0.98) gives 51 %, sqrt(0.98) 49 %.
    for (auto [t, object] : {std::pair{2.0 - std::sqrt(0.98), true}, std::pair{std::sqrt(0.98), false}}) {
        TriangleMesh big = makeBox(Vector3d(-40, -20, -20), Vector3d(0, 20, 20));
        const double c = std::sqrt(0.5);
        Eigen::Matrix3d R;
        R << c, -c, 0, c, c, 0, 0, 0, 1;
        big.transform(R, Vector3d(t / 2.0, t / 2.0, 0));
        EXPECT_EQ(Solid(big).isObjectVoxel(AlignedBox3d(Vector3d(0, 0, 0), Vector3d(1, 1, 1))), object) << t;
    }
    // Exactly half counts as object ("at least 50 %").
    EXPECT_TRUE(solid.isObjectVoxel(AlignedBox3d(Vector3d(9.5, 2, 2), Vector3d(10.5, 3, 3))));
}

TEST(SolidClassify, InsideOutsideBoundaryAndTouchingBoxes)
{
    const Solid solid(makeBox(Vector3d(0, 0, 0), Vector3d(10, 10, 10)));
    EXPECT_EQ(solid.classify(cubeAt(Vector3d(2, 2, 2), 1)), Occupancy::Inside);
    EXPECT_EQ(solid.classify(cubeAt(Vector3d(12, 2, 2), 1)), Occupancy::Outside);
    EXPECT_EQ(solid.classify(cubeAt(Vector3d(9.5, 2, 2), 1)), Occupancy::Boundary);
    // Sharing a face plane with the part: the open box misses the surface.
    EXPECT_EQ(solid.classify(cubeAt(Vector3d(10, 2, 2), 1)), Occupancy::Outside);
    EXPECT_EQ(solid.classify(cubeAt(Vector3d(9, 2, 2), 1)), Occupancy::Inside);
    EXPECT_EQ(solid.classify(cubeAt(Vector3d(9, 9, 9), 1)), Occupancy::Inside);     // in the corner
    EXPECT_EQ(solid.classify(cubeAt(Vector3d(10, 10, 10), 1)), Occupancy::Outside); // touches a corner
    // A box containing the whole part: boundary.
    EXPECT_EQ(solid.classify(AlignedBox3d(Vector3d(-1, -1, -1), Vector3d(11, 11, 11))), Occupancy::Boundary);
    // A thin plate crossing one edge only (no vertex of the part inside).
    EXPECT_EQ(solid.classify(AlignedBox3d(Vector3d(9.9, 9.9, 4), Vector3d(10.1, 10.1, 5))), Occupancy::Boundary);
}

TEST(SolidQueries, ClosestPointOnABoxByHand)
{
    const Solid solid(makeBox(Vector3d(0, 0, 0), Vector3d(10, 10, 10)));
    SurfacePoint s = solid.closestPoint(Vector3d(15, 5, 5));
    EXPECT_TRUE(s.point.isApprox(Vector3d(10, 5, 5), 1e-12));
    EXPECT_NEAR(s.distance, 5.0, 1e-12);
    EXPECT_TRUE(s.normal.isApprox(Vector3d(1, 0, 0), 1e-12));
    s = solid.closestPoint(Vector3d(12, 13, 5)); // nearest to the edge x = y = 10
    EXPECT_TRUE(s.point.isApprox(Vector3d(10, 10, 5), 1e-12));
    EXPECT_NEAR(s.distance, std::sqrt(13.0), 1e-12);
    s = solid.closestPoint(Vector3d(5, 5, 9)); // from inside: the top face
    EXPECT_TRUE(s.point.isApprox(Vector3d(5, 5, 10), 1e-12));
    EXPECT_NEAR(s.distance, 1.0, 1e-12);
    EXPECT_TRUE(s.normal.isApprox(Vector3d(0, 0, 1), 1e-12));

    EXPECT_TRUE(solid.surfaceNormal(Vector3d(10, 5, 5), 0.01).isApprox(Vector3d(1, 0, 0), 1e-12));
    EXPECT_TRUE(solid.surfaceNormal(Vector3d(10, 10, 5), 0.01).isApprox(Vector3d(1, 1, 0).normalized(), 1e-12));
    EXPECT_TRUE(solid.surfaceNormal(Vector3d(10, 10, 10), 0.01).isApprox(Vector3d(1, 1, 1).normalized(), 1e-12));
}

TEST(SolidQueries, RayAndSegmentHitsOnABoxByHand)
{
    const Solid solid(makeBox(Vector3d(0, 0, 0), Vector3d(10, 10, 10)));
    auto hit = solid.firstHit(Vector3d(-5, 5, 5), Vector3d(2, 0, 0)); // direction need not be unit
    ASSERT_TRUE(hit);
    EXPECT_NEAR(hit->distance, 5.0, 1e-12);
    EXPECT_TRUE(hit->point.isApprox(Vector3d(0, 5, 5), 1e-12));
    EXPECT_TRUE(solid.mesh().faceNormal(hit->triangle).isApprox(Vector3d(-1, 0, 0), 1e-12));
    hit = solid.firstHit(Vector3d(5, 5, 5), Vector3d(0, 0, 1)); // from inside
    ASSERT_TRUE(hit);
    EXPECT_NEAR(hit->distance, 5.0, 1e-12);
    hit = solid.firstHit(Vector3d(0, 5, 5), Vector3d(1, 0, 0)); // starting on the surface: s = 0 does not count
    ASSERT_TRUE(hit);
    EXPECT_NEAR(hit->distance, 10.0, 1e-12);
    EXPECT_FALSE(solid.firstHit(Vector3d(0, 5, 5), Vector3d(-1, 0, 0)));
    EXPECT_FALSE(solid.firstHit(Vector3d(-5, 5, 5), Vector3d(0, 1, 0)));
    hit = solid.firstHit(Vector3d(-5, -5, 3), Vector3d(1, 1, 0)); // onto the edge x = y = 0
    ASSERT_TRUE(hit);
    EXPECT_NEAR(hit->distance, 5.0 * std::sqrt(2.0), 1e-12);

    EXPECT_TRUE(solid.segmentHits(Vector3d(-1, 5, 5), Vector3d(11, 5, 5)));
    EXPECT_TRUE(solid.segmentHits(Vector3d(-1, 5, 5), Vector3d(5, 5, 5)));
    EXPECT_FALSE(solid.segmentHits(Vector3d(-1, 5, 5), Vector3d(-1, 6, 12)));
    EXPECT_FALSE(solid.segmentHits(Vector3d(0, 5, 5), Vector3d(-5, 7, 5)));   // leaves a landmark on the surface
    EXPECT_TRUE(solid.segmentHits(Vector3d(-1, 5, 10), Vector3d(11, 5, 10))); // grazes along the top face

    EXPECT_TRUE(solid.contains(Vector3d(5, 5, 5)));
    EXPECT_TRUE(solid.contains(Vector3d(10, 5, 5))); // on the surface
    EXPECT_FALSE(solid.contains(Vector3d(10.001, 5, 5)));
}

TEST(SolidQueries, ConcurrentConstQueriesAgree)
{
    const Solid solid(makeSphere(Vector3d::Zero(), 3.0, 32, 16));
    std::vector<AlignedBox3d> voxels;
    for (int i = 0; i < 200; ++i) voxels.push_back(cubeAt(Vector3d(-3.5 + 0.035 * i, -0.4, 0.1 * (i % 30) - 1.5), 0.5));
    std::vector<double> serial;
    for (const auto& v : voxels) serial.push_back(solid.insideFraction(v).estimate);
    std::vector<double> a(voxels.size()), b(voxels.size());
    std::thread ta([&] {
        for (std::size_t i = 0; i < voxels.size(); ++i) a[i] = solid.insideFraction(voxels[i]).estimate;
    });
    std::thread tb([&] {
        for (std::size_t i = voxels.size(); i-- > 0;) {
            b[i] = solid.insideFraction(voxels[i]).estimate;
            (void)solid.closestPoint(voxels[i].center());
        }
    });
    ta.join();
    tb.join();
    EXPECT_EQ(a, serial);
    EXPECT_EQ(b, serial);
}

} // namespace
} // namespace hg::model
