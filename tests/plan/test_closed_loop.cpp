// Closed loop: plan the views of a part, render the planned views (backlit
// renderer), inspect the renders against the inspection map. The nominal part
// must pass with every landmark observed and ok; a part with material missing
// on one face must fail at that face's landmarks only.
#include "hgtest/parts.h"
#include "hgtest/station.h"
#include "hullgauge/inspect/inspector.h"
#include "hullgauge/model/primitives.h"
#include "hullgauge/plan/planner.h"
#include "hullgauge/sim/renderer.h"

#include <gtest/gtest.h>

namespace hg::plan {
namespace {

using Eigen::Vector3d;

geometry::Station makeStation()
{
    return hgtest::station({.imageSize = {2448, 2048}, .focalPx = 4000});
}

struct Loop {
    geometry::Station station = makeStation();
    model::Solid nominal{model::makeBox(Vector3d(-10, -10, 0), Vector3d(10, 10, 20))};
    std::vector<PlanLandmark> landmarks;
    inspect::MapGeometry mapGeometry;
    ViewPlan plan;

    Loop()
    {
        auto add = [&](std::string id, Vec3 p, Vec3 n) {
            PlanLandmark l;
            l.id = std::move(id);
            l.position = p;
            l.normal = n;
            l.toleranceMm = 0.5;
            landmarks.push_back(l);
        };
        add("top", {1, 2, 20}, {0, 0, 1});
        add("px", {10, 1, 10}, {1, 0, 0});
        add("nx", {-10, -2, 11}, {-1, 0, 0});
        add("py", {3, 10, 9}, {0, 1, 0});
        add("ny", {-1, -10, 12}, {0, -1, 0});
        mapGeometry.cubeOrigin = Vec3(-64, -64, -64);
        mapGeometry.cubeSize = 128;
        mapGeometry.depth = 9; // ΔV = 0.25 mm
        mapGeometry.adjacencyDepth = 4;
        mapGeometry.coarsestLevel = 9;

        PlanProblem problem;
        problem.part = "cube";
        problem.solid = &nominal;
        problem.station = &station;
        problem.frame = mapGeometry.frame();
        problem.landmarks = landmarks;
        plan = planViews(problem);
    }

