// Landmark suggestion (docs/part-program.md, "Suggesting landmarks";
// include/hullgauge/plan/landmark_suggest.h): the candidates of boxes, a box
// with a bore and the simulated line's stepped block against their analytic
// faces, edges and bore; the farthest-point spread on hand-worked point sets;
// and the suggestions at the simulated line's station (config/sim/station.yaml)
// against the hand-worked selection for a box.
//
// The simulated station's camera centre is (0, -400, 15) mm at rotation 0,
// declination 0 (camera_from_fixture t = (0, 15, 400), R: camera z = part y),
// 15 mm above the floor plane z = 0; declination raises it, rotation turns it
// about z. Nothing below the floor is seen: no point of a bottom face, and
// no bottom edge (its void neighbour lies below the floor plane, over the
// turntable).
#include "hgtest/paths.h"
#include "hullgauge/geometry/station.h"
#include "hullgauge/model/csg.h"
#include "hullgauge/model/mesh_io.h"
#include "hullgauge/model/part_program.h"
#include "hullgauge/model/primitives.h"
#include "hullgauge/plan/landmark_suggest.h"

#include <cmath>
#include <gtest/gtest.h>
#include <numbers>
#include <set>

namespace hg::plan {
namespace {

using Eigen::Vector3d;
constexpr double kPi = std::numbers::pi;

double degreesBetween(const Vector3d& a, const Vector3d& b)
{
    return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) * 180.0 / kPi;
}

/// The outward normal of an axis-aligned box at a surface point: the face's
/// normal inside a face, the bisector of the two faces on an edge.
Vector3d boxNormalAt(const Vector3d& p, const Vector3d& lo, const Vector3d& hi)
{
    Vector3d n = Vector3d::Zero();
    for (int a = 0; a < 3; ++a) {
        if (std::abs(p[a] - lo[a]) < 1e-6) n[a] -= 1.0;
        if (std::abs(p[a] - hi[a]) < 1e-6) n[a] += 1.0;
    }
    return n.normalized();
}

// The box with a bore of these tests: [-20, 20] x [-15, 15] x [0, 30] less a
// through bore r = 5 along y about the line x = 0, z = 18 (64 facets, a
// vertex at the top and at the bottom of the circle).
const Vector3d kBoreLo(-20, -15, 0), kBoreHi(20, 15, 30);
constexpr double kBoreRadius = 5.0, kBoreAxisZ = 18.0;

model::TriangleMesh boxWithBore()
{
    model::TriangleMesh bore = model::makeCylinder(Vector3d(0, 0, -20), kBoreRadius, 40, 64);
    Eigen::Matrix3d toY; // z -> y, y -> -z: the cylinder's axis along y
    toY << 1, 0, 0, 0, 0, 1, 0, -1, 0;
    bore.transform(toY, Vector3d(0, 0, kBoreAxisZ));
    return model::difference(model::makeBox(kBoreLo, kBoreHi), bore);
}

/// Unit vector from the bore's axis to p, square to the axis.
Vector3d radialOfBore(const Vector3d& p)
{
    return Vector3d(p.x(), 0.0, p.z() - kBoreAxisZ).normalized();
}

geometry::Station simStation()
{
    return geometry::loadStation(hgtest::sourceDir() / "config/sim/station.yaml");
}

SuggestProblem problemFor(const std::shared_ptr<const model::Solid>& solid, const geometry::Station& station,
                          int depth = 8, int adjacency = 3)
{
    const auto cube = model::boundingCube(solid->mesh().bounds(), depth, adjacency);
    SuggestProblem p;
    p.solid = solid;
    p.station = &station;
    p.frame = {cube->cubeOrigin, cube->cubeSize, cube->depth};
    return p;
}

std::set<FeatureKind> kindsOf(const Suggestion& s)
{
    std::set<FeatureKind> kinds;
    for (const auto& lm : s.landmarks) kinds.insert(lm.candidate.kind);
    return kinds;
}

double minPairwiseMm(const Suggestion& s)
{
    double d = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < s.landmarks.size(); ++i)
        for (std::size_t j = i + 1; j < s.landmarks.size(); ++j)
            d = std::min(d, (s.landmarks[i].candidate.position - s.landmarks[j].candidate.position).norm());
    return d;
}

