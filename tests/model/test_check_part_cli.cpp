// hullgauge check-part: exit status and messages of the real program.
#include <numbers>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "hgtest/paths.h"
#include "hgtest/station.h"
#include "hullgauge/model/mesh_io.h"
#include "hullgauge/model/primitives.h"
#include "step_assembly.h"

namespace {

using Eigen::Vector3d;

std::string hullgauge()
{
    return (hgtest::binaryDir() / "bin/hullgauge").string();
}

const char* kPart = R"(part: block
mesh: block.stl
octree:
  cube_origin: [-3, -3, -3]
  cube_size: 16
  depth: 7
  adjacency_depth: 3
landmarks:
  - id: top
    position: [5, 5, 10]
    tolerance_mm: 0.2
)";

TEST(CheckPartCli, GoodProgramPrintsSummaryAsJson)
{
    hgtest::TempDir dir;
    hg::model::saveMesh(hg::model::makeBox(Vector3d(0, 0, 0), Vector3d(10, 10, 10)), dir / "block.stl");
    hgtest::writeFile(dir / "part.yaml", kPart);
    const auto r = hgtest::run(hullgauge() + " check-part --json --part " + (dir / "part.yaml").string());
    ASSERT_EQ(r.status, 0) << r.err;
    const auto j = nlohmann::json::parse(r.out);
    EXPECT_EQ(j["part"], "block");
    EXPECT_EQ(j["mesh"]["triangles"], 12);
    EXPECT_NEAR(j["mesh"]["volume_mm3"].get<double>(), 1000.0, 1e-9);
    EXPECT_DOUBLE_EQ(j["octree"]["voxel_size_mm"].get<double>(), 0.125);
    EXPECT_EQ(j["landmarks"][0]["normal"], nlohmann::json::array({0.0, 0.0, 1.0}));

    const auto text = hgtest::run(hullgauge() + " check-part --part " + (dir / "part.yaml").string());
    EXPECT_EQ(text.status, 0);
    EXPECT_NE(text.out.find("ΔV = 0.125 mm"), std::string::npos) << text.out;
}

TEST(CheckPartCli, BadInputExitsTwoWithOneLineNamingFileAndField)
{
    hgtest::TempDir dir;
    hg::model::saveMesh(hg::model::makeBox(Vector3d(0, 0, 0), Vector3d(10, 10, 10)), dir / "block.stl");
    std::string text = kPart;
    text.replace(text.find("[5, 5, 10]"), 10, "[5, 5, 15]"); // 5 mm above the top face
    hgtest::writeFile(dir / "part.yaml", text);
    auto r = hgtest::run(hullgauge() + " check-part --part " + (dir / "part.yaml").string());
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(r.out, "");
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_NE(r.err.find("part.yaml:10: landmarks[0].position: landmark 'top' is 5.000 mm from the surface"),
              std::string::npos)
        << r.err;

    // A truncated binary STL: the mesh key and the facet are named.
    std::filesystem::resize_file(dir / "block.stl", 84 + 3 * 50 + 40);
    r = hgtest::run(hullgauge() + " check-part --part " + (dir / "part.yaml").string());
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_NE(r.err.find("part.yaml:2: mesh: "), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("block.stl: facet 4: file ends after 40 of 50 bytes"), std::string::npos) << r.err;
}

TEST(CheckPartCli, BadInspectionKeyExitsTwoNamingFileLineAndKey)
{
    hgtest::TempDir dir;
    hg::model::saveMesh(hg::model::makeBox(Vector3d(0, 0, 0), Vector3d(10, 10, 10)), dir / "block.stl");
    // kPart has 11 lines: the section's key is line 13.
    hgtest::writeFile(dir / "part.yaml", std::string(kPart) + "inspection:\n  level: 8\n");
    const auto r = hgtest::run(hullgauge() + " check-part --part " + (dir / "part.yaml").string());
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("part.yaml:13: inspection.level: value 8 is outside [1, 7]"), std::string::npos) << r.err;
}

} // namespace

