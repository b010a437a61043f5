// The workspace on an analytic part (docs/workbench.md): a 40 × 30 × 20 mm box
// [0, 40] × [0, 30] × [0, 20], written as an STL here, twelve triangles.
// Its bounding-box diagonal is √(40² + 30² + 20²) = 53.85 mm, so the snap
// distance is 2 % of it, 1.077 mm, and a point is refused beyond max(1 mm,
// 1.077 mm). Expected positions and normals are the box's by hand: on a face
// the face's normal, on an edge the bisector of its two faces, at a corner
// (±1, ±1, ±1)/√3.
#include "hgtest/paths.h"
#include "hullgauge/common/digest.h"
#include "hullgauge/model/mesh_io.h"
#include "hullgauge/workbench/workspace.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <set>
#include <sstream>

namespace hg::workbench {
namespace {

namespace fs = std::filesystem;

std::string readText(const fs::path& file)
{
    std::ifstream in(file, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

/// The box as an ASCII STL, every facet counter-clockwise seen from outside.
std::string boxStl(double x, double y, double z)
{
    const double v[8][3] = {{0, 0, 0}, {x, 0, 0}, {x, y, 0}, {0, y, 0}, {0, 0, z}, {x, 0, z}, {x, y, z}, {0, y, z}};
    const int quads[6][4] = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4}, {2, 3, 7, 6}, {1, 2, 6, 5}, {3, 0, 4, 7}};
    std::ostringstream s;
    s << "solid box\n";
    for (const auto& q : quads)
        for (const auto& t : {std::array<int, 3>{q[0], q[1], q[2]}, std::array<int, 3>{q[0], q[2], q[3]}}) {
            s << " facet normal 0 0 0\n  outer loop\n";
            for (int k : t) s << "   vertex " << v[k][0] << ' ' << v[k][1] << ' ' << v[k][2] << '\n';
            s << "  endloop\n endfacet\n";
        }
    s << "endsolid box\n";
    return s.str();
}

struct BoxWorkspace : ::testing::Test {
    hgtest::TempDir dir;
    Workspace ws{dir / "parts"};
    Actor alice{"alice"};

    fs::path cad() { return hgtest::writeFile(dir / "box.stl", boxStl(40, 30, 20)); }
    PartState addBox() { return ws.add(cad(), AddOptions{}, alice); }
    fs::path draftFile() { return dir / "parts" / "box" / "box.draft.yaml"; }
    Placed place(const Eigen::Vector3d& at, int revision = 1)
    {
        LandmarkEdit edit;
        edit.position = at;
        return ws.addLandmark("box", revision, std::nullopt, edit, alice);
    }
};

TEST_F(BoxWorkspace, TheNestPlayIsTheDraftsAlignmentLimits)
{
    addBox();
    // Absent from the draft: the part program's defaults (docs/part-program.md, 1 mm and 1°).
    EXPECT_EQ(ws.read("box").draft.maxShiftMm, 1.0);
    EXPECT_EQ(toJson(ws.read("box"))["draft"]["alignment"]["max_rotation_deg"], 1.0);
    std::ofstream(draftFile(), std::ios::app) << "alignment: {max_shift_mm: 0.4, max_rotation_deg: 0.25}\n";
    const auto j = toJson(ws.read("box"));
    EXPECT_EQ(j["draft"]["alignment"]["max_shift_mm"], 0.4);
    EXPECT_EQ(j["draft"]["alignment"]["max_rotation_deg"], 0.25);
}

TEST_F(BoxWorkspace, AddsThePartWithItsDisplayMeshesAndADraftWithoutLandmarks)
{
    const PartState s = addBox();
    EXPECT_EQ(s.record.part, "box");
    EXPECT_EQ(s.record.cad, "box.stl");
    EXPECT_EQ(s.record.revision, 1);
    EXPECT_EQ(s.record.changedBy, "alice");
    EXPECT_EQ(s.cadKind, "stl");
    EXPECT_EQ(s.triangles, 12u);
    EXPECT_EQ(s.boundsMax, Eigen::Vector3d(40, 30, 20));
    EXPECT_EQ(s.cadSha256, sha256Hex(readText(dir / "box.stl")));
    EXPECT_TRUE(s.draft.landmarks.empty());
    EXPECT_EQ(s.draft.depth, 8);
    EXPECT_EQ(s.draft.adjacencyDepth, 4);
    // The display meshes: the mesh as the station sees it, and (12 ≤ 25 000) the same.
    EXPECT_EQ(model::loadMesh(dir / "parts" / "box" / "display" / "model.stl").triangles.size(), 12u);
    EXPECT_EQ(model::loadMesh(dir / "parts" / "box" / "display" / "lod.stl").triangles.size(), 12u);
    EXPECT_EQ(ws.displayMeshFile("box", false), dir / "parts" / "box" / "display" / "model.stl");
    EXPECT_EQ(ws.displayMeshFile("box", true), dir / "parts" / "box" / "display" / "lod.stl");
    EXPECT_THROW(ws.displayMeshFile("nobox", true), workbench::PartNotFound);
    ASSERT_EQ(ws.list().size(), 1u);
    // Nothing of the part's making is left in the workspace.
    std::size_t entries = 0;
    for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir / "parts")) ++entries;
    EXPECT_EQ(entries, 1u);
}