// Eleven points at x = 0..10: the centroid is x = 5, so the first pick is
// x = 0 (0 and 10 tie; the lower index wins), then x = 10 (10 mm away), then
// x = 5 (5 mm from both).
TEST(LandmarkSuggest, SpreadOnALineIsTheHandWorkedOne)
{
    std::vector<Vec3> points;
    for (int x = 0; x <= 10; ++x) points.emplace_back(x, 0, 0);
    const std::vector<FeatureKind> kinds(points.size(), FeatureKind::Face);
    const auto picks = spreadSelect(points, kinds, 3);
    ASSERT_EQ(picks.size(), 3u);
    EXPECT_EQ(picks[0].index, 0u);
    EXPECT_FALSE(picks[0].nearest);
    EXPECT_DOUBLE_EQ(picks[0].distanceMm, 5.0);
    EXPECT_EQ(picks[1].index, 10u);
    EXPECT_DOUBLE_EQ(picks[1].distanceMm, 10.0);
    EXPECT_EQ(picks[2].index, 5u);
    EXPECT_DOUBLE_EQ(picks[2].distanceMm, 5.0);
    for (const auto& p : picks) EXPECT_FALSE(p.forMinimumShare);
}

// Faces at x = 0..10 and one hole at x = 3.5, three picks with at least one
// hole. Centroid x = (55 + 3.5) / 12 = 4.875: x = 10 first (5.125 mm), then
// x = 0 (10 mm). One slot is left and the hole still missing, so the third
// pick is the hole (3.5 mm from x = 0), not the face at x = 5 the spread
// alone would take (5 mm).
TEST(LandmarkSuggest, SpreadKeepsTheMinimumShareOfAKind)
{
    std::vector<Vec3> points;
    for (int x = 0; x <= 10; ++x) points.emplace_back(x, 0, 0);
    points.emplace_back(3.5, 0, 0);
    std::vector<FeatureKind> kinds(points.size(), FeatureKind::Face);
    kinds.back() = FeatureKind::Hole;
    const auto picks = spreadSelect(points, kinds, 3, {0, 0, 1});
    ASSERT_EQ(picks.size(), 3u);
    EXPECT_EQ(picks[0].index, 10u);
    EXPECT_NEAR(picks[0].distanceMm, 5.125, 1e-12);
    EXPECT_EQ(picks[1].index, 0u);
    EXPECT_EQ(picks[2].index, 11u);
    EXPECT_TRUE(picks[2].forMinimumShare);
    EXPECT_EQ(picks[2].nearest, std::optional<std::size_t>(0u));
    EXPECT_DOUBLE_EQ(picks[2].distanceMm, 3.5);
    // More picks than points: every point, once.
    EXPECT_EQ(spreadSelect(points, kinds, 40, {0, 0, 1}).size(), points.size());
}

// A box has six faces (their centres) and twelve edges (their midpoints, the
// bisector normals); nothing else.
TEST(LandmarkSuggest, BoxCandidatesAreItsFaceCentresAndEdgeMidpoints)
{
    const Vector3d lo(-20, -15, 0), hi(20, 15, 20);
    const auto box = std::make_shared<const model::Solid>(model::makeBox(lo, hi));
    const auto candidates = findCandidates(*box);
    std::size_t faces = 0, edges = 0;
    for (const auto& c : candidates) {
        EXPECT_LE(box->closestPoint(c.position).distance, 1e-9);
        EXPECT_LT(degreesBetween(c.normal, boxNormalAt(c.position, lo, hi)), 1e-6) << c.feature;
        // On a face or an edge, at its middle: every coordinate off the
        // face's (edge's) planes is the box's middle there.
        const Vector3d mid = (lo + hi) / 2.0;
        int onPlanes = 0;
        for (int a = 0; a < 3; ++a) {
            const bool onPlane = std::abs(c.position[a] - lo[a]) < 1e-9 || std::abs(c.position[a] - hi[a]) < 1e-9;
            onPlanes += onPlane ? 1 : 0;
            if (!onPlane) {
                EXPECT_NEAR(c.position[a], mid[a], 1e-9) << c.feature;
            }
        }
        if (c.kind == FeatureKind::Face) {
            ++faces;
            EXPECT_EQ(onPlanes, 1) << c.feature;
        } else {
            ++edges;
            EXPECT_EQ(c.kind, FeatureKind::Edge);
            EXPECT_EQ(onPlanes, 2) << c.feature;
        }
    }
    EXPECT_EQ(faces, 6u);
    EXPECT_EQ(edges, 12u);
}

