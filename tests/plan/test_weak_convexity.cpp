// Weak convexity per landmark (Definition 2, Assumptions 2.7-2.10) on the
// dissertation's example objects (2.8), and view plans for them. Every verdict
// is derived by hand in the comment above its test.
//
// Station used throughout: f/Δp = 4000 px, 2448 x 2048 image, camera 300 mm
// from the fixture origin on -y looking along +y; positive declination raises
// it: camera centre (0, -300 cos δ, 300 sin δ) at rotation 0, and rotation θ
// turns that point about z (rotation 90° puts the camera at -x).
#include "hgtest/station.h"
#include "hullgauge/model/csg.h"
#include "hullgauge/model/primitives.h"
#include "hullgauge/plan/planner.h"
#include "plan_problem.h"

#include <cmath>
#include <gtest/gtest.h>

namespace hg::plan {
namespace {

using Eigen::Vector3d;

geometry::Station makeStation(geometry::Range rotation, geometry::Range declination, double floorZ = 0.0)
{
    return hgtest::station({.imageSize = {2448, 2048},
                            .focalPx = 4000,
                            .rotationRangeDeg = rotation,
                            .declinationRangeDeg = declination,
                            .floorZMm = floorZ});
}

PlanLandmark landmark(std::string id, Vec3 p, Vec3 n, double tol = 0.5)
{
    return test::landmark(std::move(id), p, n, tol);
}

// ΔV = 0.25 mm on a grid whose planes fall on integer millimetres.
PlanProblem problemFor(const model::Solid& solid, const geometry::Station& station, std::vector<PlanLandmark> lms)
{
    return test::problemFor(solid, station, std::move(lms), Vec3(-64, -64, -64), 128.0, 9);
}

const LandmarkAnalysis& find(const std::vector<LandmarkAnalysis>& all, const std::string& id)
{
    for (const auto& a : all)
        if (a.id == id) return a;
    throw std::runtime_error("no landmark " + id);
}

// Cube (2.8.1, Proposition 2.1): convex, so every face point is weakly convex.
// The top face z = 20 is grazed where 300 sin δ = 20 (δ = 3.82°); a line of
// sight elevated ε above the face through the voxel above the landmark (centre
// 0.125 mm high) meets the face within 0.125 / tan ε, so the 50 % rule needs
// ε <= atan(0.125 / 10) = 0.72° over the 10 mm half face: every witness of the
// top landmark lies within about a degree of δ = 3.82°.
TEST(WeakConvexity, CubeIsInspectableEverywhereFromGrazingPoses)
{
    model::Solid cube(model::makeBox(Vector3d(-10, -10, 0), Vector3d(10, 10, 20)));
    auto station = makeStation({-180, 180}, {0, 60});
    auto problem = problemFor(cube, station,
                              {landmark("top", {0, 0, 20}, {0, 0, 1}), landmark("px", {10, 0, 10}, {1, 0, 0}),
                               landmark("nx", {-10, 0, 10}, {-1, 0, 0}), landmark("py", {0, 10, 10}, {0, 1, 0}),
                               landmark("ny", {0, -10, 10}, {0, -1, 0}), landmark("corner", {10, 10, 20}, {1, 1, 1})});
    auto all = analyseLandmarks(problem);
    for (const auto& a : all) {
        EXPECT_TRUE(a.inspectable()) << a.id << ": " << a.reason;
        EXPECT_FALSE(a.witnessPoses.empty()) << a.id;
        EXPECT_TRUE(a.unseenVoids.empty()) << a.id << " " << a.unseenVoids.size();
    }
    const double grazing = geometry::radToDeg(std::asin(20.0 / 300.0));
    for (const auto& p : find(all, "top").witnessPoses) EXPECT_NEAR(p.declinationDeg, grazing, 1.0);
    // The -y face: lines of sight run in the plane y = -10, i.e. along x.
    for (const auto& d : find(all, "ny").witnessDirections) EXPECT_LT(std::abs(d.y()), 0.03);
}

// Stamp (fig. 5.2): a handle with a wider head on top; the impression face
// and the head's sides are convex-hull points, the handle's side is seen
// under the head along its own plane (the head overhangs above, nothing below).
TEST(WeakConvexity, StampIsInspectable)
{
    auto mesh = model::unionOf(model::makeBox(Vector3d(-5, -5, 0), Vector3d(5, 5, 30)),
                               model::makeBox(Vector3d(-12, -12, 30), Vector3d(12, 12, 38)));
    model::Solid stamp(mesh);
    auto station = makeStation({-180, 180}, {0, 60});
    auto problem = problemFor(stamp, station,
                              {landmark("face", {0, 0, 38}, {0, 0, 1}), landmark("head-side", {12, 0, 34}, {1, 0, 0}),
                               landmark("handle", {5, 0, 15}, {1, 0, 0})});
    for (const auto& a : analyseLandmarks(problem)) EXPECT_TRUE(a.inspectable()) << a.id << ": " << a.reason;
}

// Open U channel (2.8.3, Proposition 2.3), channel along x: outer walls
// y = ±10, inner walls y = ±6, inner floor z = 4, walls 12 high, 40 long.
// An inner wall's tangent plane y = -6 holds the line of sight only when it
// runs along the channel (x), leaving through an open end: inspectable with a
// full turntable, the camera looking along the channel (rotation near ±90°).
// With rotation limited to [-30°, 30°] the camera can reach the plane y = -6
// only high above (declination > 60°, out of range) — no witness: the
// fixture range excludes them.
model::TriangleMesh uChannel()
{
    // Outline in (y, z), extruded along x: prism coordinates (u, v, w) -> (x, y, z) = (w, u, v).
    std::vector<Eigen::Vector2d> outline{{-10, 0}, {10, 0}, {10, 12}, {6, 12}, {6, 4}, {-6, 4}, {-6, 12}, {-10, 12}};
    auto m = model::makePrism(outline, -20, 20);
    Eigen::Matrix3d R;
    R << 0, 0, 1, 1, 0, 0, 0, 1, 0;
    m.transform(R, Vector3d::Zero());
    return m;
}

TEST(WeakConvexity, UChannelInsideSeenOnlyAlongTheChannel)
{
    model::Solid channel(uChannel());
    auto full = makeStation({-180, 180}, {0, 60});
    auto problem =
        problemFor(channel, full,
                   {landmark("inner-wall", {0, -6, 8}, {0, 1, 0}), landmark("inner-floor", {0, 0, 4}, {0, 0, 1}),
                    landmark("outer-wall", {0, -10, 6}, {0, -1, 0})});
    auto all = analyseLandmarks(problem);
    for (const auto& a : all) EXPECT_TRUE(a.inspectable()) << a.id << ": " << a.reason;
    // Inner wall: the tangent plane y = -6 holds the line of sight (its y
    // component is only the camera's 6 mm offset over 300 mm); in that plane
    // nothing but the floor (z = 4) and the channel's ends bound it, so a line
    // descending from the raised camera through z = 8 must not drop 4 mm over
    // the 20 mm to an end: slope <= 0.2, |d.x| >= 1/√1.04 = 0.981.
    for (const auto& d : find(all, "inner-wall").witnessDirections) {
        EXPECT_LT(std::abs(d.y()), 0.025) << "inner wall line of sight " << d.transpose();
        EXPECT_GT(std::abs(d.x()), 0.98) << "inner wall line of sight " << d.transpose();
    }
    // Inner floor: a level line of sight across the 12 mm wide floor leaves
    // through an open end (20 mm away) only if it turns from x by at most
    // atan(6 / 20) = 16.7°: |d.x| >= cos 16.7° = 0.958.
    for (const auto& d : find(all, "inner-floor").witnessDirections)
        EXPECT_GT(std::abs(d.x()), 0.957) << "inner floor line of sight " << d.transpose();

    // Rotation limited to ±30°: the camera stays on the -y side and can no
    // longer look along the channel. The top of a wall (plane z = 12, grazed
    // at declination asin(12/300) = 2.3° at every rotation) stays inspectable.
    auto limited = makeStation({-30, 30}, {0, 60});
    problem.station = &limited;
    problem.landmarks.push_back(landmark("wall-top", {0, -8, 12}, {0, 0, 1}));
    all = analyseLandmarks(problem);
    EXPECT_TRUE(find(all, "wall-top").inspectable()) << find(all, "wall-top").reason;
    for (const auto& id : {"inner-wall", "inner-floor"}) {
        const auto& a = find(all, id);
        EXPECT_EQ(a.verdict, LandmarkVerdict::OutOfFixtureRange) << id << ": " << a.reason;
        EXPECT_FALSE(a.unreachableWitnesses.empty());
        EXPECT_NE(a.reason.find("cannot reach"), std::string::npos) << a.reason;
        EXPECT_FALSE(a.unseenVoids.empty()) << id;
    }
}

// Handleless cup (2.8.2, Proposition 2.2): every line from a point of the
// inner bottom leaves through the opening or meets the wall; the void above
// the bottom is seen against background only through the opening, where the
// line continues into the bottom itself. Never weakly convex, whatever the
// fixture: a concavity, blocked by the wall; the nearest inspectable surface
// is the outer wall (the inner wall is hidden like the bottom, and the
// underside rests on the turntable).
TEST(WeakConvexity, CupInnerBottomIsNeverWeaklyConvex)
{
    auto mesh = model::difference(model::makeCylinder(Vector3d(0, 0, 0), 15, 20, 48),
                                  model::makeCylinder(Vector3d(0, 0, 3), 12, 20, 48));
    model::Solid cup(mesh);
    auto station = makeStation({-180, 180}, {0, 60});
    auto problem = problemFor(cup, station,
                              {landmark("bottom", {0, 0, 3}, {0, 0, 1}), landmark("outside", {15, 0, 10}, {1, 0, 0})});
    PlanOptions options;
    options.nearestSearchLimit = 400;
    auto all = analyseLandmarks(problem, options);
    const auto& bottom = find(all, "bottom");
    EXPECT_EQ(bottom.verdict, LandmarkVerdict::Concavity) << bottom.reason;
    EXPECT_TRUE(bottom.witnessPoses.empty());
    EXPECT_TRUE(bottom.unreachableWitnesses.empty());
    ASSERT_TRUE(bottom.blockingPoint);
    // The blocker is the cup's wall (between the inner radius 12 and the outer 15).
    const double r = std::hypot(bottom.blockingPoint->x(), bottom.blockingPoint->y());
    EXPECT_GT(r, 11.7) << bottom.blockingPoint->transpose();
    EXPECT_LT(r, 15.01) << bottom.blockingPoint->transpose();
    EXPECT_GT(bottom.blockingPoint->z(), 0.0) << bottom.blockingPoint->transpose();
    // Nearest inspectable: the outer wall (radius 15, at least 15 mm away);
    // the inner wall and bottom are hidden, the underside rests on the turntable.
    ASSERT_TRUE(bottom.nearestInspectablePoint) << bottom.reason;
    const Vec3 q = *bottom.nearestInspectablePoint;
    EXPECT_GT(std::hypot(q.x(), q.y()), 14.5) << q.transpose();
    EXPECT_GT(q.z(), 0.5) << q.transpose();
    EXPECT_GE((q - Vec3(0, 0, 3)).norm(), 14.9) << q.transpose();
    EXPECT_NE(bottom.reason.find("concavity"), std::string::npos);
    EXPECT_FALSE(bottom.unseenVoids.empty());
    EXPECT_TRUE(find(all, "outside").inspectable()) << find(all, "outside").reason;
}

// Plate 40 x 40 x 10 with a through hole of radius 5, tilted so the hole axis
// is a = (0, -sin 45°, cos 45°): looking along it needs the camera 45° above
// the turntable (rotation 0, declination 45°). The hole wall at the facet
// midpoint on +x has tangent plane x = const, which holds the axis; a line in
// that plane tilted φ from the axis leaves the wall by (t/2 sin φ)² / 2R at the
// hole's ends (t = 10, R = 5), so the void voxel beside the wall (0.125 mm in)
// sees through only for sin φ <= √(2 R 0.125) / 5 = 0.22, φ <= 13°. Declination
// range [0, 60] holds 45°: inspectable; [0, 20] stays 25° away: not, and the
// reason is the fixture range. The floor is put far below (−1000 mm) so the
// line of sight through the hole reaches the back light.
TEST(WeakConvexity, HoleWallNeedsTheDeclinationToLookAlongTheAxis)
{
    const int segments = 64;
    auto mesh = model::difference(model::makeBox(Vector3d(-20, -20, -5), Vector3d(20, 20, 5)),
                                  model::makeCylinder(Vector3d(0, 0, -6), 5, 12, segments));
    const double a = geometry::degToRad(45);
    Eigen::Matrix3d R = Eigen::AngleAxisd(a, Vector3d::UnitX()).toRotationMatrix();
    mesh.transform(R, Vector3d::Zero());
    model::Solid plate(mesh);
    // Facet midpoint at angle π/segments on the inscribed polygon, normal into the hole.
    const double phi = 3.14159265358979323846 / segments;
    const Vec3 local(5 * std::cos(phi) * std::cos(phi), 5 * std::cos(phi) * std::sin(phi), 0.0);
    const Vec3 normal = R * Vec3(-std::cos(phi), -std::sin(phi), 0);
    EXPECT_NEAR((R * Vec3::UnitZ() - Vec3(0, -std::sin(a), std::cos(a))).norm(), 0, 1e-12);

    auto wide = makeStation({-180, 180}, {0, 60}, -1000);
    auto problem = problemFor(plate, wide, {landmark("hole-wall", R * local, normal)});
    auto all = analyseLandmarks(problem);
    ASSERT_TRUE(all[0].inspectable()) << all[0].reason;
    for (const auto& d : all[0].witnessDirections) {
        // The line of sight runs within 13° of the axis (either way along it).
        const double along = std::abs(d.dot(R * Vec3::UnitZ()));
        EXPECT_GT(along, std::cos(geometry::degToRad(13.5))) << d.transpose();
    }

    auto low = makeStation({-180, 180}, {0, 20}, -1000);
    problem.station = &low;
    all = analyseLandmarks(problem);
    EXPECT_EQ(all[0].verdict, LandmarkVerdict::OutOfFixtureRange) << all[0].reason;
}

// A tolerance below the station's MED: at d = 300 mm and f/Δp = 4000 px the
// best MED is 2√2·300/8001 = 0.106 mm (eq. 5.3.6-3 at θ = 0); 0.05 mm cannot
// be resolved (and is below no voxel: ΔV = 0.03125 mm on this grid).
TEST(WeakConvexity, ToleranceBelowStationMedIsRefused)
{
    model::Solid cube(model::makeBox(Vector3d(-10, -10, 0), Vector3d(10, 10, 20)));
    auto station = makeStation({-180, 180}, {0, 60});
    auto problem = problemFor(cube, station, {landmark("px", {10, 0, 10}, {1, 0, 0}, 0.05)});
    problem.frame.depth = 12; // ΔV = 0.03125 mm
    auto all = analyseLandmarks(problem);
    EXPECT_EQ(all[0].verdict, LandmarkVerdict::BelowStationMed) << all[0].reason;
    EXPECT_GT(all[0].bestMedMm, 0.106);
    EXPECT_NE(all[0].reason.find("tolerance 0.05 mm"), std::string::npos) << all[0].reason;

    // And a tolerance below ΔV (eq. 5.3.6-1).
    problem.frame.depth = 9;
    problem.landmarks[0].toleranceMm = 0.2;
    all = analyseLandmarks(problem);
    EXPECT_EQ(all[0].verdict, LandmarkVerdict::VoxelTooCoarse) << all[0].reason;
    EXPECT_NE(all[0].reason.find("at least 10"), std::string::npos) << all[0].reason;
}

// Plans: the cube's four side faces cannot share a view (a camera in two
// perpendicular side planes would stand 85° above the turntable; opposite
// planes are 20 mm apart), so at least four views. The top face's grazing
// declination (3.82°, any rotation) crosses each side face's grazing curve, so
// each side view can serve the top too: exactly four. px and px2 share the
// plane x = 10. Every landmark is observed and the exact cover agrees.
// Witnesses outside the tangent-plane band. Cube [-10,10]² x [0,20]; the
// declination range [0°, 1°] keeps the camera 0…5.2 mm high, 300 mm out on -y:
// the top face's tangent plane z = 20 (δ = 3.82°) is out of reach and every
// grid pose looks up at it by at least atan(14.8 / 290) = 2.9°, outside the 2°
// band. At δ = 1° the line of sight through the void voxel above a landmark
// 0.5 mm from the -y edge rises 0.051 mm per mm: followed back towards the
// camera it drops below z = 20 only 2.45 mm before the voxel, beyond the
// edge, and clears the edge (y = -10) where it is higher than 20 + 0.026 mm —
// about 90 % of the voxel (20 … 20.25) is seen against background: weakly
// convex for this station, found only by searching the whole pose set. At the
// face centre the same line meets the face 2.45 mm before the voxel: blocked,
// out of the fixture's range (grazing at δ = 3.82° would see it).
TEST(WeakConvexity, WitnessOutsideTheTangentBandIsFoundByTheFullPoseSearch)
{
    model::Solid cube(model::makeBox(Vector3d(-10, -10, 0), Vector3d(10, 10, 20)));
    auto station = makeStation({-10, 10}, {0, 1});
    auto problem = problemFor(
        cube, station, {landmark("near-edge", {0, -9.5, 20}, {0, 0, 1}), landmark("centre", {0, 0, 20}, {0, 0, 1})});
    auto all = analyseLandmarks(problem);
    const auto& edge = find(all, "near-edge");
    EXPECT_TRUE(edge.inspectable()) << edge.reason;
    ASSERT_FALSE(edge.witnessPoses.empty());
    for (const auto& p : edge.witnessPoses) {
        // Seen from below the tangent plane, outside the band.
        const Vec3 c = station.fixture.cameraCentreInPart(p);
        EXPECT_LT(c.z(), 20.0 - 0.02 * 290.0) << p.rotationDeg << " " << p.declinationDeg;
    }
    const auto& centre = find(all, "centre");
    EXPECT_FALSE(centre.inspectable());
    EXPECT_EQ(centre.verdict, LandmarkVerdict::OutOfFixtureRange) << centre.reason;
}

TEST(ViewPlan, CubePlanObservesEveryLandmark)
{
    model::Solid cube(model::makeBox(Vector3d(-10, -10, 0), Vector3d(10, 10, 20)));
    auto station = makeStation({-180, 180}, {0, 60});
    auto problem = problemFor(cube, station,
                              {landmark("top", {0, 0, 20}, {0, 0, 1}), landmark("px", {10, 0, 10}, {1, 0, 0}),
                               landmark("nx", {-10, 0, 10}, {-1, 0, 0}), landmark("py", {0, 10, 10}, {0, 1, 0}),
                               landmark("ny", {0, -10, 10}, {0, -1, 0}), landmark("px2", {10, 5, 4}, {1, 0, 0})});
    PlanOptions options;
    options.exact = true;
    auto plan = planViews(problem, options);
    ASSERT_TRUE(plan.feasible) << (plan.problems.empty() ? "" : plan.problems[0]);
    EXPECT_EQ(plan.views.size(), 4u);
    ASSERT_TRUE(plan.exactViews);
    EXPECT_EQ(*plan.exactViews, 4u);
    std::vector<int> seen(problem.landmarks.size(), 0);
    for (const auto& v : plan.views) {
        EXPECT_TRUE(station.fixture.reachable(v.pose));
        ASSERT_EQ(v.landmarks.size(), v.predictedMedMm.size());
        for (std::size_t k = 0; k < v.landmarks.size(); ++k) {
            ++seen[v.landmarks[k]];
            EXPECT_LE(v.predictedMedMm[k], 0.5);
            EXPECT_GT(v.predictedMedMm[k], 0.1);
        }
    }
    for (std::size_t l = 0; l < seen.size(); ++l) EXPECT_GT(seen[l], 0) << problem.landmarks[l].id;
    // px and px2 share the face plane x = 10: one view serves both.
    bool shared = false;
    for (const auto& v : plan.views)
        shared = shared || (std::count(v.landmarks.begin(), v.landmarks.end(), 1u) &&
                            std::count(v.landmarks.begin(), v.landmarks.end(), 5u));
    EXPECT_TRUE(shared);
}

TEST(ViewPlan, DesignerBestViewsAreHonoured)
{
    // The designer asks for the +x face landmark from rotation 0, declination
    // 30°: the camera stands at (0, -260, 150), on the inner side of the face
    // plane x = 10, so the line of sight to the void voxel beside the face
    // first passes through the cube (it enters near (9.7, -10, 15.4), 11 mm
    // from the landmark): Rule 2 fails. The plan keeps the designer's view
    // (5.3.2), reports its failure to the designer, and plans an equivalent
    // view from its variation list (5.4.1): a pose that passes the rules and
    // whose line of sight turns from the designer's by at most Θ, the largest
    // view angle eq. 5.3.6-3 allows for the 0.5 mm tolerance at that distance.
    model::Solid cube(model::makeBox(Vector3d(-10, -10, 0), Vector3d(10, 10, 20)));
    auto station = makeStation({-180, 180}, {0, 60});
    auto lm = landmark("px", {10, 0, 10}, {1, 0, 0});
    lm.bestViews = {{{0, 30, 0}}};
    auto problem = problemFor(cube, station, {lm});
    auto plan = planViews(problem);
    ASSERT_EQ(plan.landmarks.size(), 1u);
    EXPECT_TRUE(plan.landmarks[0].designerBestViews);
    ASSERT_FALSE(plan.landmarks[0].warnings.empty());
    EXPECT_NE(plan.landmarks[0].warnings[0].find("Rule 2"), std::string::npos) << plan.landmarks[0].warnings[0];
    ASSERT_EQ(plan.views.size(), 1u);
    EXPECT_TRUE(plan.feasible) << (plan.problems.empty() ? "" : plan.problems[0]);
    ASSERT_EQ(plan.views[0].landmarks.size(), 1u);
    const Vec3 x(10, 0, 10);
    const Vec3 designer = (x - station.fixture.cameraCentreInPart({0, 30, 0})).normalized();
    const Vec3 chosen = plan.views[0].camera.lineOfSight(x);
    const double theta = maxViewAngleRad(4000, (x - station.fixture.cameraCentreInPart({0, 30, 0})).norm(), 0.5);
    EXPECT_GT(theta, geometry::degToRad(20)); // hand check: Θ = 38.2° at d = 300 mm
    EXPECT_LE(std::acos(designer.dot(chosen)), theta + 1e-9);
    // And the chosen view grazes the face: camera centre within 1 mm of x = 10.
    EXPECT_NEAR(plan.views[0].camera.centre()->x(), 10.0, 1.0);
}

TEST(ViewPlan, RequestedViewCountTooSmallFails)
{
    model::Solid cube(model::makeBox(Vector3d(-10, -10, 0), Vector3d(10, 10, 20)));
    auto station = makeStation({-180, 180}, {0, 60});
    auto problem =
        problemFor(cube, station, {landmark("px", {10, 0, 10}, {1, 0, 0}), landmark("py", {0, 10, 10}, {0, 1, 0})});
    PlanOptions options;
    options.maxViews = 1;
    auto plan = planViews(problem, options);
    EXPECT_FALSE(plan.feasible);
    ASSERT_FALSE(plan.problems.empty());
    EXPECT_NE(plan.problems.back().find("at most 1"), std::string::npos) << plan.problems.back();
}

} // namespace
} // namespace hg::plan