    inspect::InspectionResult inspect(const model::TriangleMesh& part) const
    {
        const std::vector<inspect::MapLandmark> mls(landmarks.begin(), landmarks.end());
        auto map = inspect::InspectionMap::build(
            "cube", mapGeometry, mls, {}, [&](const Eigen::AlignedBox3d& b) { return nominal.isObjectVoxel(b); });
        sim::SilhouetteRenderer renderer({part});
        std::vector<inspect::CapturedView> views;
        for (const auto& v : plan.views) views.push_back({v.id, v.camera, renderer.render(v.camera)});
        return inspect::Inspector(map).inspect(views, {});
    }
};

TEST(ClosedLoop, NominalPassesDefectFailsAtItsLandmark)
{
    Loop loop;
    ASSERT_TRUE(loop.plan.feasible) << (loop.plan.problems.empty() ? "" : loop.plan.problems[0]);
    ASSERT_FALSE(loop.plan.views.empty());

    const auto nominal = loop.inspect(loop.nominal.mesh());
    EXPECT_TRUE(nominal.pass);
    for (const auto& l : nominal.landmarks)
        EXPECT_EQ(l.status, inspect::LandmarkStatus::Ok) << l.id << ": " << l.reason;

    // 0.75 mm of material missing on the +x face: px sees a 0.75 mm error
    // (> 0.5 mm tolerance); the other faces are untouched.
    const auto defect = loop.inspect(model::makeBox(Vector3d(-10, -10, 0), Vector3d(9.25, 10, 20)));
    EXPECT_FALSE(defect.pass);
    for (const auto& l : defect.landmarks) {
        if (l.id == "px")
            EXPECT_NE(l.status, inspect::LandmarkStatus::Ok);
        else
            EXPECT_EQ(l.status, inspect::LandmarkStatus::Ok) << l.id << ": " << l.reason;
    }
}

// The planner proves void the neighbours of the very voxel the inspection
// map holds as each landmark's type-three node (VoxelFrame::landmarkVoxel):
// on this grid (ΔV = 0.25 mm, faces on voxel faces) the voxel just inside the
// face, whichever way the face's normal points.
TEST(ClosedLoop, PlannerAndMapShareEachLandmarkVoxel)
{
    Loop loop;
    const std::vector<inspect::MapLandmark> mls(loop.landmarks.begin(), loop.landmarks.end());
    const auto map = inspect::InspectionMap::build(
        "cube", loop.mapGeometry, mls, {}, [&](const Eigen::AlignedBox3d& b) { return loop.nominal.isObjectVoxel(b); });
    ASSERT_EQ(loop.plan.landmarks.size(), mls.size());
    for (std::size_t l = 0; l < mls.size(); ++l) {
        const auto& node = map.nodes()[static_cast<std::size_t>(map.landmarkNode(l, 9))];
        EXPECT_EQ(loop.plan.landmarks[l].voxel, inspect::keyIndex(node.key)) << mls[l].id;
        EXPECT_TRUE(node.expectedObject) << mls[l].id;
    }
    // Hand-worked: top (1, 2, 20) +z is voxel ((1 + 64) / 0.25, (2 + 64) / 0.25, (20 + 64) / 0.25 - 1);
    // ny (-1, -10, 12) -y is voxel (252, 216, 304), y index (−10 + 64) / 0.25 on the face's high side.
    EXPECT_EQ(loop.plan.landmarks[0].voxel, Eigen::Vector3i(260, 264, 335));
    EXPECT_EQ(loop.plan.landmarks.back().voxel, Eigen::Vector3i(252, 216, 304));
}

// The whole defect list (hgtest::plateDefects: a feature shifted, material
// missing at a corner, a burr, a hole too large, a face too low, each 0.65 mm)
// through the planner's own views: plan once from the nominal CAD, render the
// planned views of every part as made, inspect. The station can look down the
// through hole (declination up to 90°), and the part stands on a spigot of
// radius 5 mm, 50 mm above the turntable (the floor disc of Rule 2), so every
// landmark — the bottom face and the hole wall included — has a witness. Expected per landmark from the defect geometry
// (hgtest::expectJudgedAgainstTruth): |e| > tolerance + 2ΔV fails, |e| <
// tolerance − 2ΔV passes, e inside the reported bracket ± ΔV.
TEST(ClosedLoop, DefectListThroughThePlannedViews)
{
    const hgtest::TestPart plate = hgtest::defectPlatePart();
    geometry::Station station = makeStation();
    station.fixture.declinationRangeDeg = {0, 90};
    station.floorZMm = -50.0;

    PlanProblem problem;
    problem.part = plate.name;
    problem.solid = plate.solid.get();
    problem.station = &station;
    problem.frame = plate.geometry.frame();
    for (const auto& l : plate.landmarks) problem.landmarks.push_back({l, {}, std::nullopt});
    PlanOptions options;
    options.rules.floorRadiusMm = 5.0;
    const ViewPlan plan = planViews(problem, options);
    ASSERT_TRUE(plan.feasible) << (plan.problems.empty() ? "" : plan.problems[0]);
    for (const auto& a : plan.landmarks) EXPECT_TRUE(a.inspectable()) << a.id << ": " << a.reason;
    std::vector<geometry::CameraModel> cameras;
    for (const auto& v : plan.views) cameras.push_back(v.camera);

    const inspect::InspectionMap map = plate.map();
    const inspect::Inspector inspector(map);
    std::vector<hgtest::PartAsMade> parts{hgtest::asDesigned(plate)};
    for (auto& d : hgtest::plateDefects(plate)) parts.push_back(std::move(d));
    std::uint64_t seed = 100;
    for (const auto& made : parts) {
        SCOPED_TRACE(made.name);
        const auto views = hgtest::renderViews(made.mesh, cameras, 2.0, seed += 16);
        const auto result = inspector.inspect(views, {});
        bool defective = false;
        for (double e : made.offsetMm) defective = defective || std::abs(e) > 0.0;
        EXPECT_EQ(result.pass, !defective);
        hgtest::expectJudgedAgainstTruth(result, plate, made);
    }
}

} // namespace
} // namespace hg::plan
