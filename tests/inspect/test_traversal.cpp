// Goal-driven traversal and error measures on a fake voxel oracle: the true
// part is the half-space z <= 10 + e, whose exact voxel labels are known (a
// cube voxel is >= 50 % inside exactly when its centre is), so error numbers
// and boundary brackets can be counted by hand.
#include <gtest/gtest.h>

#include <cmath>

#include "hullgauge/inspect/inspector.h"

using namespace hg::inspect;

namespace {

MapGeometry geometry32()
{
    MapGeometry g;
    g.cubeSize = 32.0;
    g.depth = 5; // ΔV = 1 mm
    g.adjacencyDepth = 3;
    g.coarsestLevel = 3;
    return g;
}

InspectionMap faceMap(double tolerance = 0.6)
{
    return InspectionMap::build("face", geometry32(),
                                {{"a", Eigen::Vector3d(16.3, 16.7, 10.0), Eigen::Vector3d::UnitZ(), tolerance}}, {},
                                [](const Box3& b) { return b.center().z() <= 10.0; });
}

/// The true part: z <= 10 + e, labelled exactly; counts the calls.
struct ShiftedFace {
    double e;
    int* calls;
    VoxelLabel operator()(const Box3& b) const
    {
        ++*calls;
        return b.center().z() <= 10.0 + e ? VoxelLabel::Object : VoxelLabel::Void;
    }
};

} // namespace

TEST(Traversal, NominalFaceHasNoErrorAndHalfVoxelBracket)
{
    const auto map = faceMap();
    int calls = 0;
    const auto r = Inspector(map).inspectWith(ShiftedFace{0.0, &calls});
    ASSERT_EQ(r.landmarks.size(), 1u);
    const LandmarkResult& l = r.landmarks[0];
    EXPECT_EQ(l.status, LandmarkStatus::Ok);
    EXPECT_EQ(l.errorNumber, 0);
    // Voxel centres at z = 9.5 (object) and 10.5 (void) bracket the face.
    EXPECT_DOUBLE_EQ(l.offsetLowMm, -0.5);
    EXPECT_DOUBLE_EQ(l.offsetHighMm, 0.5);
    EXPECT_DOUBLE_EQ(l.errorMinMm, 0.0);
    EXPECT_DOUBLE_EQ(l.errorMaxMm, 0.5);
    EXPECT_DOUBLE_EQ(l.errorMm, 0.25);
    EXPECT_TRUE(r.pass);
    // Landmark voxel (z index 9, just inside the face) + its 26 neighbours (all
    // correct: recursion stops) + the normal line's voxels beyond the first
    // layer (z index 6, 7 and 11, 12).
    EXPECT_EQ(calls, 27 + 4);
    EXPECT_EQ(r.voxelsReconstructed, 31u);
}

TEST(Traversal, RaisedFaceCountsWrongLayerAndBracketsOffset)
{
    const auto map = faceMap();
    int calls = 0;
    const auto r = Inspector(map).inspectWith(ShiftedFace{1.3, &calls});
    const LandmarkResult& l = r.landmarks[0];
    // The layer of voxels with centres at z = 10.5 is object but should be void:
    // 7 x 7 of them within the three adjacency layers.
    EXPECT_EQ(l.errorNumber, 49);
    EXPECT_DOUBLE_EQ(l.offsetLowMm, 0.5);
    EXPECT_DOUBLE_EQ(l.offsetHighMm, 1.5);
    EXPECT_DOUBLE_EQ(l.errorMinMm, 0.5);
    EXPECT_DOUBLE_EQ(l.errorMaxMm, 1.5);
    EXPECT_DOUBLE_EQ(l.errorMm, 1.0);
    EXPECT_LE(l.errorMinMm - 1.0, 1.3);
    EXPECT_GE(l.errorMaxMm + 1.0, 1.3);
    EXPECT_EQ(l.status, LandmarkStatus::OutOfTolerance);
    EXPECT_FALSE(r.pass);
    EXPECT_DOUBLE_EQ(r.statistics.totalVolumeError, 49.0);
}