TEST_F(BoxWorkspace, AClickAboveAFaceLandsOnTheFaceWithTheFaceNormal)
{
    addBox();
    const Placed p = place({20, 15, 20.3});
    EXPECT_EQ(p.landmark.id, "L1");
    EXPECT_EQ(p.landmark.on, Placement::Face);
    EXPECT_EQ(p.landmark.position, Eigen::Vector3d(20, 15, 20));
    EXPECT_EQ(p.landmark.normal, Eigen::Vector3d(0, 0, 1));
    EXPECT_FALSE(p.landmark.normalGiven);
    EXPECT_NEAR(p.movedMm, 0.3, 1e-12);
    EXPECT_EQ(p.revision, 2);
    // The normal is left to the loader: the draft does not write one.
    EXPECT_EQ(readText(draftFile()).find("normal"), std::string::npos);
    const PartState s = ws.read("box");
    EXPECT_EQ(s.record.revision, 2);
    EXPECT_EQ(s.record.change, "landmark L1 added on face");
    ASSERT_EQ(s.draft.landmarks.size(), 1u);
    EXPECT_EQ(s.draft.landmarks[0].normal, Eigen::Vector3d(0, 0, 1));
    EXPECT_EQ(s.draft.landmarks[0].toleranceMm, 0.1);
}

TEST_F(BoxWorkspace, AClickAMillimetreFromAnEdgeLandsOnTheEdgeWithTheBisector)
{
    addBox();
    // 1 mm in from the top face's front edge (y = 0, z = 20): within 1.077 mm.
    const Placed p = place({20, 1, 20});
    EXPECT_EQ(p.landmark.on, Placement::Edge);
    EXPECT_NEAR((p.landmark.position - Eigen::Vector3d(20, 0, 20)).norm(), 0.0, 1e-12);
    EXPECT_NEAR((p.landmark.normal - Eigen::Vector3d(0, -1, 1).normalized()).norm(), 0.0, 1e-12);
    EXPECT_NEAR(p.movedMm, 1.0, 1e-12);
    // 1.2 mm in is beyond the snap distance: the face.
    const Placed q = place({20, 1.2, 20.1}, 2);
    EXPECT_EQ(q.landmark.on, Placement::Face);
    EXPECT_NEAR((q.landmark.position - Eigen::Vector3d(20, 1.2, 20)).norm(), 0.0, 1e-12);
    EXPECT_EQ(q.landmark.id, "L2");
}

