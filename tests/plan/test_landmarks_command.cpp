// `hullgauge landmarks suggest` end to end (docs/part-program.md, "Suggesting
// landmarks"): the landmarks list it writes, spliced into a copy of the
// simulated line's part program, passes `hullgauge plan` at the simulated
// station with every landmark inspectable and observed; more landmarks asked
// for than there are gives fewer with a note; a bad mesh exits 2 naming it.
#include "hgtest/paths.h"
#include "hullgauge/model/csg.h"
#include "hullgauge/model/mesh_io.h"
#include "hullgauge/model/primitives.h"

#include <fstream>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <sstream>

namespace hg::plan {
namespace {

using Eigen::Vector3d;
namespace fs = std::filesystem;

std::string tool()
{
    return (hgtest::binaryDir() / "bin" / "hullgauge").string();
}

fs::path simDir()
{
    return hgtest::sourceDir() / "config" / "sim";
}

std::string readText(const fs::path& file)
{
    std::ifstream in(file);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

/// The simulated line's part program up to its landmarks, with `mesh` (absolute) as its model.
std::string programHead(const fs::path& mesh)
{
    std::istringstream in(readText(simDir() / "stepped-block.yaml"));
    std::string text, line;
    while (std::getline(in, line) && line.rfind("landmarks:", 0) != 0) {
        if (line.rfind("mesh:", 0) == 0) line = "mesh: " + mesh.string();
        text += line + '\n';
    }
    return text;
}

std::size_t count(const std::string& text, const std::string& what)
{
    std::size_t n = 0;
    for (auto at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
    return n;
}

/// Plans `part` at the simulated station; every landmark must be inspectable and observed.
void expectPlanned(const hgtest::TempDir& dir, const fs::path& part, std::size_t landmarks)
{
    const auto r =
        hgtest::run(tool() + " plan --part " + part.string() + " --station " + (simDir() / "station.yaml").string() +
                    " --out " + (dir / "plan.json").string() + " --report " + (dir / "plan.md").string());
    ASSERT_EQ(r.status, 0) << r.err;
    std::ifstream in(dir / "plan.json");
    const auto plan = nlohmann::json::parse(in);
    EXPECT_TRUE(plan["feasible"].get<bool>());
    ASSERT_EQ(plan["landmarks"].size(), landmarks);
    for (const auto& l : plan["landmarks"]) {
        EXPECT_EQ(l["status"], "inspectable") << l["id"];
        EXPECT_FALSE(l["observed_by"].empty()) << l["id"];
    }
}

// The simulated line's stepped block, judged with its
// program's octree (depth 8, adjacency_depth 4) and tolerance (0.4 mm).
TEST(LandmarksCommand, SuggestionSplicedIntoTheSimulatedProgramPassesPlan)
{
    hgtest::TempDir dir;
    const fs::path mesh = simDir() / "stepped-block.stl";
    const auto r =
        hgtest::run(tool() + " landmarks suggest --mesh " + mesh.string() + " --station " +
                    (simDir() / "station.yaml").string() + " --depth 8 --adjacency-depth 4 --tolerance 0.4 --count 8");
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(count(r.out, "  - {id: "), 8u) << r.out;
    EXPECT_EQ(count(r.out, "  # face: ") + count(r.out, "  # edge: "), 8u) << r.out;
    EXPECT_GE(count(r.out, "  # face: "), 2u) << r.out;
    EXPECT_GE(count(r.out, "  # edge: "), 2u) << r.out;
    EXPECT_EQ(count(r.out, "#   chosen: "), 8u) << r.out;
    hgtest::writeFile(dir / "part.yaml", programHead(mesh) + r.out);
    expectPlanned(dir, dir / "part.yaml", 8);
}

// A box with a bore along y (r = 5 about x = 0, z = 18) through [-20, 20] x
// [-15, 15] x [0, 30], written to --out: faces, edges and the bore, all planned.
TEST(LandmarksCommand, BoxWithABoreSuggestionPassesPlan)
{
    hgtest::TempDir dir;
    model::TriangleMesh bore = model::makeCylinder(Vector3d(0, 0, -20), 5, 40, 64);
    Eigen::Matrix3d toY;
    toY << 1, 0, 0, 0, 0, 1, 0, -1, 0;
    bore.transform(toY, Vector3d(0, 0, 18));
    model::saveMesh(model::difference(model::makeBox(Vector3d(-20, -15, 0), Vector3d(20, 15, 30)), bore),
                    dir / "bored.stl");
    const auto r = hgtest::run(tool() + " landmarks suggest --mesh " + (dir / "bored.stl").string() + " --station " +
                               (simDir() / "station.yaml").string() + " --out " + (dir / "landmarks.yaml").string());
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_TRUE(r.out.empty()) << r.out;
    const std::string fragment = readText(dir / "landmarks.yaml");
    EXPECT_GE(count(fragment, "  # face: "), 1u) << fragment;
    EXPECT_GE(count(fragment, "  # edge: "), 1u) << fragment;
    EXPECT_GE(count(fragment, "  # hole: "), 1u) << fragment;
    // The octree the fragment was judged with (the defaults: depth 8, adjacency_depth 3).
    hgtest::writeFile(dir / "part.yaml",
                      "part: bored\nmesh: bored.stl\noctree:\n  depth: 8\n  adjacency_depth: 3\n" + fragment);
    expectPlanned(dir, dir / "part.yaml", count(fragment, "  - {id: "));
}

TEST(LandmarksCommand, MoreThanThereAreGivesFewerWithANote)
{
    const auto r = hgtest::run(tool() + " landmarks suggest --mesh " + (simDir() / "stepped-block.stl").string() +
                               " --station " + (simDir() / "station.yaml").string() + " --count 100");
    ASSERT_EQ(r.status, 0) << r.err;
    const std::size_t given = count(r.out, "  - {id: ");
    EXPECT_GT(given, 8u);
    EXPECT_LT(given, 100u);
    EXPECT_NE(r.err.find("note: asked for 100 landmarks, but only " + std::to_string(given)), std::string::npos)
        << r.err;
    EXPECT_NE(r.out.find("# Note: asked for 100 landmarks"), std::string::npos) << r.out;
}

// A tolerance no view of the station resolves (eq. 5.3.6-3: the finest MED
// at 400 mm with f = 2500 px is far above 1 µm): nothing to suggest, exit 2.
TEST(LandmarksCommand, NothingInspectableExitsTwo)
{
    const auto r = hgtest::run(tool() + " landmarks suggest --mesh " + (simDir() / "stepped-block.stl").string() +
                               " --station " + (simDir() / "station.yaml").string() + " --tolerance 0.001");
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("stepped-block.stl: landmarks: no point of the part found (25 candidates) is inspectable"),
              std::string::npos)
        << r.err;
    EXPECT_TRUE(r.out.empty()) << r.out;
}

TEST(LandmarksCommand, BadMeshExitsTwoNamingIt)
{
    hgtest::TempDir dir;
    // A box missing one of its twelve triangles: not closed.
    model::TriangleMesh open = model::makeBox(Vector3d(0, 0, 0), Vector3d(10, 10, 10));
    open.triangles.pop_back();
    model::saveMesh(open, dir / "open.stl", model::MeshEncoding::Ascii);
    const std::string station = " --station " + (simDir() / "station.yaml").string();
    auto r = hgtest::run(tool() + " landmarks suggest --mesh " + (dir / "open.stl").string() + station);
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("open.stl"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("open edge"), std::string::npos) << r.err;
    EXPECT_TRUE(r.out.empty()) << r.out;

    r = hgtest::run(tool() + " landmarks suggest --mesh " + (dir / "missing.stl").string() + station);
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("missing.stl"), std::string::npos) << r.err;
}

} // namespace
} // namespace hg::plan