TEST(Traversal, LoweredFaceIsFoundByNeighbourSearch)
{
    const auto map = faceMap(3.0);
    int calls = 0;
    const auto r = Inspector(map).inspectWith(ShiftedFace{-2.2, &calls});
    const LandmarkResult& l = r.landmarks[0];
    // Object only at z centres 7.5 and below (two layers under the landmark
    // voxel): found by the ring-by-ring search; layers 8.5 and 9.5 are missing
    // material: 2 x 49.
    EXPECT_EQ(l.errorNumber, 98);
    EXPECT_DOUBLE_EQ(l.offsetLowMm, -2.5);
    EXPECT_DOUBLE_EQ(l.offsetHighMm, -1.5);
    EXPECT_DOUBLE_EQ(l.errorMinMm, 1.5);
    EXPECT_DOUBLE_EQ(l.errorMaxMm, 2.5);
    EXPECT_EQ(l.status, LandmarkStatus::Ok); // 2.0 mm mean error within 3 mm
    // Every voxel is reconstructed at most once: the 7^3 network is the limit.
    EXPECT_LE(calls, 343);
}

TEST(Traversal, ErrorsBeyondTheAdjacencyLayersOverflowOrAreNotFound)
{
    const auto map = faceMap(0.6);
    int calls = 0;
    EXPECT_EQ(Inspector(map).inspectWith(ShiftedFace{4.0, &calls}).landmarks[0].status, LandmarkStatus::Overflow);
    EXPECT_EQ(Inspector(map).inspectWith(ShiftedFace{-4.0, &calls}).landmarks[0].status, LandmarkStatus::NotFound);
    // With only one adjacency layer around the landmark voxel (the voxel just
    // inside the face, z in [9, 10]) the normal line's voxel centres lie at
    // z = 8.5, 9.5 and 10.5: a 1.3 mm cut is still measured, a 0.7 mm raise
    // overflows, and a 1.7 mm cut leaves no object voxel to find.
    InspectionOptions o;
    o.adjacency = 1;
    const LandmarkResult cut = Inspector(map, o).inspectWith(ShiftedFace{-1.3, &calls}).landmarks[0];
    EXPECT_EQ(cut.status, LandmarkStatus::OutOfTolerance);
    EXPECT_DOUBLE_EQ(cut.offsetLowMm, -1.5);
    EXPECT_DOUBLE_EQ(cut.offsetHighMm, -0.5);
    // Every voxel on the line is object: the surface lies above the last
    // centre (0.5 mm); the bracket runs to the line's reach (1.0 mm).
    const LandmarkResult raised = Inspector(map, o).inspectWith(ShiftedFace{0.7, &calls}).landmarks[0];
    EXPECT_EQ(raised.status, LandmarkStatus::Overflow);
    EXPECT_TRUE(raised.overflowHigh);
    EXPECT_DOUBLE_EQ(raised.offsetLowMm, 0.5);
    EXPECT_DOUBLE_EQ(raised.offsetHighMm, 1.0);
    EXPECT_DOUBLE_EQ(raised.errorMinMm, 0.5);
    EXPECT_DOUBLE_EQ(raised.errorMaxMm, 1.0);
    EXPECT_EQ(Inspector(map, o).inspectWith(ShiftedFace{-1.7, &calls}).landmarks[0].status, LandmarkStatus::NotFound);
}