TEST_F(BoxWorkspace, AClickNearACornerLandsOnTheCornerWithTheMeanOfItsFaces)
{
    addBox();
    const Placed p = place({0.5, 0.5, 20.1});
    EXPECT_EQ(p.landmark.on, Placement::Corner);
    EXPECT_NEAR((p.landmark.position - Eigen::Vector3d(0, 0, 20)).norm(), 0.0, 1e-12);
    EXPECT_NEAR((p.landmark.normal - Eigen::Vector3d(-1, -1, 1).normalized()).norm(), 0.0, 1e-9);
}

TEST_F(BoxWorkspace, APointFarFromTheSurfaceIsRefusedNamingItsDistance)
{
    addBox();
    const std::string before = readText(draftFile());
    try {
        place({20, 15, 40});
        FAIL() << "a point 20 mm above the box was placed";
    } catch (const InputError& e) {
        EXPECT_EQ(e.problem(),
                  "landmark position (20, 15, 40) is 20.000 mm from the part's surface; click on the part");
    }
    EXPECT_EQ(readText(draftFile()), before);
    EXPECT_EQ(ws.read("box").record.revision, 1);
}

TEST_F(BoxWorkspace, AChangeOnAnOlderRevisionIsRefusedNamingWhoChangedWhatAndTheDraftStays)
{
    addBox();
    place({20, 15, 20});
    const std::string before = readText(draftFile());
    LandmarkEdit edit;
    edit.toleranceMm = 0.2;
    try {
        ws.changeLandmark("box", 1, "L1", edit, Actor{"bob"});
        FAIL() << "a change on revision 1 was made on a draft at revision 2";
    } catch (const StaleRevision& e) {
        const std::string at = ws.read("box").record.changedAt.substr(11, 8);
        EXPECT_EQ(e.problem(), "the draft of box is at revision 2 (alice, " + at +
                                   ": landmark L1 added on face); this change was made on revision 1: reload the "
                                   "part and make it again");
    }
    EXPECT_EQ(readText(draftFile()), before);
    const Placed changed = ws.changeLandmark("box", 2, "L1", edit, Actor{"bob"});
    EXPECT_EQ(changed.revision, 3);
    EXPECT_EQ(changed.landmark.toleranceMm, 0.2);
    EXPECT_EQ(ws.read("box").record.change, "landmark L1 tolerance 0.2 mm");
}

TEST_F(BoxWorkspace, ADraftTheLoaderRefusesIsRefusedInItsWordsAndStaysAsItWas)
{
    addBox();
    LandmarkEdit edit;
    edit.position = Eigen::Vector3d(20, 15, 20);
    ws.addLandmark("box", 1, std::string("c1"), edit, alice);
    const std::string before = readText(draftFile());
    edit.position = Eigen::Vector3d(10, 15, 20);
    try {
        ws.addLandmark("box", 2, std::string("c1"), edit, alice);
        FAIL() << "a second landmark c1 was added";
    } catch (const InputError& e) {
        EXPECT_EQ(e.file(), "box.draft.yaml");
        EXPECT_EQ(e.problem(), "duplicate landmark id 'c1'");
    }
    // A normal into the part: refused as the loader refuses it.
    LandmarkEdit inward;
    inward.normal = Eigen::Vector3d(0, 0, -1);
    EXPECT_THROW(ws.changeLandmark("box", 2, "c1", inward, alice), InputError);
    EXPECT_EQ(readText(draftFile()), before);
    EXPECT_EQ(ws.read("box").record.revision, 2);
}

TEST_F(BoxWorkspace, MovesRenamesAndRemovesLandmarks)
{
    addBox();
    place({20, 15, 20});
    LandmarkEdit move;
    move.position = Eigen::Vector3d(23, 19, 20.2);
    move.newId = "top";
    const Placed moved = ws.changeLandmark("box", 2, "L1", move, alice);
    EXPECT_EQ(moved.landmark.id, "top");
    EXPECT_EQ(moved.landmark.position, Eigen::Vector3d(23, 19, 20));
    EXPECT_EQ(ws.read("box").record.change, "landmark L1 moved 5.000 mm onto a face, renamed top");
    EXPECT_EQ(ws.removeLandmark("box", 3, "top", alice), 4);
    EXPECT_TRUE(ws.read("box").draft.landmarks.empty());
    EXPECT_THROW(ws.removeLandmark("box", 4, "top", alice), InputError);
}