namespace {

// `check-part --station S --views V`: the uncertainty each landmark is
// expected to be measured with at those views (docs/inspection.md,
// "Capability"). Decided on the bracket (no view sees the top on its
// outline) the top's U is ΔV/2 = 0.0625 mm exactly; by the sub-voxel
// deviation it is smaller. Either way ±0.2 mm is provable and ±0.002 mm is not.
TEST(CheckPartCli, WithAStationTheExpectedUncertaintyOfEveryLandmarkIsPrinted)
{
    hgtest::TempDir dir;
    hg::model::saveMesh(hg::model::makeBox(Vector3d(0, 0, 0), Vector3d(10, 10, 10)), dir / "block.stl");
    hgtest::writeFile(dir / "part.yaml", kPart);
    hgtest::writeFile(dir / "station.yaml", hgtest::stationYaml({.focalPx = 4000}));
    hgtest::writeFile(dir / "views.yaml", "- {rotation_deg: 0, declination_deg: 0}\n"
                                          "- {rotation_deg: 90, declination_deg: 30}\n");
    const std::string args = " check-part --part " + (dir / "part.yaml").string() + " --station " +
                             (dir / "station.yaml").string() + " --views " + (dir / "views.yaml").string();
    auto r = hgtest::run(hullgauge() + args + " --json");
    ASSERT_EQ(r.status, 0) << r.err;
    const auto j = nlohmann::json::parse(r.out);
    ASSERT_EQ(j["capability"].size(), 1u);
    const auto& c = j["capability"][0];
    EXPECT_EQ(c["id"], "top");
    EXPECT_DOUBLE_EQ(c["zone_mm"].get<double>(), 0.4);
    if (c["basis"] == "bracket")
        EXPECT_DOUBLE_EQ(c["expected_uncertainty_mm"].get<double>(), 0.0625);
    else
        EXPECT_LT(c["expected_uncertainty_mm"].get<double>(), 0.0625);
    EXPECT_TRUE(c["capable"].get<bool>());
    const auto text = hgtest::run(hullgauge() + args);
    EXPECT_EQ(text.status, 0);
    EXPECT_NE(text.out.find("landmark top: tolerance zone 0.4 mm ≥ 4 U"), std::string::npos) << text.out;

    std::string tight = kPart;
    tight.replace(tight.find("0.2"), 3, "0.002");
    hgtest::writeFile(dir / "part.yaml", tight);
    const auto refused = hgtest::run(hullgauge() + args);
    EXPECT_EQ(refused.status, 0);
    EXPECT_NE(refused.out.find("landmark top: tolerance zone 0.004 mm is narrower than 4 U"), std::string::npos)
        << refused.out;
    // --station needs the views it would be used at.
    const auto noViews = hgtest::run(hullgauge() + " check-part --part " + (dir / "part.yaml").string() +
                                     " --station " + (dir / "station.yaml").string());
    EXPECT_EQ(noViews.status, 2) << noViews.err;
}

} // namespace