TEST(Traversal, FacesOnTheGridAreReachedAlikeWhicheverWayTheirNormalPoints)
{
    // The same face, part above it (normal -z): the landmark voxel is again
    // the one inside (z in [10, 11]), so the line reaches 1.5 mm into the
    // part and 0.5 mm out of it, as for the +z face.
    const auto map = InspectionMap::build("face", geometry32(),
                                          {{"a", Eigen::Vector3d(16.3, 16.7, 10.0), -Eigen::Vector3d::UnitZ(), 0.6}},
                                          {}, [](const Box3& b) { return b.center().z() >= 10.0; });
    EXPECT_EQ(keyIndex(map.nodes()[map.landmarkNode(0, 5)].key), Eigen::Vector3i(16, 16, 10));
    InspectionOptions o;
    o.adjacency = 1;
    int calls = 0;
    auto above = [&calls](double z0) {
        return [z0, &calls](const Box3& b) {
            ++calls;
            return b.center().z() >= z0 ? VoxelLabel::Object : VoxelLabel::Void;
        };
    };
    const LandmarkResult cut = Inspector(map, o).inspectWith(above(11.3)).landmarks[0];
    EXPECT_EQ(cut.status, LandmarkStatus::OutOfTolerance);
    EXPECT_DOUBLE_EQ(cut.offsetLowMm, -1.5);
    EXPECT_DOUBLE_EQ(cut.offsetHighMm, -0.5);
    EXPECT_EQ(Inspector(map, o).inspectWith(above(9.3)).landmarks[0].status, LandmarkStatus::Overflow);
}

TEST(Traversal, CoarserLevelUsesLargerVoxelsWithoutRebuilding)
{
    const auto map = faceMap(1.5);
    int calls = 0;
    InspectionOptions o;
    o.level = 4; // ΔV = 2 mm
    const auto r = Inspector(map, o).inspectWith(ShiftedFace{1.3, &calls});
    EXPECT_DOUBLE_EQ(r.voxelSizeMm, 2.0);
    const LandmarkResult& l = r.landmarks[0];
    // Level-4 voxel centres at z = 9, 11: 9 <= 11.3 object, 11 <= 11.3 object,
    // 13 void: the surface lies between 1 and 3 mm above the landmark.
    EXPECT_DOUBLE_EQ(l.offsetLowMm, 1.0);
    EXPECT_DOUBLE_EQ(l.offsetHighMm, 3.0);
    EXPECT_EQ(l.status, LandmarkStatus::OutOfTolerance);
    o.level = 2;
    EXPECT_THROW(Inspector(map, o), std::invalid_argument);
}

TEST(Traversal, UndecidedLandmarkIsNotObservableNotPassed)
{
    const auto map = faceMap();
    const auto r = Inspector(map).inspectWith([](const Box3&) { return VoxelLabel::Undecided; });
    EXPECT_EQ(r.landmarks[0].status, LandmarkStatus::NotObservable);
    EXPECT_FALSE(r.pass);
}

TEST(Traversal, EarlyExitStopsAtFirstFailingLandmarkAndMaskSkips)
{
    const auto map = InspectionMap::build("face", geometry32(),
                                          {{"a", Eigen::Vector3d(8.5, 8.5, 10.0), Eigen::Vector3d::UnitZ(), 0.6},
                                           {"b", Eigen::Vector3d(24.5, 24.5, 10.0), Eigen::Vector3d::UnitZ(), 0.6}},
                                          {}, [](const Box3& b) { return b.center().z() <= 10.0; });
    // Raised only where x < 16: landmark a fails, b is fine.
    auto oracle = [](const Box3& b) {
        const double top = b.center().x() < 16.0 ? 11.3 : 10.0;
        return b.center().z() <= top ? VoxelLabel::Object : VoxelLabel::Void;
    };
    InspectionOptions o;
    o.earlyExit = true;
    const auto r = Inspector(map, o).inspectWith(oracle);
    EXPECT_EQ(r.landmarks[0].status, LandmarkStatus::OutOfTolerance);
    EXPECT_EQ(r.landmarks[1].status, LandmarkStatus::NotInspected);
    const auto full = Inspector(map).inspectWith(oracle);
    EXPECT_EQ(full.landmarks[1].status, LandmarkStatus::Ok);
    InspectionOptions m;
    m.maskedLandmarks = {"a"};
    const auto masked = Inspector(map, m).inspectWith(oracle);
    ASSERT_EQ(masked.landmarks.size(), 1u);
    EXPECT_EQ(masked.landmarks[0].id, "b");
    EXPECT_TRUE(masked.pass);
}