// The bore gives four points round its wall at mid-length (y = 0), on the
// mesh, their normals pointing to the axis; and four on each rim (y = ±15),
// normals within half a facet angle (360° / 64 / 2 = 2.8°) of the bisector of
// the face and the true wall there. Re-entrant edges give nothing.
TEST(LandmarkSuggest, BoreCandidatesLieOnItsWallAndRimsWithNormalsToTheAxis)
{
    const auto part = std::make_shared<const model::Solid>(boxWithBore());
    std::size_t wall = 0, rim = 0;
    for (const auto& c : findCandidates(*part)) {
        EXPECT_LE(part->closestPoint(c.position).distance, 1e-9);
        if (c.kind != FeatureKind::Hole) {
            EXPECT_LT(degreesBetween(c.normal, boxNormalAt(c.position, kBoreLo, kBoreHi)), 1e-6) << c.feature;
            continue;
        }
        const double fromAxis = std::hypot(c.position.x(), c.position.z() - kBoreAxisZ);
        // The 64-gon lies between the inscribed radius r cos(π/64) and r.
        EXPECT_LE(fromAxis, kBoreRadius + 1e-9);
        EXPECT_GE(fromAxis, kBoreRadius * std::cos(kPi / 64) - 1e-9);
        if (std::abs(c.position.y()) < 1e-9) {
            ++wall;
            EXPECT_LT(degreesBetween(c.normal, -radialOfBore(c.position)), 1e-6) << c.feature;
        } else {
            ++rim;
            EXPECT_NEAR(std::abs(c.position.y()), 15.0, 1e-9);
            const Vector3d face(0, c.position.y() > 0 ? 1 : -1, 0);
            EXPECT_LT(degreesBetween(c.normal, face - radialOfBore(c.position)), 360.0 / 64 / 2 + 1e-6) << c.feature;
        }
    }
    EXPECT_EQ(wall, 4u);
    EXPECT_EQ(rim, 8u);
}

// Plates [-30, 30] x [-10, 10] x [0, 30] with an opening through them along
// y about the line x = 0, z = 18: a slot 20 mm along x, 6 mm across (its ends
// half circles r = 3 about x = ±7, 16 facets each, a vertex at each end's
// apex), and a D: the circle r = 5 less what lies beyond x = 3 (48 facets on
// the arc, one flat).
constexpr double kOpeningAxisZ = 18.0;

model::TriangleMesh plateWith(const std::vector<Eigen::Vector2d>& outline)
{
    model::TriangleMesh cutter = model::makePrism(outline, -20, 20);
    Eigen::Matrix3d toY; // z -> y, y -> -z: the prism's axis along y
    toY << 1, 0, 0, 0, 0, 1, 0, -1, 0;
    cutter.transform(toY, Vector3d(0, 0, kOpeningAxisZ));
    return model::difference(model::makeBox(Vector3d(-30, -10, 0), Vector3d(30, 10, 30)), cutter);
}

std::vector<Eigen::Vector2d> slotOutline()
{
    std::vector<Eigen::Vector2d> out;
    for (int end : {1, -1})
        for (int i = 0; i <= 16; ++i) {
            const double a = (end > 0 ? -0.5 : 0.5) * kPi + i * kPi / 16;
            out.emplace_back(end * 7.0 + 3.0 * std::cos(a), 3.0 * std::sin(a));
        }
    return out;
}

std::vector<Eigen::Vector2d> dOutline()
{
    const double from = std::acos(3.0 / 5.0);
    std::vector<Eigen::Vector2d> out{{3.0, -4.0}};
    for (int i = 0; i <= 48; ++i) {
        const double a = from + i * (2.0 * kPi - 2.0 * from) / 48;
        out.emplace_back(5.0 * std::cos(a), 5.0 * std::sin(a));
    }
    out.pop_back(); // (3, -4) again
    return out;
}

/// The wall candidates (kind hole, at mid-length y = 0) and the rim ones.
struct OpeningCandidates {
    std::vector<LandmarkCandidate> wall, rim;
};