namespace {

// A mesh as CAD exports it (docs/part-program.md, "Meshes as they come"): the
// block with two of its faces written twice and the whole shell inside out.
// check-part lists the repairs; `mesh_repair: strict` refuses it, exit 2.
TEST(CheckPartCli, RepairedMeshIsListedAndStrictModeRefusesIt)
{
    hgtest::TempDir dir;
    hg::model::TriangleMesh block = hg::model::makeBox(Vector3d(0, 0, 0), Vector3d(10, 10, 10));
    block.flip();
    block.triangles.push_back(block.triangles[0]);
    block.triangles.push_back(block.triangles[5]);
    hg::model::saveMesh(block, dir / "block.stl");
    hgtest::writeFile(dir / "part.yaml", kPart);
    auto r = hgtest::run(hullgauge() + " check-part --json --part " + (dir / "part.yaml").string());
    ASSERT_EQ(r.status, 0) << r.err;
    const auto j = nlohmann::json::parse(r.out);
    EXPECT_EQ(j["mesh_repair"]["mode"], "repair");
    EXPECT_EQ(j["mesh_repair"]["repaired"], true);
    EXPECT_EQ(j["mesh_repair"]["duplicate_faces"], 2);
    EXPECT_EQ(j["mesh_repair"]["flipped_shells"], 1);
    EXPECT_EQ(j["mesh_repair"]["self_intersections"], 0);
    EXPECT_DOUBLE_EQ(j["mesh_repair"]["gap_tolerance_mm"].get<double>(), 0.02);
    EXPECT_NEAR(j["mesh"]["volume_mm3"].get<double>(), 1000.0, 1e-9);
    const auto text = hgtest::run(hullgauge() + " check-part --part " + (dir / "part.yaml").string());
    EXPECT_EQ(text.status, 0);
    EXPECT_NE(text.out.find("repaired    2 kinds of defect (mesh_repair: repair):\n  2 duplicate faces removed\n"
                            "  1 shell oriented inward flipped\n"),
              std::string::npos)
        << text.out;

    // mesh_repair: strict, given after `mesh` (line 3).
    std::string strict = kPart;
    strict.insert(strict.find("octree:"), "mesh_repair: strict\n");
    hgtest::writeFile(dir / "part.yaml", strict);
    r = hgtest::run(hullgauge() + " check-part --part " + (dir / "part.yaml").string());
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(r.out, "");
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_NE(r.err.find("part.yaml:2: mesh: "), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("block.stl: mesh: needs repair (mesh_repair: strict): 2 duplicate faces, 1 shell oriented "
                         "inward"),
              std::string::npos)
        << r.err;

    // A clean mesh passes strict mode and reports nothing repaired.
    hg::model::saveMesh(hg::model::makeBox(Vector3d(0, 0, 0), Vector3d(10, 10, 10)), dir / "block.stl");
    r = hgtest::run(hullgauge() + " check-part --part " + (dir / "part.yaml").string());
    EXPECT_EQ(r.status, 0) << r.err;
    EXPECT_NE(r.out.find("repaired    nothing"), std::string::npos) << r.out;

    strict.replace(strict.find("mesh_repair: strict"), 19, "mesh_repair: lenient");
    hgtest::writeFile(dir / "part.yaml", strict);
    r = hgtest::run(hullgauge() + " check-part --part " + (dir / "part.yaml").string());
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("part.yaml:3: mesh_repair: unknown mode 'lenient' (expected repair or strict)"),
              std::string::npos)
        << r.err;
}

} // namespace

namespace {

// A STEP assembly (docs/part-program.md, "STEP parts"): check-part lists its
// solids by name and marks the one `mesh_solid` chose; a name the file does
// not hold, and `mesh_solid` on a mesh file, exit 2 at the key's line.
const char* kAssemblyPart = R"(part: pin
mesh: assembly.step
mesh_solid: pin
octree:
  depth: 6
  adjacency_depth: 3
landmarks:
  - id: cap
    position: [100, 0, 30]
    tolerance_mm: 0.2
)";