TEST(Measures, DistancePerimeterAreaBrackets)
{
    const LandmarkEstimate a{Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(-1, 0, 0), 0.0, 0.5};
    const LandmarkEstimate b{Eigen::Vector3d(10, 0, 0), Eigen::Vector3d(1, 0, 0), 0.0, 0.5};
    const Bracket d = distanceBracket(a, b);
    EXPECT_DOUBLE_EQ(d.min, 10.0);
    EXPECT_DOUBLE_EQ(d.max, 11.0);
    // A diamond of half-diagonals 5 with radial normals, each vertex free by ±1:
    // half-diagonals in [4, 6], area 2ab in [32, 72], edges √(a² + b²).
    std::vector<LandmarkEstimate> ring;
    for (int i = 0; i < 4; ++i) {
        const double ang = i * M_PI / 2;
        const Eigen::Vector3d n(std::cos(ang), std::sin(ang), 0);
        ring.push_back({5.0 * n, n, -1.0, 1.0});
    }
    const Bracket area = areaBracket(ring);
    EXPECT_NEAR(area.min, 32.0, 1e-9);
    EXPECT_NEAR(area.max, 72.0, 1e-9);
    const Bracket per = perimeterBracket(ring);
    EXPECT_NEAR(per.min, 4 * std::sqrt(32.0), 1e-9);
    EXPECT_NEAR(per.max, 4 * std::sqrt(72.0), 1e-9);
    // Crossing segments: the minimum distance is interior (0 where they meet).
    const LandmarkEstimate c{Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 0, 0), -1.0, 1.0};
    const LandmarkEstimate e{Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(0, 1, 0), -1.0, 1.0};
    EXPECT_NEAR(distanceBracket(c, e).min, 0.0, 1e-12);
    EXPECT_NEAR(distanceBracket(c, e).max, std::sqrt(2.0), 1e-12);
}

TEST(Measures, DiscriminationOfAnOnAxisView)
{
    hg::geometry::Intrinsics in;
    in.K << 1000, 0, 320, 0, 1000, 240, 0, 0, 1;
    in.imageSize = {640, 480};
    const hg::geometry::CameraModel cam(in, {Eigen::Matrix3d::Identity(), Eigen::Vector3d(0, 0, 400)});
    const ViewDiscrimination v = viewDiscrimination(cam, Eigen::Vector3d::Zero());
    EXPECT_TRUE(v.observes);
    EXPECT_NEAR(v.distanceMm, 400.0, 1e-12);
    EXPECT_NEAR(v.thetaDeg, 0.0, 1e-9);
    // eq. 4.4.4-19: Δp < 1.5 (f/d) (d ΔV/√2) / (d − ΔV/√2) with Δp = 1 px, f = 1000 px.
    const double dv = v.medRangeMm;
    EXPECT_NEAR(1.5 * (1000.0 / 400.0) * (400.0 * dv / std::sqrt(2.0)) / (400.0 - dv / std::sqrt(2.0)), 1.0, 1e-12);
    // eq. 4.4.5-11 at Θ = 0: Δp < 2 (f/d) (w d) / (d − w), w = ΔV / 2√2.
    const double w = v.medAngleMm / (2 * std::sqrt(2.0));
    EXPECT_NEAR(2 * (1000.0 / 400.0) * (w * 400.0) / (400.0 - w), 1.0, 1e-12);
    EXPECT_FALSE(viewDiscrimination(cam, Eigen::Vector3d(0, 0, -500)).observes);
}