OpeningCandidates openingCandidates(const model::Solid& part)
{
    OpeningCandidates out;
    for (const auto& c : findCandidates(part)) {
        EXPECT_LE(part.closestPoint(c.position).distance, 1e-9);
        if (c.kind == FeatureKind::Hole) (std::abs(c.position.y()) < 1e-9 ? out.wall : out.rim).push_back(c);
    }
    return out;
}

// The slot: four wall points — its apexes (±10, 0, 18), normals along ∓x
// within half a facet's angle (180° / 16 / 2), and the middles of its flats
// (0, 0, 18 ± 3), normals ∓z — and four on each rim (y = ±10).
TEST(LandmarkSuggest, SlotCandidatesLieOnItsEndsAndFlatsWithNormalsIntoIt)
{
    const model::Solid part(plateWith(slotOutline()));
    const OpeningCandidates c = openingCandidates(part);
    ASSERT_EQ(c.wall.size(), 4u);
    EXPECT_EQ(c.rim.size(), 8u);
    std::set<std::pair<int, int>> seen;
    for (const auto& w : c.wall) {
        EXPECT_NE(w.feature.find("slot 20 × 6 mm"), std::string::npos) << w.feature;
        // The wall's centroid, where the rays start, lies within microns of
        // the slot's centre: CGAL's cut leaves slivers along the wall.
        const double x = w.position.x(), dz = w.position.z() - kOpeningAxisZ;
        if (std::abs(dz) < 1.0) {
            EXPECT_NEAR(std::abs(x), 10.0, 1e-5);
            EXPECT_LT(degreesBetween(w.normal, Vector3d(-x, 0, 0)), 180.0 / 16 / 2 + 1e-6) << w.feature;
        } else {
            EXPECT_NEAR(x, 0.0, 1e-5);
            EXPECT_NEAR(std::abs(dz), 3.0, 1e-9);
            EXPECT_LT(degreesBetween(w.normal, Vector3d(0, 0, -dz)), 1e-6) << w.feature;
        }
        seen.emplace(static_cast<int>(std::round(x)), static_cast<int>(std::round(dz)));
    }
    EXPECT_EQ(seen, (std::set<std::pair<int, int>>{{-10, 0}, {10, 0}, {0, -3}, {0, 3}}));
    for (const auto& r : c.rim) EXPECT_NEAR(std::abs(r.position.y()), 10.0, 1e-9) << r.feature;
}

// The D: four wall points on its outline (the flat x = 3, |z - 18| ≤ 4, normal
// -x; or the arc, between the 48-gon's inscribed radius and 5, normal to the
// axis within half a facet's angle), one of them on the flat; four on each rim.
TEST(LandmarkSuggest, DShapedHoleCandidatesLieOnItsFlatAndArc)
{
    const model::Solid part(plateWith(dOutline()));
    const OpeningCandidates c = openingCandidates(part);
    ASSERT_EQ(c.wall.size(), 4u);
    EXPECT_EQ(c.rim.size(), 8u);
    const double facet = (2.0 * kPi - 2.0 * std::acos(0.6)) / 48;
    std::size_t onFlat = 0;
    for (const auto& w : c.wall) {
        EXPECT_NE(w.feature.find("D-shaped hole"), std::string::npos) << w.feature;
        const Vector3d radial(w.position.x(), 0, w.position.z() - kOpeningAxisZ);
        if (std::abs(w.position.x() - 3.0) < 1e-9) {
            ++onFlat;
            EXPECT_LE(std::abs(radial.z()), 4.0 + 1e-9);
            EXPECT_LT(degreesBetween(w.normal, Vector3d(-1, 0, 0)), 1e-6);
        } else {
            EXPECT_LE(radial.norm(), 5.0 + 1e-9);
            EXPECT_GE(radial.norm(), 5.0 * std::cos(facet / 2) - 1e-9);
            EXPECT_LT(degreesBetween(w.normal, -radial), facet / 2 * 180.0 / kPi + 1e-6) << w.feature;
        }
    }
    EXPECT_EQ(onFlat, 1u);
}