TEST(CheckPartCli, StepAssemblyListsItsSolidsByNameAndTheChosenOne)
{
    hgtest::TempDir dir;
    hgtest::writeBracketAndPin(dir / "assembly.step");
    hgtest::writeFile(dir / "part.yaml", kAssemblyPart);
    auto r = hgtest::run(hullgauge() + " check-part --json --part " + (dir / "part.yaml").string());
    ASSERT_EQ(r.status, 0) << r.err;
    const auto j = nlohmann::json::parse(r.out);
    EXPECT_EQ(j["step"]["solids"], 2);
    EXPECT_EQ(j["step"]["mesh_solid"], "pin");
    ASSERT_EQ(j["step"]["tree"].size(), 2u);
    EXPECT_EQ(j["step"]["tree"][0]["name"], "bracket");
    EXPECT_EQ(j["step"]["tree"][0]["chosen"], false);
    EXPECT_EQ(j["step"]["tree"][1]["name"], "pin");
    EXPECT_EQ(j["step"]["tree"][1]["chosen"], true);
    const double pin = std::numbers::pi * hgtest::kPinRadius * hgtest::kPinRadius * hgtest::kPinLength;
    EXPECT_NEAR(j["step"]["tree"][1]["volume_mm3"].get<double>(), pin, 1e-6 * pin);
    EXPECT_NEAR(j["step"]["volume_mm3"].get<double>(), pin, 1e-6 * pin);

    const auto text = hgtest::run(hullgauge() + " check-part --part " + (dir / "part.yaml").string());
    EXPECT_EQ(text.status, 0) << text.err;
    EXPECT_NE(text.out.find("step        solid 'pin' of 2 (mesh_solid), "), std::string::npos) << text.out;
    EXPECT_NE(text.out.find("solids      2 in the file's product tree\n  'bracket': volume "), std::string::npos)
        << text.out;
    EXPECT_NE(text.out.find("  'pin': volume 2356.19 mm³ (chosen: mesh_solid)\n"), std::string::npos) << text.out;

    // Without mesh_solid both are listed, the union is the part.
    std::string all = kAssemblyPart;
    all.erase(all.find("mesh_solid: pin\n"), 16);
    hgtest::writeFile(dir / "part.yaml", all);
    r = hgtest::run(hullgauge() + " check-part --json --part " + (dir / "part.yaml").string());
    ASSERT_EQ(r.status, 0) << r.err;
    const auto u = nlohmann::json::parse(r.out);
    EXPECT_TRUE(u["step"]["mesh_solid"].is_null());
    EXPECT_EQ(u["step"]["tree"][0]["name"], "bracket");
    EXPECT_EQ(u["step"]["tree"][1]["name"], "pin");
}

TEST(CheckPartCli, UnknownSolidOrSolidOfAMeshExitsTwoAtTheKeysLine)
{
    hgtest::TempDir dir;
    hgtest::writeBracketAndPin(dir / "assembly.step");
    std::string text = kAssemblyPart;
    text.replace(text.find("mesh_solid: pin"), 15, "mesh_solid: nut");
    hgtest::writeFile(dir / "part.yaml", text);
    auto r = hgtest::run(hullgauge() + " check-part --part " + (dir / "part.yaml").string());
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(r.out, "");
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_NE(r.err.find("part.yaml:3: mesh_solid: "), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("no solid named 'nut'; the file's 2 solids are: 'bracket', 'pin'"), std::string::npos)
        << r.err;

    hg::model::saveMesh(hg::model::makeBox(Vector3d(0, 0, 0), Vector3d(10, 10, 10)), dir / "block.stl");
    std::string mesh = kPart;
    mesh.insert(mesh.find("octree:"), "mesh_solid: pin\n");
    hgtest::writeFile(dir / "part.yaml", mesh);
    r = hgtest::run(hullgauge() + " check-part --part " + (dir / "part.yaml").string());
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("part.yaml:3: mesh_solid: block.stl is a mesh (STL, OBJ, PLY or OFF)"), std::string::npos)
        << r.err;
}

// `landmarks suggest --solid`: the same names, refused as an option's value.
TEST(CheckPartCli, LandmarksSuggestRefusesAnUnknownSolidListingTheNames)
{
    hgtest::TempDir dir;
    hgtest::writeBracketAndPin(dir / "assembly.step");
    const auto r = hgtest::run(hullgauge() + " landmarks suggest --mesh " + (dir / "assembly.step").string() +
                               " --solid nut --station " + (hgtest::sourceDir() / "config/sim/station.yaml").string());
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(r.out, "");
    EXPECT_NE(r.err.find("--solid: no solid named 'nut'; the file's 2 solids are: 'bracket', 'pin'"), std::string::npos)
        << r.err;
}

} // namespace