TEST_F(BoxWorkspace, ASecondPartOfTheSameNameIsRefused)
{
    addBox();
    EXPECT_THROW(ws.add(cad(), AddOptions{}, alice), PartExists);
    EXPECT_THROW(ws.addUpload("box.stl", boxStl(10, 10, 10), AddOptions{}, alice), PartExists);
    AddOptions other;
    other.name = "box-2";
    EXPECT_EQ(ws.add(cad(), other, alice).record.part, "box-2");
    EXPECT_EQ(ws.list().size(), 2u);
}

/// The workspace holds exactly `names` (no staging folder left behind).
void expectEntries(const fs::path& folder, std::set<std::string> names)
{
    std::set<std::string> found;
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(folder, ec)) found.insert(e.path().filename().string());
    EXPECT_EQ(found, names);
}

TEST_F(BoxWorkspace, AnUploadThatIsNoMeshIsRefusedInTheLoadersWordsAndLeavesNothing)
{
    try {
        ws.addUpload("bracket.stl", "this is not a mesh\n", AddOptions{}, alice);
        FAIL() << "text was taken for a mesh";
    } catch (const InputError& e) {
        EXPECT_EQ(e.file(), "bracket.stl") << e.what();
        EXPECT_EQ(std::string(e.what()).find(".adding"), std::string::npos) << e.what();
    }
    expectEntries(dir / "parts", {});
    // A binary STL cut short: 80 bytes of header, 12 facets announced, 2 there.
    std::string truncated(80, ' ');
    const std::uint32_t facets = 12;
    truncated.append(reinterpret_cast<const char*>(&facets), 4);
    truncated.append(2 * 50, '\0');
    try {
        ws.addUpload("bracket.stl", truncated, AddOptions{}, alice);
        FAIL() << "a truncated STL was added";
    } catch (const InputError& e) {
        EXPECT_EQ(std::string(e.what()),
                  "bracket.stl: facet 3: file ends after 2 of the 12 facets the header announces");
    }
    expectEntries(dir / "parts", {});
    EXPECT_THROW(ws.addUpload("bracket.txt", boxStl(1, 1, 1), AddOptions{}, alice), InputError);
    EXPECT_THROW(ws.read("bracket"), PartNotFound);
    EXPECT_THROW(ws.read("../etc"), PartNotFound);
}

TEST_F(BoxWorkspace, AnUploadIsAddedLikeAFile)
{
    AddOptions o;
    o.name = "upload";
    o.toleranceMm = 0.25;
    const PartState s = ws.addUpload("Box.STL", boxStl(40, 30, 20), o, alice);
    EXPECT_EQ(s.record.cad, "upload.stl");
    EXPECT_EQ(s.record.toleranceMm, 0.25);
    EXPECT_EQ(s.triangles, 12u);
}

TEST_F(BoxWorkspace, AReleaseIsRefusedBeforeTheDraftIsVerified)
{
    addBox();
    place({20, 15, 20});
    const fs::path station = hgtest::writeFile(dir / "station.yaml", "not read before the verification\n");
    try {
        ws.release("box", 2, station, 7, {}, alice);
        FAIL() << "an unverified draft was released";
    } catch (const ReleaseRefused& e) {
        EXPECT_NE(e.problem().find("has not been verified on the twin"), std::string::npos) << e.what();
    }
    EXPECT_FALSE(fs::exists(dir / "parts" / "box" / "box.yaml"));
    EXPECT_THROW(ws.release("box", 1, station, 7, {}, alice), StaleRevision);
}

} // namespace
} // namespace hg::workbench