// At the simulated station (the camera looks along y at rotation 0, through
// the slot against the backlight) the slotted plate's suggestion holds a
// landmark on the slot.
TEST(LandmarkSuggest, SlottedPlateGetsItsSlot)
{
    const auto part = std::make_shared<const model::Solid>(plateWith(slotOutline()));
    const auto station = simStation();
    const Suggestion s = suggestLandmarks(problemFor(part, station), {});
    std::size_t onSlot = 0;
    for (const auto& lm : s.landmarks)
        if (lm.candidate.kind == FeatureKind::Hole && lm.candidate.feature.find("slot") != std::string::npos) ++onSlot;
    EXPECT_GE(onSlot, 1u);
}

// The box [-20, 20] x [-15, 15] x [0, 20] at the simulated station, 4
// landmarks (at least one face and one edge). Inspectable: the top and the
// four side face centres, the four top and four vertical edge midpoints (13
// candidates, centroid (0, 0, 180/13)); the bottom face and edges are not.
// Worked by hand: the vertical edge midpoints (±20, ±15, 10) are farthest
// from the centroid (25.3 mm); the first is followed by the opposite one
// (50 mm), then by a third vertical edge (30 mm from its nearer one; the top
// centre would be 26.9 mm, a top edge 22.4 mm at most). The last slot must be
// a face: the top centre, √(20² + 15² + 10²) = 26.93 mm from each vertical
// edge midpoint (a side face centre is 15 or 20 mm from one of them).
TEST(LandmarkSuggest, BoxSuggestionIsTheHandWorkedSpread)
{
    const Vector3d lo(-20, -15, 0), hi(20, 15, 20);
    const auto box = std::make_shared<const model::Solid>(model::makeBox(lo, hi));
    const auto station = simStation();
    SuggestOptions options;
    options.count = 4;
    const Suggestion s = suggestLandmarks(problemFor(box, station), options);
    EXPECT_EQ(s.candidates[0], 6u);
    EXPECT_EQ(s.candidates[1], 12u);
    EXPECT_EQ(s.inspectable[0], 5u);
    EXPECT_EQ(s.inspectable[1], 8u);
    ASSERT_EQ(s.landmarks.size(), 4u);
    EXPECT_GE(minPairwiseMm(s), std::sqrt(725.0) - 1e-6);
    for (std::size_t i = 0; i < 3; ++i) {
        EXPECT_EQ(s.landmarks[i].candidate.kind, FeatureKind::Edge);
        EXPECT_NEAR(std::abs(s.landmarks[i].candidate.position.x()), 20.0, 1e-9);
        EXPECT_NEAR(std::abs(s.landmarks[i].candidate.position.y()), 15.0, 1e-9);
        EXPECT_NEAR(s.landmarks[i].candidate.position.z(), 10.0, 1e-9);
    }
    EXPECT_EQ(s.landmarks[3].id, "face-1");
    EXPECT_LT((s.landmarks[3].candidate.position - Vector3d(0, 0, 20)).norm(), 1e-9);
    EXPECT_NE(s.landmarks[3].reason.find("at least 1 of 4 on faces"), std::string::npos) << s.landmarks[3].reason;
    for (const auto& lm : s.landmarks) {
        EXPECT_LE(box->closestPoint(lm.candidate.position).distance, 1e-6);
        EXPECT_LT(degreesBetween(lm.candidate.normal, boxNormalAt(lm.candidate.position, lo, hi)), 1e-6);
        EXPECT_GT(lm.witnessPoses, 0u);
    }
    EXPECT_TRUE(s.notes.empty());
}

// The box with a bore at the simulated station: faces, edges and the bore
// among eight suggestions, each on the mesh with its analytic normal.
TEST(LandmarkSuggest, BoxWithABoreGetsFacesEdgesAndTheBore)
{
    const auto part = std::make_shared<const model::Solid>(boxWithBore());
    const auto station = simStation();
    const Suggestion s = suggestLandmarks(problemFor(part, station), {});
    ASSERT_EQ(s.landmarks.size(), 8u);
    EXPECT_EQ(kindsOf(s), (std::set<FeatureKind>{FeatureKind::Face, FeatureKind::Edge, FeatureKind::Hole}));
    std::set<std::string> ids;
    for (const auto& lm : s.landmarks) {
        const LandmarkCandidate& c = lm.candidate;
        EXPECT_TRUE(ids.insert(lm.id).second) << lm.id;
        EXPECT_LE(part->closestPoint(c.position).distance, 1e-6) << lm.id;
        if (c.kind == FeatureKind::Hole && std::abs(c.position.y()) < 1e-9) {
            EXPECT_LT(degreesBetween(c.normal, -radialOfBore(c.position)), 1e-6) << lm.id;
        } else if (c.kind == FeatureKind::Hole) {
            const Vector3d face(0, c.position.y() > 0 ? 1 : -1, 0);
            EXPECT_LT(degreesBetween(c.normal, face - radialOfBore(c.position)), 360.0 / 64 / 2 + 1e-6) << lm.id;
        } else {
            EXPECT_LT(degreesBetween(c.normal, boxNormalAt(c.position, kBoreLo, kBoreHi)), 1e-6) << lm.id;
        }
    }
}

