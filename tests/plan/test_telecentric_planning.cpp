// Planning for a telecentric camera (docs/telecentric.md): grazing lines of
// sight are parallel to the optical axis, and Rule 4 holds a view to the
// lens's depth of field and telecentric field. Every expectation is derived
// by hand in the comment above it.
//
// Station: a telecentric camera of 100 px per mm of object (0.01 mm/px),
// 2448 x 2048 px, on the part's -y side looking along +y with its focus plane
// (camera z = 0) through the fixture origin: X_cam = (x, -z, y) at rotation 0,
// declination 0. Rotation θ turns the part about z; the optical axis in the
// part frame is then (sin θ, cos θ, 0) (θ = 90° looks along +x).
#include "hgtest/station.h"
#include "hullgauge/model/primitives.h"
#include "hullgauge/plan/planner.h"
#include "hullgauge/plan/pose_space.h"
#include "plan_problem.h"

#include <cmath>
#include <gtest/gtest.h>

namespace hg::plan {
namespace {

geometry::Station telecentricStation(const std::string& limits, geometry::Range rotation = {-180, 180})
{
    return hgtest::station({.imageSize = {2448, 2048},
                            .focalPx = 100,
                            .cameraKeys = "  model: telecentric\n" + limits,
                            .distanceMm = 0,
                            .rotationRangeDeg = rotation,
                            .declinationRangeDeg = {0, 60}});
}

PlanLandmark landmark(std::string id, Vec3 p, Vec3 n, double tol = 0.1)
{
    return test::landmark(std::move(id), p, n, tol);
}

// ΔV = 0.0625 mm on a grid whose planes fall on sixteenths of a millimetre.
PlanProblem problemFor(const model::Solid& solid, const geometry::Station& station, std::vector<PlanLandmark> lms)
{
    return test::problemFor(solid, station, std::move(lms), Vec3(-16, -16, -16), 32.0, 9);
}

// The face x = 5 (normal +x) is grazed where the axis lies in it: n·a =
// sin θ·cos δ = 0, θ = 0 or ±180° at every declination — wherever the
// landmark is. A pinhole camera 300 mm away grazes it where its centre does,
// 300·sin θ = 5 (θ = ±0.95°, 180 ∓ 0.95°): not these.
TEST(TelecentricPlanning, GrazingPosesPutTheOpticalAxisInTheTangentPlane)
{
    const geometry::Station station = telecentricStation("");
    ASSERT_EQ(station.fixture.cameraProjection, geometry::Projection::Telecentric);
    PoseGrid grid;
    grid.rotationStepDeg = 10;
    grid.declinationStepDeg = 10;
    for (const Vec3& at : {Vec3(5, 0, 5), Vec3(5, 3, 8), Vec3(5, -4, 1)}) {
        const auto poses = grazingPoses(station.fixture, at, Vec3::UnitX(), grid);
        ASSERT_FALSE(poses.empty());
        for (const auto& p : poses) {
            const double r = std::remainder(p.rotationDeg, 180.0);
            EXPECT_NEAR(r, 0.0, 1e-9) << "rotation " << p.rotationDeg << " declination " << p.declinationDeg;
            // The axis there lies in the tangent plane.
            EXPECT_NEAR(station.cameraAt(p).opticalAxis().x(), 0.0, 1e-12) << p.rotationDeg;
        }
    }
}

// A 10 mm cube [-5, 5]² x [0, 10]; the landmark at the top face's middle
// (0, 0, 10), normal +z. Only horizontal axes (declination 0) graze the top
// face, and every one passes 10 mm from the landmark: its distance from the
// optical axis is the height above the fixture origin. Its depth is 0.
TEST(TelecentricPlanning, ALandmarkOutsideTheTelecentricFieldIsRefused)
{
    model::Solid cube(model::makeBox(Vec3(-5, -5, 0), Vec3(5, 5, 10)));
    const Vec3 top(0, 0, 10);
    // A 30 mm field (radius 15): inside. A 16 mm field (radius 8): outside at every grazing pose.
    const geometry::Station wide = telecentricStation("  telecentric_field_mm: 30\n");
    const auto ok = analyseLandmarks(problemFor(cube, wide, {landmark("top", top, Vec3::UnitZ())}));
    ASSERT_EQ(ok.size(), 1u);
    EXPECT_TRUE(ok[0].inspectable()) << ok[0].reason;
    const geometry::Station narrow = telecentricStation("  telecentric_field_mm: 16\n");
    const auto refused = analyseLandmarks(problemFor(cube, narrow, {landmark("top", top, Vec3::UnitZ())}));
    ASSERT_EQ(refused.size(), 1u);
    EXPECT_EQ(refused[0].verdict, LandmarkVerdict::OutsideTelecentricField) << refused[0].reason;
    EXPECT_NE(refused[0].reason.find("telecentric field (16 mm across; e.g. 10 mm from the axis)"), std::string::npos)
        << refused[0].reason;
    // The pose itself: Rule 4 names the field.
    const ViewRules rules(cube, narrow, 0.0625);
    LandmarkTarget target;
    target.position = top;
    target.witnessVoxel = Eigen::AlignedBox3d(Vec3(-0.0625, -0.0625, 10.0), Vec3(0.0625, 0.0625, 10.125));
    target.toleranceMm = 0.1;
    const RuleCheck check = rules.check(target, geometry::FixturePose{0, 0, 0});
    EXPECT_TRUE(check.inDepthOfField);
    EXPECT_FALSE(check.inTelecentricField);
    EXPECT_FALSE(check.rule4);
    EXPECT_NEAR(check.offAxisMm, 10.0, 1e-9);
    EXPECT_NE(check.failure().find("outside the lens's telecentric field"), std::string::npos) << check.failure();
}

// The landmark (0, 4, 10) on the top face, the turntable held within ±10°:
// its depth is 4·cos θ in [3.94, 4] mm at every reachable pose. A depth of
// field of 10 mm ([-5, 5]) holds it; one of 6 mm ([-3, 3]) does not.
TEST(TelecentricPlanning, ALandmarkOutsideTheDepthOfFieldIsRefused)
{
    model::Solid cube(model::makeBox(Vec3(-5, -5, 0), Vec3(5, 5, 10)));
    const Vec3 at(0, 4, 10);
    const geometry::Station deep = telecentricStation("  depth_of_field_mm: 10\n", {-10, 10});
    const auto ok = analyseLandmarks(problemFor(cube, deep, {landmark("top", at, Vec3::UnitZ())}));
    ASSERT_EQ(ok.size(), 1u);
    EXPECT_TRUE(ok[0].inspectable()) << ok[0].reason;
    const geometry::Station shallow = telecentricStation("  depth_of_field_mm: 6\n", {-10, 10});
    ASSERT_TRUE(shallow.depthOfFieldMm);
    EXPECT_DOUBLE_EQ(shallow.depthOfFieldMm->min, -3.0);
    const auto refused = analyseLandmarks(problemFor(cube, shallow, {landmark("top", at, Vec3::UnitZ())}));
    ASSERT_EQ(refused.size(), 1u);
    EXPECT_EQ(refused[0].verdict, LandmarkVerdict::OutsideDepthOfField) << refused[0].reason;
    EXPECT_NE(refused[0].reason.find("outside the depth of field [-3, 3] mm"), std::string::npos) << refused[0].reason;
}

} // namespace
} // namespace hg::plan
