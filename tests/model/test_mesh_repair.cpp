// Meshes as they come (docs/part-program.md): defective meshes made here from
// clean ones — faces written twice, two bodies exported overlapping as one
// soup, a vertex split by 0.01 mm, a shell turned inside out, a planar face
// folded over itself — are repaired, the report names each defect with its
// count, the repaired volume is the analytic one and `mesh_repair: strict`
// refuses each naming the defect. Meshes of the kind public CAD exports are
// (a hex nut and a spur gear whose faces meet themselves at the seam) load,
// repair and inspect to the verdicts of their clean twins.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <numbers>
#include <random>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <spdlog/fmt/fmt.h>

#include "hgtest/parts.h"
#include "hgtest/paths.h"
#include "hullgauge/common/error.h"
#include "hullgauge/inspect/inspector.h"
#include "hullgauge/inspect/part_map.h"
#include "hullgauge/model/csg.h"
#include "hullgauge/model/mesh_io.h"
#include "hullgauge/model/mesh_repair.h"
#include "hullgauge/model/part_program.h"
#include "hullgauge/model/primitives.h"

namespace hg::model {
namespace {

namespace fs = std::filesystem;
using Eigen::Vector2d;
using Eigen::Vector3d;
constexpr double kPi = std::numbers::pi;

// The box [0, 40] x [0, 30] x [0, 20] less a bore r = 6 about (20, 15): a
// 48-gon, so the volume is 24000 − 20 · (48/2) r² sin(2π/48) exactly.
constexpr int kBoreFacets = 48;
TriangleMesh boxWithBore()
{
    return difference(makeBox(Vector3d(0, 0, 0), Vector3d(40, 30, 20)),
                      makeCylinder(Vector3d(20, 15, -1), 6.0, 22.0, kBoreFacets));
}
double polygonArea(int n, double r)
{
    return 0.5 * n * r * r * std::sin(2.0 * kPi / n);
}
const double kBoxWithBoreVolume = 24000.0 - 20.0 * polygonArea(kBoreFacets, 6.0);

/// Vertex of `m` at `p` (exactly); -1 when none.
int vertexAt(const TriangleMesh& m, const Vector3d& p)
{
    for (std::size_t i = 0; i < m.vertices.size(); ++i)
        if (m.vertices[i] == p) return static_cast<int>(i);
    return -1;
}

/// Loads `mesh` written as a binary STL (every vertex once per facet, as exporters write it).
ImportedMesh exported(const hgtest::TempDir& dir, const TriangleMesh& mesh, const std::string& name,
                      const MeshRepairOptions& options = {})
{
    saveMesh(mesh, dir / name);
    return importMesh(dir / name, options);
}

/// The strict refusal of `mesh`, or "" when it was accepted.
std::string strictRefusal(const hgtest::TempDir& dir, const TriangleMesh& mesh, const std::string& name)
{
    try {
        exported(dir, mesh, name, {MeshRepairMode::Strict});
    } catch (const InputError& e) {
        EXPECT_EQ(e.field(), "mesh");
        return e.what();
    }
    return "";
}

// Binary STL rounds coordinates to single precision: volumes agree with the
// analytic ones to about 1e-7 of themselves.
constexpr double kStlVolumeTolerance = 1e-6;

TEST(MeshRepair, CleanMeshNeedsNoRepairAndPassesStrict)
{
    hgtest::TempDir dir;
    const ImportedMesh m = exported(dir, boxWithBore(), "clean.stl");
    EXPECT_TRUE(m.repair.clean()) << m.repair.repairs();
    EXPECT_EQ(m.repair.items().size(), 0u);
    EXPECT_NEAR(m.mesh.signedVolume(), kBoxWithBoreVolume, kStlVolumeTolerance * kBoxWithBoreVolume);
    EXPECT_EQ(strictRefusal(dir, boxWithBore(), "strict.stl"), "");
}

TEST(MeshRepair, DuplicatedFacesAreRemovedAndCounted)
{
    hgtest::TempDir dir;
    TriangleMesh m = boxWithBore();
    const std::size_t triangles = m.triangles.size();
    for (std::size_t i : {0u, 7u, 19u, 33u, 40u}) m.triangles.push_back(m.triangles[i]);
    // A face written a third time counts twice.
    m.triangles.push_back(m.triangles[7]);
    const ImportedMesh r = exported(dir, m, "dup.stl");
    EXPECT_EQ(r.repair.duplicateFaces, 6u);
    EXPECT_EQ(r.repair.opposedFaces + r.repair.selfIntersections + r.repair.mergedVertices + r.repair.flippedShells,
              0u);
    EXPECT_EQ(r.mesh.triangles.size(), triangles);
    EXPECT_NEAR(r.mesh.signedVolume(), kBoxWithBoreVolume, kStlVolumeTolerance * kBoxWithBoreVolume);
    EXPECT_NE(r.repair.repairs().find("6 duplicate faces removed"), std::string::npos) << r.repair.repairs();
    const std::string refusal = strictRefusal(dir, m, "dup-strict.stl");
    EXPECT_NE(refusal.find("dup-strict.stl: mesh: needs repair (mesh_repair: strict): 6 duplicate faces"),
              std::string::npos)
        << refusal;
}

// Two bodies exported as one soup, overlapping: the box with the bore and a
// 20 x 10 x 10 mm box half inside it. The part is their union:
// V = V(box with bore) + 2000 − 1000 mm³ (the overlap [30, 40] x [10, 20] x [5, 15] misses the bore).
TEST(MeshRepair, OverlappingBodiesAreAutorefinedIntoTheirUnion)
{
    hgtest::TempDir dir;
    TriangleMesh m = boxWithBore();
    m.append(makeBox(Vector3d(30, 10, 5), Vector3d(50, 20, 15)));
    const ImportedMesh r = exported(dir, m, "overlap.stl");
    EXPECT_GT(r.repair.selfIntersections, 0u);
    EXPECT_EQ(r.repair.autorefinedPairs, r.repair.selfIntersections);
    EXPECT_EQ(r.repair.retriangulatedFaces, 0u);
    const double expected = kBoxWithBoreVolume + 1000.0;
    EXPECT_NEAR(r.mesh.signedVolume(), expected, kStlVolumeTolerance * expected);
    EXPECT_TRUE(checkMesh(r.mesh).ok()) << checkMesh(r.mesh).problem();
    EXPECT_TRUE(r.mesh.bounds().isApprox(Eigen::AlignedBox3d(Vector3d(0, 0, 0), Vector3d(50, 30, 20))));
    EXPECT_NE(r.repair.repairs().find("self-intersecting triangle pairs removed"), std::string::npos);
    const std::string refusal = strictRefusal(dir, m, "overlap-strict.stl");
    EXPECT_NE(refusal.find(fmt::format("{} self-intersecting triangle pairs", r.repair.selfIntersections)),
              std::string::npos)
        << refusal;
}

// The top corner (40, 30, 20) written 0.01 mm off (+x) in the top face's
// triangles only: the two edges from it along the top face's border are
// open on both sides (4 open edges), a slit 0.01 mm wide.
TriangleMesh splitCorner(double byMm)
{
    TriangleMesh m = boxWithBore();
    const int corner = vertexAt(m, Vector3d(40, 30, 20));
    EXPECT_GE(corner, 0);
    const int copy = static_cast<int>(m.vertices.size());
    m.vertices.push_back(Vector3d(40 + byMm, 30, 20));
    for (std::size_t i = 0; i < m.triangles.size(); ++i)
        for (int& v : m.triangles[i])
            if (v == corner && m.faceNormal(i).z() > 0.5) v = copy;
    return m;
}

TEST(MeshRepair, GapOfAHundredthOfAMillimetreIsClosed)
{
    hgtest::TempDir dir;
    const TriangleMesh m = splitCorner(0.01);
    EXPECT_EQ(checkMesh(m).openEdges, 4u);
    const ImportedMesh r = exported(dir, m, "gap.stl");
    EXPECT_EQ(r.repair.mergedVertices, 1u);
    EXPECT_EQ(r.repair.closedEdges, 4u);
    EXPECT_DOUBLE_EQ(r.repair.gapToleranceMm, 0.02);
    // The vertex kept is the one written first (the side faces'), so the box is exact again.
    EXPECT_NEAR(r.mesh.signedVolume(), kBoxWithBoreVolume, kStlVolumeTolerance * kBoxWithBoreVolume);
    EXPECT_TRUE(r.mesh.bounds().isApprox(Eigen::AlignedBox3d(Vector3d(0, 0, 0), Vector3d(40, 30, 20))));
    EXPECT_NE(r.repair.repairs().find("1 vertex on an open edge within 0.02 mm merged, closing 4 open edges"),
              std::string::npos)
        << r.repair.repairs();
    const std::string refusal = strictRefusal(dir, m, "gap-strict.stl");
    EXPECT_NE(refusal.find("a gap: 1 vertex on an open edge within 0.02 mm of another"), std::string::npos) << refusal;
}

// A gap wider than the tolerance is a hole: refused, naming the open edges
// and the tolerance; a larger mesh_gap_mm closes it.
TEST(MeshRepair, GapWiderThanTheToleranceIsRefusedNamingTheOpenEdges)
{
    hgtest::TempDir dir;
    const TriangleMesh m = splitCorner(0.05);
    try {
        exported(dir, m, "wide.stl");
        FAIL() << "a 0.05 mm gap was closed with the 0.02 mm tolerance";
    } catch (const InputError& e) {
        const std::string what = e.what();
        EXPECT_NE(what.find("wide.stl: mesh: not closed: 4 open edges"), std::string::npos) << what;
        EXPECT_NE(what.find("gaps up to 0.02 mm are closed; this one is wider"), std::string::npos) << what;
    }
    MeshRepairOptions wider;
    wider.gapToleranceMm = 0.1;
    EXPECT_EQ(exported(dir, m, "wide.stl", wider).repair.mergedVertices, 1u);
}

// An open surface with a large hole (the bore's wall missing) cannot be read
// as a solid whatever the repair: refused naming the open edges.
TEST(MeshRepair, OpenSurfaceWithALargeHoleIsRefused)
{
    hgtest::TempDir dir;
    TriangleMesh m = boxWithBore();
    std::erase_if(m.triangles, [&](const std::array<int, 3>& t) {
        const Vector3d c = (m.vertices[t[0]] + m.vertices[t[1]] + m.vertices[t[2]]) / 3.0;
        return std::abs(std::hypot(c.x() - 20, c.y() - 15) - 6.0) < 0.5 && c.z() > 0.0 && c.z() < 20.0;
    });
    const std::size_t open = checkMesh(m).openEdges;
    EXPECT_GE(open, 2u * kBoreFacets); // at least the rims of the bore at z = 0 and z = 20
    try {
        exported(dir, m, "open.stl");
        FAIL() << "an open surface was accepted";
    } catch (const InputError& e) {
        const std::string what = e.what();
        EXPECT_NE(what.find(fmt::format("open.stl: mesh: not closed: {} open edges", open)), std::string::npos) << what;
    }
}

// Two shells: the box with the bore and a void [4, 8] x [4, 8] x [4, 8]
// inside its material, written as a void is (normals into the cavity, out of
// the material). Exported with the outer shell inside out: it is flipped, the
// void keeps its orientation. V = V(box with bore) − 64.
TEST(MeshRepair, FlippedShellIsTurnedOutward)
{
    hgtest::TempDir dir;
    TriangleMesh m = boxWithBore();
    m.flip();
    TriangleMesh voidShell = makeBox(Vector3d(4, 4, 4), Vector3d(8, 8, 8));
    voidShell.flip();
    m.append(voidShell);
    const ImportedMesh r = exported(dir, m, "flipped.stl");
    EXPECT_EQ(r.repair.flippedShells, 1u);
    EXPECT_EQ(r.repair.reorientedFaces, 0u);
    const double expected = kBoxWithBoreVolume - 64.0;
    EXPECT_NEAR(r.mesh.signedVolume(), expected, kStlVolumeTolerance * expected);
    EXPECT_NE(r.repair.repairs().find("1 shell oriented inward flipped"), std::string::npos) << r.repair.repairs();
    const std::string refusal = strictRefusal(dir, m, "flipped-strict.stl");
    EXPECT_NE(refusal.find("1 shell oriented inward"), std::string::npos) << refusal;
}

Vector3d centroid(const TriangleMesh& m, std::size_t i)
{
    const auto& t = m.triangles[i];
    return (m.vertices[t[0]] + m.vertices[t[1]] + m.vertices[t[2]]) / 3.0;
}

/// Two triangles sharing an edge whose corners all satisfy `on` (a face of the part).
std::pair<std::size_t, std::size_t> neighboursWhere(const TriangleMesh& m,
                                                    const std::function<bool(const Vector3d&)>& on)
{
    std::vector<std::size_t> face;
    for (std::size_t i = 0; i < m.triangles.size(); ++i)
        if (std::all_of(m.triangles[i].begin(), m.triangles[i].end(), [&](int v) { return on(m.vertices[v]); }))
            face.push_back(i);
    for (std::size_t a : face)
        for (std::size_t b : face) {
            int shared = 0;
            for (int v : m.triangles[a]) shared += std::count(m.triangles[b].begin(), m.triangles[b].end(), v);
            if (a != b && shared == 2) return {a, b};
        }
    ADD_FAILURE() << "no two triangles of the face share an edge";
    return {0, 0};
}

/// Replaces triangle `i` (a, b, c) by the fan (E, b, c), (a, E, c), (a, b, E)
/// about `e`, a point of its plane outside it: the three add up to (a, b, c)
/// but fold over each other and over the neighbours E lies in.
void foldTriangle(TriangleMesh& m, std::size_t i, const Vector3d& e)
{
    const int ei = static_cast<int>(m.vertices.size());
    m.vertices.push_back(e);
    const auto [a, b, c] = m.triangles[i];
    m.triangles[i] = {ei, b, c};
    m.triangles.push_back({a, ei, c});
    m.triangles.push_back({a, b, ei});
}

// The bottom face (z = 0) of the box with the bore: one of its triangles
// folded about a point of the face outside it.
TEST(MeshRepair, PlanarFaceFoldedOverItselfIsRetriangulated)
{
    hgtest::TempDir dir;
    TriangleMesh m = boxWithBore();
    const auto [folded, neighbour] = neighboursWhere(m, [](const Vector3d& p) { return p.z() == 0.0; });
    foldTriangle(m, folded, centroid(m, neighbour));
    const ImportedMesh r = exported(dir, m, "fold.stl");
    EXPECT_EQ(r.repair.retriangulatedFaces, 1u);
    EXPECT_GT(r.repair.selfIntersections, 0u);
    EXPECT_EQ(r.repair.autorefinedPairs, 0u);
    EXPECT_NEAR(r.mesh.signedVolume(), kBoxWithBoreVolume, kStlVolumeTolerance * kBoxWithBoreVolume);
    EXPECT_NEAR(r.mesh.area(), boxWithBore().area(), 1e-6 * r.mesh.area());
    const std::string refusal = strictRefusal(dir, m, "fold-strict.stl");
    EXPECT_NE(refusal.find("1 planar face overlapping itself"), std::string::npos) << refusal;
}

// Two bodies exported touching along a face: the box [0, 10]³ and [10, 20] x
// [0, 10]², each closed; the face x = 10 is written twice, opposite ways. The
// wall of no thickness goes, the union (2000 mm³) stays.
TEST(MeshRepair, TouchingBodiesLoseTheWallBetweenThem)
{
    hgtest::TempDir dir;
    TriangleMesh m = makeBox(Vector3d(0, 0, 0), Vector3d(10, 10, 10));
    TriangleMesh right = makeBox(Vector3d(10, 0, 0), Vector3d(20, 10, 10));
    // makeBox triangulates x = 10 of the right box as it does x = 10 of the left one, mirrored: the same diagonal.
    m.append(right);
    const ImportedMesh r = exported(dir, m, "touching.stl");
    EXPECT_EQ(r.repair.opposedFaces, 4u);
    EXPECT_NEAR(r.mesh.signedVolume(), 2000.0, 1e-9);
    EXPECT_TRUE(checkMesh(r.mesh).ok()) << checkMesh(r.mesh).problem();
}

// ---------------------------------------------------------------------------
// Held-out style: meshes shaped as public CAD exports are.

/// A hex nut M8-like: hexagon of circumradius 7.5 mm (corners at 30° + k·60°,
/// flats at x = ±7.5 cos 30°), 6 mm high, a bore r = 3.2 mm (32 facets).
constexpr double kNutR = 7.5, kNutH = 6.0, kNutBore = 3.2;
constexpr int kNutBoreFacets = 32;
TriangleMesh nut()
{
    std::vector<Vector2d> hexagon;
    for (int k = 0; k < 6; ++k) {
        const double a = kPi / 6.0 + k * kPi / 3.0;
        hexagon.emplace_back(kNutR * std::cos(a), kNutR * std::sin(a));
    }
    // The bore flush with both faces, so each of its facets stays the two triangles makeCylinder made.
    return difference(makePrism(hexagon, 0.0, kNutH), makeCylinder(Vector3d(0, 0, 0), kNutBore, kNutH, kNutBoreFacets));
}
const double kNutVolume = (1.5 * std::sqrt(3.0) * kNutR * kNutR - polygonArea(kNutBoreFacets, kNutBore)) * kNutH;

/// Triangles of `m` whose corners all satisfy `on`.
std::vector<std::size_t> trianglesWhere(const TriangleMesh& m, const std::function<bool(const Vector3d&)>& on)
{
    std::vector<std::size_t> out;
    for (std::size_t i = 0; i < m.triangles.size(); ++i)
        if (std::all_of(m.triangles[i].begin(), m.triangles[i].end(), [&](int v) { return on(m.vertices[v]); }))
            out.push_back(i);
    return out;
}

/// Writes the planar quad facet made of `facet`'s triangles once more with
/// the other diagonal, oriented as the facet is (and, with `exactCopy`, once
/// more as it is): the export meeting itself at a seam.
void rewriteFacet(TriangleMesh& m, const std::vector<std::size_t>& facet, bool exactCopy)
{
    std::vector<int> corners;
    Vector3d normal = Vector3d::Zero();
    for (std::size_t i : facet) {
        normal += m.faceNormal(i);
        for (int v : m.triangles[i])
            if (std::find(corners.begin(), corners.end(), v) == corners.end()) corners.push_back(v);
        if (exactCopy) m.triangles.push_back(m.triangles[i]);
    }
    ASSERT_EQ(corners.size(), 4u);
    // Order the corners around the facet's centre, counter-clockwise about its normal.
    Vector3d centre = Vector3d::Zero();
    for (int v : corners) centre += m.vertices[v] / 4.0;
    const Vector3d u = (m.vertices[corners[0]] - centre).normalized(), w = normal.normalized().cross(u);
    std::sort(corners.begin(), corners.end(), [&](int a, int b) {
        const Vector3d pa = m.vertices[a] - centre, pb = m.vertices[b] - centre;
        return std::atan2(pa.dot(w), pa.dot(u)) < std::atan2(pb.dot(w), pb.dot(u));
    });
    // The diagonal the facet does not use.
    const bool usesFirst = std::any_of(facet.begin(), facet.end(), [&](std::size_t i) {
        const auto& t = m.triangles[i];
        return std::count(t.begin(), t.end(), corners[0]) && std::count(t.begin(), t.end(), corners[2]);
    });
    const int s = usesFirst ? 1 : 0;
    m.triangles.push_back({corners[s], corners[s + 1], corners[(s + 2) % 4]});
    m.triangles.push_back({corners[s], corners[(s + 2) % 4], corners[(s + 3) % 4]});
}

/// The nut as exported: the bore's seam facet (between 0° and 11.25°)
/// written three times (once more as it is, once with the other diagonal),
/// and a triangle of the flat x = 7.5 cos 30° folded over its neighbour.
TriangleMesh nutAsExported()
{
    TriangleMesh m = nut();
    const double step = 2.0 * kPi / kNutBoreFacets;
    const auto seam = trianglesWhere(m, [&](const Vector3d& p) {
        const double a = std::atan2(p.y(), p.x());
        return std::abs(std::hypot(p.x(), p.y()) - kNutBore) < 1e-9 && a > -1e-9 && a < step + 1e-9;
    });
    EXPECT_EQ(seam.size(), 2u);
    rewriteFacet(m, seam, true);
    const double flat = kNutR * std::cos(kPi / 6.0);
    const auto side = trianglesWhere(m, [&](const Vector3d& p) { return std::abs(p.x() - flat) < 1e-9; });
    EXPECT_EQ(side.size(), 2u);
    // E: the centroid of the other triangle of the flat, outside the folded one.
    foldTriangle(m, side[0], centroid(m, side[1]));
    return m;
}

/// A spur gear: 12 trapezoid teeth between the root circle r = 10 and the
/// tip r = 12 mm, 5 mm thick, a bore r = 3 mm (24 facets).
constexpr int kTeeth = 12, kGearBoreFacets = 24;
constexpr double kGearThickness = 5.0, kGearBore = 3.0;
std::vector<Vector2d> gearOutline()
{
    std::vector<Vector2d> outline;
    const double pitch = 2.0 * kPi / kTeeth;
    for (int k = 0; k < kTeeth; ++k)
        for (const auto& [r, a] : {std::pair{10.0, -0.25}, {12.0, -0.1}, {12.0, 0.1}, {10.0, 0.25}})
            outline.emplace_back(r * std::cos((k + a) * pitch), r * std::sin((k + a) * pitch));
    return outline;
}
TriangleMesh gear()
{
    return difference(makePrism(gearOutline(), 0.0, kGearThickness),
                      makeCylinder(Vector3d(0, 0, -1), kGearBore, kGearThickness + 2.0, kGearBoreFacets));
}
double gearVolume()
{
    const auto p = gearOutline();
    double twice = 0.0; // shoelace
    for (std::size_t i = 0; i < p.size(); ++i) {
        const Vector2d& a = p[i];
        const Vector2d& b = p[(i + 1) % p.size()];
        twice += a.x() * b.y() - a.y() * b.x();
    }
    return (0.5 * twice - polygonArea(kGearBoreFacets, kGearBore)) * kGearThickness;
}

/// The gear as exported: the tip face of tooth 0 (the seam at 0°) written a
/// second time with the other diagonal, a flank of tooth 6 written twice as
/// it is, and a radial wall of no thickness between teeth 0 and 1 (at 15°,
/// r 4..9 mm, both sides written) where two bodies of the model met.
TriangleMesh gearAsExported()
{
    TriangleMesh m = gear();
    const double tipX = 12.0 * std::cos(0.1 * 2.0 * kPi / kTeeth);
    const auto tipFace = trianglesWhere(
        m, [&](const Vector3d& p) { return std::abs(std::hypot(p.x(), p.y()) - 12.0) < 1e-9 && p.x() > tipX - 1e-9; });
    EXPECT_EQ(tipFace.size(), 2u);
    rewriteFacet(m, tipFace, false);
    // Tooth 6 points along −x: its flank from the root at 5.75 pitches to the tip at 5.9 pitches.
    const double pitch = 2.0 * kPi / kTeeth;
    const Vector2d root(10.0 * std::cos(5.75 * pitch), 10.0 * std::sin(5.75 * pitch));
    const Vector2d tip(12.0 * std::cos(5.9 * pitch), 12.0 * std::sin(5.9 * pitch));
    const auto flank = trianglesWhere(m, [&](const Vector3d& p) {
        const Vector2d q(p.x(), p.y());
        return (q - root).norm() < 1e-9 || (q - tip).norm() < 1e-9;
    });
    EXPECT_EQ(flank.size(), 2u);
    for (std::size_t i : flank) m.triangles.push_back(m.triangles[i]);
    const double a = kPi / 12.0;
    const int w = static_cast<int>(m.vertices.size());
    for (const auto& [r, z] : {std::pair{4.0, 0.0}, {9.0, 0.0}, {9.0, kGearThickness}, {4.0, kGearThickness}})
        m.vertices.emplace_back(r * std::cos(a), r * std::sin(a), z);
    for (const std::array<int, 3>& t : {std::array{0, 1, 2}, {0, 2, 3}}) {
        m.triangles.push_back({w + t[0], w + t[1], w + t[2]});
        m.triangles.push_back({w + t[0], w + t[2], w + t[1]});
    }
    return m;
}

TEST(MeshRepairHeldOut, HexNutWhoseFacesMeetThemselvesLoadsAsItsSolid)
{
    hgtest::TempDir dir;
    const ImportedMesh r = exported(dir, nutAsExported(), "nut.stl");
    std::cout << "nut: " << r.repair.repairs() << "\n";
    EXPECT_EQ(r.repair.duplicateFaces, 2u);
    EXPECT_EQ(r.repair.retriangulatedFaces, 2u); // the bore's seam facet and the folded flat
    EXPECT_GT(r.repair.selfIntersections, 0u);
    EXPECT_EQ(r.repair.autorefinedPairs + r.repair.opposedFaces + r.repair.mergedVertices + r.repair.flippedShells, 0u);
    EXPECT_NEAR(r.mesh.signedVolume(), kNutVolume, kStlVolumeTolerance * kNutVolume);
    EXPECT_TRUE(checkMesh(r.mesh).ok());
}

TEST(MeshRepairHeldOut, SpurGearWithCoincidentFacesLoadsAsItsSolid)
{
    hgtest::TempDir dir;
    const ImportedMesh r = exported(dir, gearAsExported(), "gear.stl");
    std::cout << "gear: " << r.repair.repairs() << "\n";
    EXPECT_EQ(r.repair.duplicateFaces, 2u);
    EXPECT_EQ(r.repair.opposedFaces, 4u);
    EXPECT_EQ(r.repair.retriangulatedFaces, 1u);
    EXPECT_EQ(r.repair.autorefinedPairs + r.repair.mergedVertices + r.repair.flippedShells, 0u);
    const double volume = gearVolume();
    EXPECT_NEAR(r.mesh.signedVolume(), volume, kStlVolumeTolerance * volume);
    EXPECT_TRUE(checkMesh(r.mesh).ok());
    const std::string refusal = strictRefusal(dir, gearAsExported(), "gear-strict.stl");
    EXPECT_NE(refusal.find("2 duplicate faces, 4 coincident faces of opposite orientation, 1 planar face "
                           "overlapping itself"),
              std::string::npos)
        << refusal;
}

// ---------------------------------------------------------------------------
// Inspected like the clean twin: the same frames (rendered from the part as
// made) inspected with the program of the clean mesh and with that of the
// repaired one give the same status at every landmark — ok on the part as
// designed, out of tolerance where a face was made 1 mm low. The nut's
// depth 7 and the gear's depth 8 put ΔV at 0.15 and 0.10 mm (the default cube
// with 12 adjacency layers, which measure up to 1.77 and 1.25 mm); the
// tolerance ±0.4 mm lies beyond 2ΔV of both the nominal offset 0 and the
// defect's 1 mm.

std::string programYaml(const std::string& mesh, int depth, const std::string& landmarks)
{
    return "part: p\nmesh: " + mesh + "\noctree:\n  depth: " + std::to_string(depth) +
           "\n  adjacency_depth: 12\nlandmarks:\n" + landmarks;
}

std::string landmarkYaml(const std::string& id, const Vector3d& p)
{
    std::ostringstream s;
    s.precision(17);
    s << "  - {id: " << id << ", position: [" << p.x() << ", " << p.y() << ", " << p.z() << "], tolerance_mm: 0.4}\n";
    return s.str();
}

std::vector<inspect::LandmarkStatus> statuses(const PartProgram& program,
                                              const std::vector<inspect::CapturedView>& views)
{
    const inspect::InspectionMap map = inspect::buildInspectionMap(program, 1);
    const inspect::InspectionResult result = inspect::Inspector(map).inspect(views, {});
    std::vector<inspect::LandmarkStatus> out;
    for (const auto& lm : result.landmarks) out.push_back(lm.status);
    return out;
}

/// Loads the clean and the as-exported mesh under the same landmarks, and
/// inspects `asMade` (offsets per landmark) and the part as designed from
/// grazing views of the clean program's landmarks.
void expectInspectedLikeTheCleanTwin(const TriangleMesh& clean, const TriangleMesh& asExported, int depth,
                                     const std::string& landmarks, const hgtest::PartAsMade& lowered,
                                     const std::string& lowLandmark)
{
    hgtest::TempDir dir;
    saveMesh(clean, dir / "clean.stl");
    saveMesh(asExported, dir / "exported.stl");
    hgtest::writeFile(dir / "clean.yaml", programYaml("clean.stl", depth, landmarks));
    hgtest::writeFile(dir / "exported.yaml", programYaml("exported.stl", depth, landmarks));
    const PartProgram cleanProgram = loadPartProgram(dir / "clean.yaml");
    const PartProgram repaired = loadPartProgram(dir / "exported.yaml");
    EXPECT_FALSE(repaired.meshRepairReport.clean());
    EXPECT_EQ(repaired.octree.cubeSize, cleanProgram.octree.cubeSize); // the same bounds, so the same ΔV
    hgtest::TestPart part;
    part.name = "clean";
    part.mesh = cleanProgram.solid->mesh();
    part.solid = cleanProgram.solid;
    part.landmarks = inspect::mapLandmarks(cleanProgram);
    std::mt19937_64 rng(11);
    const hgtest::PartAsMade designed = hgtest::asDesigned(part);
    for (const hgtest::PartAsMade* made : {&designed, &lowered}) {
        const auto cameras = hgtest::grazingViewSet(part, made, 2, rng);
        const auto views = hgtest::renderViews(made->mesh, cameras, 2.0, 5);
        const auto expected = statuses(cleanProgram, views);
        EXPECT_EQ(statuses(repaired, views), expected) << made->name;
        for (std::size_t i = 0; i < part.landmarks.size(); ++i) {
            const bool low = made == &lowered && part.landmarks[i].id == lowLandmark;
            const auto& id = part.landmarks[i].id;
            if (low)
                EXPECT_EQ(expected[i], inspect::LandmarkStatus::OutOfTolerance) << made->name << " " << id;
            else
                EXPECT_EQ(expected[i], inspect::LandmarkStatus::Ok)
                    << made->name << " " << id << ": " << inspect::toString(expected[i]);
        }
    }
}

TEST(MeshRepairHeldOut, HexNutIsInspectedLikeItsCleanTwin)
{
    const double flat = kNutR * std::cos(kPi / 6.0);
    const std::string landmarks = landmarkYaml("top", Vector3d(5, 0.5, kNutH)) +
                                  landmarkYaml("flat", Vector3d(flat, 0.5, 3)) +
                                  landmarkYaml("bottom", Vector3d(-5, 0.5, 0));
    hgtest::PartAsMade low{
        "top-low", difference(nut(), makeBox(Vector3d(-10, -10, kNutH - 1.0), Vector3d(10, 10, 9))), {-1.0, 0.0, 0.0}};
    expectInspectedLikeTheCleanTwin(nut(), nutAsExported(), 7, landmarks, low, "top");
}

TEST(MeshRepairHeldOut, SpurGearIsInspectedLikeItsCleanTwin)
{
    const std::string landmarks = landmarkYaml("top", Vector3d(7, 0.5, kGearThickness)) +
                                  landmarkYaml("tip", Vector3d(12.0 * std::cos(0.2 * kPi / kTeeth), 0.3, 2.5)) +
                                  landmarkYaml("bottom", Vector3d(-7, 0.5, 0));
    hgtest::PartAsMade low{"top-low",
                           difference(gear(), makeBox(Vector3d(-13, -13, kGearThickness - 1.0), Vector3d(13, 13, 9))),
                           {-1.0, 0.0, 0.0}};
    expectInspectedLikeTheCleanTwin(gear(), gearAsExported(), 8, landmarks, low, "top");
}

// Found by the bounded fuzz runs (docs/fuzzing.md): the stepped block's PLY
// with faces mutated so that one face's outline lies on a line (its
// re-triangulation had no two-dimensional inside to walk: a null face), and
// an STL with coordinates near 1e308 (the gap search's grid cells overflowed).
// Both are read to a mesh or a refusal naming the file, never a crash.
const std::uint8_t kPlyFlatOutline[] = {
    0x70, 0x6c, 0x79, 0x0a, 0x66, 0x6f, 0x72, 0x6d, 0x61, 0x74, 0x20, 0x62, 0x69, 0x6e, 0x61, 0x72, 0x79, 0x5f, 0x6c,
    0x69, 0x74, 0x74, 0x6c, 0x65, 0x5f, 0x65, 0x6e, 0x64, 0x69, 0x61, 0x6e, 0x20, 0x31, 0x2e, 0x30, 0x0a, 0x63, 0x6f,
    0x6d, 0x6d, 0x65, 0x6e, 0x74, 0x20, 0x73, 0x74, 0x67, 0x70, 0x70, 0x65, 0x64, 0x20, 0x62, 0x6c, 0x6f, 0x63, 0x6b,
    0x0a, 0x65, 0x6c, 0x65, 0x6d, 0x65, 0x6e, 0x74, 0x20, 0x76, 0x65, 0x72, 0x74, 0x65, 0x78, 0x20, 0x31, 0x32, 0x0a,
    0x70, 0x72, 0x6f, 0x70, 0x65, 0x72, 0x74, 0x79, 0x20, 0x66, 0x6c, 0x6f, 0x61, 0x74, 0x20, 0x78, 0x0a, 0x70, 0x72,
    0x6f, 0x70, 0x65, 0x72, 0x74, 0x79, 0x20, 0x66, 0x6c, 0x6f, 0x61, 0x74, 0x20, 0x79, 0x0a, 0x70, 0x72, 0x6f, 0x70,
    0x65, 0x72, 0x74, 0x79, 0x20, 0x66, 0x6c, 0x6f, 0x61, 0x74, 0x20, 0x7a, 0x0a, 0x65, 0x6c, 0x65, 0x6d, 0x65, 0x6e,
    0x74, 0x20, 0x66, 0x61, 0x63, 0x65, 0x20, 0x32, 0x30, 0x0a, 0x70, 0x72, 0x6f, 0x70, 0x65, 0x72, 0x74, 0x79, 0x20,
    0x6c, 0x69, 0x73, 0x74, 0x20, 0x75, 0x63, 0x68, 0x61, 0x72, 0x20, 0x69, 0x6e, 0x74, 0x20, 0x76, 0x65, 0x72, 0x74,
    0x65, 0x78, 0x5f, 0x69, 0x6e, 0x64, 0x69, 0x63, 0x65, 0x73, 0x0a, 0x65, 0x6e, 0x64, 0x5f, 0x68, 0x65, 0x61, 0x64,
    0x65, 0x72, 0x0a, 0x00, 0x00, 0xf0, 0xc1, 0x00, 0x00, 0xa0, 0xc1, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xf0, 0x41,
    0x00, 0x00, 0xa0, 0xc1, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xf0, 0x41, 0x00, 0x00, 0xa0, 0xc1, 0x00, 0x00, 0x70,
    0x41, 0x00, 0x00, 0xf0, 0xc1, 0x00, 0x00, 0xa0, 0x41, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xf0, 0x41, 0x00, 0x00,
    0xa0, 0x41, 0x00, 0x00, 0x70, 0x41, 0x00, 0x00, 0xf0, 0x41, 0x00, 0x00, 0xa0, 0x41, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x00, 0x00, 0x00, 0xc1, 0x70, 0xa0, 0x00, 0x00, 0x41, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xa0, 0x41,
    0x00, 0x00, 0x70, 0x41, 0x00, 0x00, 0xf0, 0xc1, 0x00, 0x00, 0xa0, 0xc1, 0x00, 0x00, 0xf0, 0x41, 0x00, 0x00, 0xf0,
    0xc1, 0x00, 0x00, 0xa0, 0x41, 0x00, 0x00, 0xf0, 0x41, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xa0, 0xc1, 0x00, 0x00,
    0xf0, 0x41, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xa0, 0x41, 0x00, 0x00, 0xf0, 0x41, 0x03, 0x00, 0x00, 0x00, 0x00,
    0x01, 0x00, 0x00, 0x00, 0x02, 0x00, 0x00, 0x00, 0x03, 0x03, 0x00, 0x00, 0x00, 0x04, 0x00, 0x00, 0x00, 0x05, 0x00,
    0x00, 0x00, 0x03, 0x00, 0x00, 0x00, 0x00, 0x02, 0x00, 0x00, 0x00, 0x06, 0x00, 0x00, 0x00, 0x03, 0x03, 0x00, 0x00,
    0x00, 0x07, 0x00, 0x00, 0x00, 0x04, 0x00, 0x00, 0x00, 0x03, 0x08, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x06,
    0x00, 0x00, 0x00, 0x03, 0x09, 0x00, 0x00, 0x00, 0x07, 0x00, 0x00, 0x00, 0x03, 0x00, 0x00, 0x00, 0x03, 0x06, 0x00,
    0x00, 0x00, 0x0a, 0x00, 0x00, 0x00, 0x08, 0x00, 0x00, 0x00, 0x03, 0x07, 0x00, 0x00, 0x00, 0x09, 0x00, 0x00, 0x00,
    0x0b, 0x00, 0x00, 0x00, 0x03, 0x00, 0x00, 0x00, 0x00, 0x03, 0x00, 0x00, 0x00, 0x05, 0x00, 0x00, 0x00, 0x03, 0x00,
    0x00, 0x00, 0x00, 0x05, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x03, 0x01, 0x00, 0x00, 0x00, 0x05, 0x00, 0x00,
    0x00, 0x04, 0x00, 0x00, 0x00, 0x03, 0x01, 0x00, 0x00, 0x00, 0x04, 0x00, 0x00, 0x00, 0x02, 0x00, 0x00, 0x00, 0x03,
    0x02, 0x00, 0x00, 0x00, 0x04, 0x00, 0x00, 0x00, 0x07, 0x00, 0x00, 0x00, 0x03, 0x02, 0x00, 0x00, 0x00, 0x07, 0x00,
    0x00, 0x00, 0x06, 0x00, 0x00, 0x00, 0x03, 0x06, 0x00, 0x00, 0x00, 0x07, 0x00, 0x00, 0x00, 0x0b, 0x00, 0x00, 0x00,
    0x03, 0x06, 0x00, 0x00, 0x00, 0x0b, 0x00, 0x00, 0x00, 0x0a, 0x00, 0x00, 0x00, 0x03, 0x0a, 0x00, 0x00, 0x00, 0x0b,
    0x00, 0x00, 0x00, 0x09, 0x00, 0x00, 0x00, 0x03, 0x0a, 0x00, 0x00, 0x00, 0x09, 0x00, 0x00, 0x00, 0x08, 0x00, 0x00,
    0x00, 0x03, 0x08, 0x00, 0x00, 0x00, 0x09, 0x00, 0x00, 0x00, 0x03, 0x00, 0x00, 0x00, 0x03, 0x08, 0x00, 0x00, 0x00,
    0x03, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
};
const std::uint8_t kStlHugeCoordinates[] = {
    0x73, 0x74, 0x65, 0x70, 0x70, 0x65, 0x64, 0x2d, 0x62, 0x6c, 0x6f, 0x63, 0x6b, 0x20, 0x6e, 0x6f, 0x6d, 0x69, 0x6e,
    0x61, 0x6c, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x00, 0x00, 0x14, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x80, 0xbf, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x00, 0xf0, 0xc1, 0x00, 0x00, 0xa0, 0xc1, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xf0, 0x41, 0x00, 0x00,
    0xa0, 0xc1, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xf0, 0x41, 0x00, 0x00, 0xa0, 0xc1, 0x00, 0x00, 0x70, 0x41, 0x00,
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x80, 0x3f, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xf0, 0xc1, 0x00, 0x00,
    0xa0, 0x41, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xf0, 0x41, 0x00, 0x00, 0xa0, 0x41, 0x00, 0x00, 0x70, 0x41, 0x00,
    0x00, 0xf0, 0x41, 0x00, 0x00, 0xa0, 0x41, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x80, 0xbf, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xf0, 0xc1, 0x00, 0x00, 0xa0, 0xc1, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x00, 0xf0, 0x41, 0x00, 0x00, 0xa0, 0xc1, 0x00, 0x00, 0x70, 0x41, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xa0, 0xc1,
    0x00, 0x00, 0x70, 0x41, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x80, 0x3f, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x00, 0xf0, 0xc1, 0x00, 0x00, 0xa0, 0x41, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xa0, 0x41,
    0x00, 0x00, 0x70, 0x41, 0x00, 0x00, 0xf0, 0x41, 0x00, 0x00, 0xa0, 0x41, 0x00, 0x00, 0x70, 0x41, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x00, 0x00, 0x00, 0x80, 0xbf, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xf0, 0xc1, 0x00, 0x00, 0xa0, 0xc1,
    0x00, 0x00, 0xf0, 0x41, 0x00, 0x00, 0xf0, 0xc1, 0x00, 0x00, 0xa0, 0xc1, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x00, 0xa0, 0xc1, 0x00, 0x00, 0x70, 0x41, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x80, 0x3f,
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xf0, 0xc1, 0x00, 0x00, 0xa0, 0x41, 0x00, 0x00, 0xf0, 0x41, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x00, 0xa0, 0x41, 0x00, 0x00, 0x70, 0x41, 0x00, 0x00, 0xf0, 0xc1, 0x00, 0x00, 0xa0, 0x41, 0x00, 0x00,
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x80, 0xbf, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x00, 0xa0, 0xc1, 0x00, 0x00, 0x70, 0x41, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xa0, 0xc1, 0x00, 0x00,
    0xf0, 0x41, 0x00, 0x00, 0xf0, 0xc1, 0x00, 0x00, 0xa0, 0xc1, 0x00, 0x00, 0xf0, 0x41, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x00, 0x80, 0x3f, 0x00, 0x00, 0x00, 0x80, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xa0, 0x41, 0x00, 0x00,
    0x70, 0x41, 0x00, 0x00, 0xf0, 0xc1, 0x00, 0x00, 0xa0, 0x41, 0x00, 0x00, 0xf0, 0x41, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x00, 0xa0, 0x41, 0x00, 0x00, 0xf0, 0x41, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x80, 0xbf, 0x00, 0x00, 0xf0, 0xc1, 0x00, 0x00, 0xa0, 0xc1, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xf0, 0xc1, 0x00,
    0x00, 0xa0, 0x41, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xf0, 0x41, 0x00, 0x00, 0xa0, 0x41, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x80, 0xbf, 0x00, 0x00, 0xf0, 0xc1, 0x00,
    0x00, 0xa0, 0xc1, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xf0, 0x41, 0x00, 0x00, 0xa0, 0x41, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x00, 0xf0, 0x41, 0x00, 0x00, 0xa0, 0xc1, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x80, 0x3f, 0x00,
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xf0, 0x41, 0x00, 0x00, 0xa0, 0xc1, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x00, 0xf0, 0x41, 0x00, 0x00, 0xa0, 0x41, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xf0, 0x41, 0x00, 0x00, 0xa0,
    0x41, 0x00, 0x00, 0x70, 0x41, 0x00, 0x00, 0x00, 0x00, 0x80, 0x3f, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x00, 0xf0, 0x41, 0x00, 0x00, 0xa0, 0xc1, 0x00, 0x00, 0x00, 0x6e, 0x61, 0x6e, 0x00, 0x00, 0x00, 0xf0, 0x41,
    0x00, 0x00, 0xa0, 0x41, 0x00, 0x00, 0x70, 0x41, 0x00, 0x00, 0xf0, 0x41, 0x00, 0x00, 0xa0, 0xc1, 0x00, 0x00, 0x70,
    0x41, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x80, 0x00, 0x00, 0x80, 0x3f, 0x00, 0x00, 0xf0, 0x41,
    0x00, 0x00, 0xa0, 0xc1, 0x00, 0x00, 0x70, 0x41, 0x00, 0x00, 0xf0, 0x41, 0x00, 0x00, 0xa0, 0x41, 0x00, 0x00, 0x70,
    0x41, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xa0, 0x41, 0x00, 0x00, 0x70, 0x41, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x80, 0x3f, 0x00, 0x00, 0xf0, 0x41, 0x00, 0x00, 0xa0, 0xc1, 0x00, 0x00, 0x70,
    0x41, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xa0, 0x41, 0x00, 0x00, 0x70, 0x41, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0xa0, 0xc1, 0x00, 0x00, 0x70, 0x41, 0x00, 0x00, 0x00, 0x00, 0x80, 0x3f, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xa0, 0xc1, 0x00, 0x00, 0x70, 0x41, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0xa0, 0x41, 0x00, 0x00, 0x70, 0x41, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xa0, 0x41, 0x00, 0x00, 0xf0, 0x41, 0x00,
    0x00, 0x00, 0x00, 0x80, 0x3f, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0xa0, 0xc1, 0x00, 0x00, 0x70, 0x41, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xa0, 0x41, 0x00, 0x00, 0xf0, 0x41, 0x00,
    0x00, 0x00, 0x00, 0x00, 0x00, 0xa0, 0xc1, 0x00, 0x00, 0xf0, 0x41, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x80, 0x00, 0x00, 0x80, 0x3f, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xa0, 0xc1, 0x00, 0x00, 0xf0, 0x41, 0x00,
    0x00, 0x00, 0x00, 0x00, 0x00, 0xa0, 0x41, 0x00, 0x00, 0xf0, 0x41, 0x00, 0x00, 0xf0, 0xc1, 0x00, 0x00, 0xa0, 0x41,
    0x00, 0x00, 0xf0, 0x41, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x80, 0x3f, 0x00,
    0x00, 0x00, 0x00, 0x00, 0x00, 0xa0, 0xc1, 0x00, 0x00, 0xf0, 0x41, 0x00, 0x00, 0xf0, 0xc1, 0x00, 0x00, 0xa0, 0x41,
    0x00, 0x00, 0xf0, 0x41, 0x00, 0x00, 0xf0, 0xc1, 0x00, 0x00, 0xa0, 0xc1, 0x00, 0x00, 0xf0, 0x41, 0x00, 0x00, 0x00,
    0x00, 0x80, 0xbf, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xf0, 0xc1, 0x00, 0x00, 0xa0, 0xc1,
    0x00, 0x00, 0xf0, 0x41, 0x00, 0x00, 0xf0, 0xc1, 0x00, 0x00, 0xa0, 0x41, 0x00, 0x00, 0xf0, 0x41, 0x00, 0x00, 0xf0,
    0xc1, 0x00, 0x00, 0xa0, 0x41, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x80, 0xbf, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xf0, 0xc1, 0x00, 0x00, 0xa0, 0xc1, 0x00, 0x00, 0xf0, 0x41, 0x00, 0x00, 0xf0,
    0xc1, 0x00, 0x00, 0xa0, 0x41, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xf0, 0xc1, 0x00, 0x00, 0xa0, 0xc1, 0x00, 0x00,
    0x00, 0x00, 0x00, 0x00,
};

// An OBJ whose polygon's corners lie on a line (found by the fuzz runs: CGAL's
// triangulation's precondition threw through the reader).
const std::uint8_t kObjDegeneratePolygon[] = {
    0x76, 0x20, 0x30, 0x20, 0x30, 0x20, 0x30, 0x0a, 0x76, 0x20, 0x31, 0x20, 0x30, 0x20, 0x30, 0x0a, 0x76, 0x20,
    0x30, 0x20, 0x31, 0x20, 0x31, 0x0a, 0x76, 0x20, 0x30, 0x20, 0x30, 0x20, 0x31, 0x0a, 0x66, 0x20, 0x2d, 0x34,
    0x20, 0x2d, 0x32, 0x20, 0x2d, 0x33, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x42, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x0b, 0x66, 0x20, 0x2d, 0x34,
    0x20, 0x2d, 0x33, 0x20, 0x2d, 0x31, 0x0a, 0x66, 0x20, 0x2d, 0x34, 0x20, 0x2d, 0x31, 0x20, 0x2d, 0x32, 0x0a,
    0x66, 0x20, 0x2d, 0x33, 0x20, 0x2d, 0x32, 0x20, 0x2d, 0x31, 0x0a,
};

void expectReadOrNamed(const std::uint8_t* bytes, std::size_t size, const std::string& name)
{
    hgtest::TempDir dir;
    const auto file = dir / name;
    std::ofstream(file, std::ios::binary)
        .write(reinterpret_cast<const char*>(bytes), static_cast<std::streamsize>(size));
    try {
        (void)importMesh(file);
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
    }
}

TEST(MeshRepairFuzzed, AFaceWhoseOutlineLiesOnALineIsNotWalked)
{
    expectReadOrNamed(kPlyFlatOutline, sizeof kPlyFlatOutline, "flat-outline.ply");
}

TEST(MeshRepairFuzzed, APolygonOnALineIsTriangulatedAsAFanNotByCgal)
{
    expectReadOrNamed(kObjDegeneratePolygon, sizeof kObjDegeneratePolygon, "line-polygon.obj");
}

TEST(MeshRepairFuzzed, CoordinatesNearTheDoubleRangeHaveNoGapGridCell)
{
    expectReadOrNamed(kStlHugeCoordinates, sizeof kStlHugeCoordinates, "huge.stl");
}

} // namespace
} // namespace hg::model