// The simulated line's stepped block: tall block x in [-30, 0] up to z = 30,
// step x in [0, 30] up to z = 15, y in [-20, 20]. Every suggestion on the
// mesh; faces and edges (no bore); the normals those of the block's planes.
TEST(LandmarkSuggest, SteppedBlockSuggestionsLieOnItsFacesAndEdges)
{
    const auto block =
        std::make_shared<const model::Solid>(model::loadMesh(hgtest::sourceDir() / "config/sim/stepped-block.stl"));
    const auto station = simStation();
    const Suggestion s = suggestLandmarks(problemFor(block, station, 8, 4), {});
    ASSERT_EQ(s.landmarks.size(), 8u);
    EXPECT_EQ(kindsOf(s), (std::set<FeatureKind>{FeatureKind::Face, FeatureKind::Edge}));
    EXPECT_EQ(s.candidates[2], 0u);
    for (const auto& lm : s.landmarks) {
        const Vector3d& p = lm.candidate.position;
        EXPECT_LE(block->closestPoint(p).distance, 1e-6) << lm.id;
        // The point lies in the tall block's or the step's box; its normal is that box's there.
        const bool tall = p.x() <= 0.0 && !(p.x() > -1e-9 && p.z() < 15.0 - 1e-9);
        const Vector3d lo(tall ? -30 : 0, -20, 0), hi(tall ? 0 : 30, 20, tall ? 30 : 15);
        EXPECT_LT(degreesBetween(lm.candidate.normal, boxNormalAt(p, lo, hi)), 1e-6) << lm.id << " " << p.transpose();
    }
}

// Asking for more landmarks than there are inspectable candidates gives them
// all, with a note saying so.
TEST(LandmarkSuggest, MoreThanThereAreGivesAllWithANote)
{
    const auto box = std::make_shared<const model::Solid>(model::makeBox(Vector3d(-20, -15, 0), Vector3d(20, 15, 20)));
    const auto station = simStation();
    SuggestOptions options;
    options.count = 50;
    const Suggestion s = suggestLandmarks(problemFor(box, station), options);
    EXPECT_EQ(s.landmarks.size(), 13u);
    ASSERT_FALSE(s.notes.empty());
    EXPECT_NE(s.notes.front().find("asked for 50 landmarks, but only 13"), std::string::npos) << s.notes.front();
    const std::string yaml = landmarksYaml(s, 0.5, {"header"});
    EXPECT_NE(yaml.find("# Note: asked for 50"), std::string::npos);
}

// The box's candidates no reachable pose inspects — its bottom face and
// bottom edges, on the floor plane z = 0 — are kept as refused, each with the
// planner's verdict as its rule and a reason.
TEST(LandmarkSuggest, RefusedCandidatesNameTheRuleThatRemovedThem)
{
    const auto box = std::make_shared<const model::Solid>(model::makeBox(Vector3d(-20, -15, 0), Vector3d(20, 15, 20)));
    const auto station = simStation();
    SuggestOptions options;
    options.count = 50;
    const Suggestion s = suggestLandmarks(problemFor(box, station), options);
    ASSERT_EQ(s.refused.size(), 5u);
    std::set<std::string> verdicts;
    for (LandmarkVerdict v :
         {LandmarkVerdict::NoVoidNeighbour, LandmarkVerdict::Concavity, LandmarkVerdict::OutOfFixtureRange,
          LandmarkVerdict::OutsideDepthOfField, LandmarkVerdict::BelowStationMed, LandmarkVerdict::VoxelTooCoarse})
        verdicts.insert(std::string(hg::enumName(v)));
    for (const RefusedCandidate& r : s.refused) {
        EXPECT_NEAR(r.candidate.position.z(), 0.0, 1e-9) << r.candidate.feature;
        EXPECT_TRUE(verdicts.count(r.rule)) << r.rule;
        EXPECT_FALSE(r.why.empty());
    }
    EXPECT_NE(refusedMarkdown(s).find("| " + s.refused.front().rule + " |"), std::string::npos);
}

// A screen (on the twin, in the commands) that refuses the box's top centre,
// the hand-worked spread's face (BoxSuggestionIsTheHandWorkedSpread): the
// spread is made again without it, a side face taking the face's slot, and
// the top centre is kept as refused under the screen's rule.
TEST(LandmarkSuggest, AScreenedOutPickIsLeftOutAndTheSpreadMadeAgain)
{
    const auto box = std::make_shared<const model::Solid>(model::makeBox(Vector3d(-20, -15, 0), Vector3d(20, 15, 20)));
    const auto station = simStation();
    const Vector3d topCentre(0, 0, 20);
    SuggestOptions options;
    options.count = 4;
    std::size_t calls = 0;
    options.screen = [&](const std::vector<LandmarkCandidate>& chosen, const ViewPlan& plan,
                         const std::vector<inspect::LandmarkCapability>& capability) {
        ++calls;
        EXPECT_EQ(plan.landmarks.size(), chosen.size());
        EXPECT_EQ(capability.size(), chosen.size());
        std::vector<Refusal> out;
        for (std::size_t i = 0; i < chosen.size(); ++i)
            if ((chosen[i].position - topCentre).norm() < 1e-9) out.push_back({i, "screened", "refused by the test"});
        return out;
    };
    const Suggestion s = suggestLandmarks(problemFor(box, station), options);
    EXPECT_EQ(calls, 2u);
    ASSERT_EQ(s.landmarks.size(), 4u);
    std::size_t faces = 0;
    for (const auto& lm : s.landmarks) {
        EXPECT_GT((lm.candidate.position - topCentre).norm(), 1e-6) << lm.id;
        if (lm.candidate.kind == FeatureKind::Face) {
            ++faces;
            EXPECT_LT(lm.candidate.position.z(), 20.0 - 1e-9) << lm.id; // a side face's centre
        }
    }
    EXPECT_EQ(faces, 1u);
    ASSERT_FALSE(s.refused.empty());
    EXPECT_EQ(s.refused.back().rule, "screened");
    EXPECT_LT((s.refused.back().candidate.position - topCentre).norm(), 1e-9);
}

// The fragment spliced into a copy of the simulated line's part program loads
// (docs/part-program.md): every landmark where it was suggested, with its
// normal and tolerance.
TEST(LandmarkSuggest, FragmentLoadsAsThePartProgramsLandmarks)
{
    const auto meshFile = hgtest::sourceDir() / "config/sim/stepped-block.stl";
    const auto block = std::make_shared<const model::Solid>(model::loadMesh(meshFile));
    const auto station = simStation();
    const Suggestion s = suggestLandmarks(problemFor(block, station, 8, 4), {});
    hgtest::TempDir dir;
    hgtest::writeFile(dir / "part.yaml", "part: stepped-block\nmesh: " + meshFile.string() +
                                             "\noctree:\n  depth: 8\n  adjacency_depth: 4\n" +
                                             landmarksYaml(s, 0.4, {"suggested", "for the test"}));
    const model::PartProgram program = model::loadPartProgram(dir / "part.yaml");
    ASSERT_EQ(program.landmarks.size(), s.landmarks.size());
    for (std::size_t i = 0; i < s.landmarks.size(); ++i) {
        EXPECT_EQ(program.landmarks[i].id, s.landmarks[i].id);
        EXPECT_LT((program.landmarks[i].position - s.landmarks[i].candidate.position).norm(), 1e-6);
        EXPECT_LT(degreesBetween(program.landmarks[i].normal, s.landmarks[i].candidate.normal), 1e-3);
        EXPECT_FALSE(program.landmarks[i].normalFromMesh);
        EXPECT_DOUBLE_EQ(program.landmarks[i].toleranceMm, 0.4);
    }
}

} // namespace
} // namespace hg::plan
