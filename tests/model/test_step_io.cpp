// STEP parts (docs/part-program.md, "STEP parts"): files made here from Open
// CASCADE primitives — a box with a through bore, a stepped block of two fused
// boxes, a block with filleted vertical edges — checked against their analytic
// volumes and surfaces; a STEP part inspected like its STL twin; truncated
// files and files without a solid refused by the real program.
#include <cmath>
#include <fstream>
#include <iostream>
#include <numbers>
#include <set>
#include <sstream>
#include <string>

#include <BRepAlgoAPI_Cut.hxx>
#include <BRepAlgoAPI_Fuse.hxx>
#include <BRepBuilderAPI_MakeFace.hxx>
#include <BRepFilletAPI_MakeFillet.hxx>
#include <BRepPrimAPI_MakeBox.hxx>
#include <BRepPrimAPI_MakeCylinder.hxx>
#include <IFSelect_ReturnStatus.hxx>
#include <Interface_Static.hxx>
#include <STEPControl_Controller.hxx>
#include <STEPControl_Writer.hxx>
#include <TopExp_Explorer.hxx>
#include <TopoDS.hxx>
#include <gp_Ax2.hxx>
#include <gp_Pln.hxx>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "hgtest/paths.h"
#include "hgtest/station.h"
#include "hullgauge/common/error.h"
#include "hullgauge/geometry/station.h"
#include "hullgauge/model/part_program.h"
#include "hullgauge/model/step_io.h"
#include "hullgauge/plan/landmark_suggest.h"
#include "step_assembly.h"

namespace {

using Eigen::Vector3d;
using hg::model::PartProgram;
namespace fs = std::filesystem;
constexpr double kPi = std::numbers::pi;

// Part (a): the box [0, 40] x [0, 30] x [0, 20] less a through bore r = 6 along z about (20, 15).
constexpr double kBoreRadius = 6.0;
const Vector3d kBoreAxis(20, 15, 0);
// Part (c): the same box with its four vertical edges filleted, r = 4.
constexpr double kFilletRadius = 4.0;

TopoDS_Shape boxWithBore()
{
    const TopoDS_Shape box = BRepPrimAPI_MakeBox(gp_Pnt(0, 0, 0), gp_Pnt(40, 30, 20)).Shape();
    const gp_Ax2 axis(gp_Pnt(kBoreAxis.x(), kBoreAxis.y(), -1), gp::DZ());
    const TopoDS_Shape bore = BRepPrimAPI_MakeCylinder(axis, kBoreRadius, 22).Shape();
    return BRepAlgoAPI_Cut(box, bore).Shape();
}

// Part (b): the simulated line's stepped block (config/sim/make-meshes.py):
// tall block x in [-30, 0] up to z = 30, step x in [0, 30] up to z = 15, y in [-20, 20].
TopoDS_Shape steppedBlock()
{
    const TopoDS_Shape tall = BRepPrimAPI_MakeBox(gp_Pnt(-30, -20, 0), gp_Pnt(0, 20, 30)).Shape();
    const TopoDS_Shape step = BRepPrimAPI_MakeBox(gp_Pnt(0, -20, 0), gp_Pnt(30, 20, 15)).Shape();
    return BRepAlgoAPI_Fuse(tall, step).Shape();
}

TopoDS_Shape filletedBlock()
{
    const TopoDS_Shape box = BRepPrimAPI_MakeBox(gp_Pnt(0, 0, 0), gp_Pnt(40, 30, 20)).Shape();
    BRepFilletAPI_MakeFillet fillet(box);
    for (TopExp_Explorer e(box, TopAbs_EDGE); e.More(); e.Next()) {
        // The vertical edges: their two vertices differ in z only.
        TopExp_Explorer v(e.Current(), TopAbs_VERTEX);
        const gp_Pnt a = BRep_Tool::Pnt(TopoDS::Vertex(v.Current()));
        v.Next();
        const gp_Pnt b = BRep_Tool::Pnt(TopoDS::Vertex(v.Current()));
        if (std::abs(a.X() - b.X()) < 1e-9 && std::abs(a.Y() - b.Y()) < 1e-9)
            fillet.Add(kFilletRadius, TopoDS::Edge(e.Current()));
    }
    return fillet.Shape();
}

fs::path writeStep(const TopoDS_Shape& shape, const fs::path& file)
{
    STEPControl_Writer writer;
    EXPECT_EQ(writer.Transfer(shape, STEPControl_AsIs), IFSelect_RetDone);
    EXPECT_EQ(writer.Write(file.c_str()), IFSelect_RetDone);
    return file;
}

/// A part program for `mesh` with the cube derived from the part, and `landmarks` (YAML list items).
std::string programYaml(const std::string& mesh, int depth, const std::string& landmarks)
{
    return "part: p\nmesh: " + mesh + "\noctree:\n  depth: " + std::to_string(depth) +
           "\n  adjacency_depth: 3\nlandmarks:\n" + landmarks;
}

PartProgram loadStepPart(const hgtest::TempDir& dir, const TopoDS_Shape& shape, int depth, const std::string& landmarks)
{
    writeStep(shape, dir / "part.step");
    hgtest::writeFile(dir / "part.yaml", programYaml("part.step", depth, landmarks));
    return hg::model::loadPartProgram(dir / "part.yaml");
}

std::string exe()
{
    return (hgtest::binaryDir() / "bin/hullgauge").string();
}

// The tessellation's chords lie within the deflection δ of the surface, so the
// mesh volume differs from the exact one by at most (curved area) · δ: more for
// a bore (the chords cut into the void), less for a convex fillet.
TEST(StepPart, BoreTessellationVolumeWithinTheDeflectionOfTheAnalyticVolume)
{
    hgtest::TempDir dir;
    const PartProgram p =
        loadStepPart(dir, boxWithBore(), 7, "  - {id: top, position: [10, 5, 20], tolerance_mm: 0.2}\n");
    ASSERT_TRUE(p.brep);
    const double exact = 40.0 * 30.0 * 20.0 - kPi * kBoreRadius * kBoreRadius * 20.0;
    const double deflection = p.octree.voxelSize() / 20.0;
    EXPECT_DOUBLE_EQ(p.brep->tessellation().linearDeflectionMm, deflection);
    EXPECT_NEAR(p.brep->summary().volumeMm3, exact, 1e-6 * exact);
    EXPECT_EQ(p.brep->summary().solids, 1u);
    const double mesh = p.solid->mesh().signedVolume();
    const double curvedArea = 2.0 * kPi * kBoreRadius * 20.0;
    std::cout << "bore: deflection " << deflection << " mm, mesh volume error " << mesh - exact << " mm³ (bound "
              << curvedArea * deflection << "), " << p.solid->mesh().triangles.size() << " triangles\n";
    EXPECT_GT(mesh, exact);
    EXPECT_LT(mesh - exact, curvedArea * deflection);
    EXPECT_EQ(p.brep->tessellation().triangles, p.solid->mesh().triangles.size());
}

TEST(StepPart, FilletTessellationVolumeWithinTheDeflectionOfTheAnalyticVolume)
{
    hgtest::TempDir dir;
    const PartProgram p =
        loadStepPart(dir, filletedBlock(), 7, "  - {id: top, position: [20, 15, 20], tolerance_mm: 0.2}\n");
    const double r = kFilletRadius;
    const double exact = 40.0 * 30.0 * 20.0 - 4.0 * (r * r - kPi * r * r / 4.0) * 20.0;
    EXPECT_NEAR(p.brep->summary().volumeMm3, exact, 1e-6 * exact);
    const double deflection = p.tessellationDeflectionMm();
    const double mesh = p.solid->mesh().signedVolume();
    const double curvedArea = 4.0 * (kPi / 2.0 * r) * 20.0;
    std::cout << "fillet: deflection " << deflection << " mm, mesh volume error " << mesh - exact << " mm³ (bound "
              << curvedArea * deflection << ")\n";
    EXPECT_LT(mesh, exact);
    EXPECT_LT(exact - mesh, curvedArea * deflection);
}

TEST(StepPart, SteppedBlockOfTwoFusedBoxesIsExactAndItsConcaveEdgeTakesTheBisector)
{
    hgtest::TempDir dir;
    const PartProgram p = loadStepPart(dir, steppedBlock(), 5,
                                       "  - {id: step-top, position: [15, 0, 15.25], tolerance_mm: 0.2}\n"
                                       "  - {id: riser-foot, position: [0, 0, 15], tolerance_mm: 0.2}\n");
    EXPECT_NEAR(p.brep->summary().volumeMm3, 54000.0, 1e-6);
    EXPECT_NEAR(p.solid->mesh().signedVolume(), 54000.0, 1e-6);
    EXPECT_TRUE(p.brep->summary().bounds.isApprox(Eigen::AlignedBox3d(Vector3d(-30, -20, 0), Vector3d(30, 20, 30))));
    const auto& top = p.landmarks[0];
    EXPECT_TRUE(top.onBRep);
    EXPECT_NEAR((top.position - Vector3d(15, 0, 15)).norm(), 0.0, 1e-9);
    EXPECT_NEAR(top.distanceToSurfaceMm, 0.25, 1e-9);
    EXPECT_NEAR((top.normal - Vector3d(0, 0, 1)).norm(), 0.0, 1e-9);
    const auto& foot = p.landmarks[1];
    EXPECT_NEAR((foot.position - Vector3d(0, 0, 15)).norm(), 0.0, 1e-9);
    EXPECT_NEAR((foot.normal - Vector3d(1, 0, 1).normalized()).norm(), 0.0, 1e-9);
}

// Landmarks given 0.3 mm off the bore's wall, in the void and in the
// material, snap onto the cylinder r = 6 (within 1 µm), normals towards the axis.
TEST(StepPart, LandmarksOffTheBoreWallSnapToTheCylinderWithNormalsIntoTheBore)
{
    hgtest::TempDir dir;
    auto at = [](double radius, double deg, double z) -> Vector3d {
        const double a = deg * kPi / 180.0;
        return kBoreAxis + Vector3d(radius * std::cos(a), radius * std::sin(a), z);
    };
    auto yaml = [](const std::string& id, const Vector3d& q) {
        std::ostringstream s;
        s.precision(17);
        s << "  - {id: " << id << ", position: [" << q.x() << ", " << q.y() << ", " << q.z()
          << "], tolerance_mm: 0.2}\n";
        return s.str();
    };
    const std::vector<std::pair<double, double>> cases = {{5.7, 30.0}, {6.3, 200.0}, {5.7, 123.0}};
    std::string landmarks;
    for (std::size_t i = 0; i < cases.size(); ++i)
        landmarks += yaml("b" + std::to_string(i), at(cases[i].first, cases[i].second, 10.0 - 3.0 * double(i)));
    // Depth 5: ΔV = 1.67 mm, so a landmark may lie up to ΔV/4 = 0.42 mm off the surface.
    const PartProgram p = loadStepPart(dir, boxWithBore(), 5, landmarks);
    double worst = 0.0;
    for (std::size_t i = 0; i < cases.size(); ++i) {
        const auto& lm = p.landmarks[i];
        const Vector3d expected = at(kBoreRadius, cases[i].second, 10.0 - 3.0 * double(i));
        const Vector3d inward = (kBoreAxis + Vector3d(0, 0, expected.z()) - expected).normalized();
        const double error = (lm.position - expected).norm();
        worst = std::max(worst, error);
        EXPECT_LT(error, 1e-3) << lm.id; // 1 µm
        const Vector3d radial = lm.position - Vector3d(kBoreAxis.x(), kBoreAxis.y(), lm.position.z());
        EXPECT_NEAR(radial.norm(), kBoreRadius, 1e-3) << lm.id;
        EXPECT_NEAR(lm.distanceToSurfaceMm, 0.3, 1e-3) << lm.id;
        EXPECT_NEAR((lm.normal - inward).norm(), 0.0, 1e-6) << lm.id;
        EXPECT_TRUE(lm.normalFromMesh && lm.onBRep);
    }
    std::cout << "bore: largest snap error " << worst * 1e3 << " µm\n";
}

TEST(StepPart, LandmarksOnAFilletSnapToTheFilletRadiusFromItsAxis)
{
    hgtest::TempDir dir;
    const Vector3d axis(36, 26, 0); // the fillet of the edge x = 40, y = 30
    const double c = std::cos(kPi / 4.0);
    const Vector3d given = axis + Vector3d(4.2 * c, 4.2 * c, 10.0);
    std::ostringstream yaml;
    yaml.precision(17);
    yaml << "  - {id: f, position: [" << given.x() << ", " << given.y() << ", " << given.z()
         << "], tolerance_mm: 0.2}\n";
    const PartProgram p = loadStepPart(dir, filletedBlock(), 5, yaml.str());
    const auto& lm = p.landmarks[0];
    const Vector3d radial = lm.position - Vector3d(axis.x(), axis.y(), lm.position.z());
    std::cout << "fillet: snap error " << std::abs(radial.norm() - kFilletRadius) * 1e3 << " µm\n";
    EXPECT_NEAR(radial.norm(), kFilletRadius, 1e-3);
    EXPECT_NEAR((lm.position - (axis + Vector3d(4 * c, 4 * c, 10))).norm(), 0.0, 1e-3);
    EXPECT_NEAR((lm.normal - Vector3d(c, c, 0)).norm(), 0.0, 1e-6);
}

// `hullgauge landmarks suggest` on a STEP part (docs/part-program.md,
// "Suggesting landmarks"): the box [-20, 20] x [-15, 15] x [0, 30] with a
// bore r = 5 along y about x = 0, z = 18, at the simulated station. The
// model has the cube its part program would derive; every suggestion lies on
// the exact surface (within the 1 µm the B-rep is snapped to) with the exact
// normal: a face's, the bisector on an edge, towards the axis in the bore.
TEST(StepPart, LandmarksSuggestedLieOnTheExactSurfaceWithItsNormals)
{
    hgtest::TempDir dir;
    const TopoDS_Shape box = BRepPrimAPI_MakeBox(gp_Pnt(-20, -15, 0), gp_Pnt(20, 15, 30)).Shape();
    const gp_Ax2 axis(gp_Pnt(0, -16, 18), gp::DY());
    const TopoDS_Shape bored = BRepAlgoAPI_Cut(box, BRepPrimAPI_MakeCylinder(axis, 5.0, 32).Shape()).Shape();
    writeStep(bored, dir / "bored.step");
    const hg::model::CadModel cad = hg::model::loadCadModel(dir / "bored.step", 8, 3);
    ASSERT_TRUE(cad.brep);
    hgtest::writeFile(dir / "part.yaml",
                      programYaml("bored.step", 8, "  - {id: top, position: [0, 0, 30], tolerance_mm: 0.5}\n"));
    const PartProgram program = hg::model::loadPartProgram(dir / "part.yaml");
    EXPECT_TRUE(cad.octree.cubeOrigin.isApprox(program.octree.cubeOrigin));
    EXPECT_DOUBLE_EQ(cad.octree.cubeSize, program.octree.cubeSize);
    EXPECT_EQ(cad.solid->mesh().triangles.size(), program.solid->mesh().triangles.size());

    const auto station = hg::geometry::loadStation(hgtest::sourceDir() / "config/sim/station.yaml");
    hg::plan::SuggestProblem problem;
    problem.solid = cad.solid;
    problem.brep = cad.brep.get();
    problem.station = &station;
    problem.frame = {cad.octree.cubeOrigin, cad.octree.cubeSize, cad.octree.depth};
    const hg::plan::Suggestion s = hg::plan::suggestLandmarks(problem, {});
    ASSERT_EQ(s.landmarks.size(), 8u);
    EXPECT_GT(s.candidates[2], 0u); // the bore's wall and rims
    std::set<hg::plan::FeatureKind> kinds;
    for (const auto& lm : s.landmarks) kinds.insert(lm.candidate.kind);
    EXPECT_EQ(kinds.size(), 3u); // faces, edges and the bore
    for (const auto& lm : s.landmarks) {
        const Vector3d& p = lm.candidate.position;
        // The box's planes the point lies on, and whether it is on the bore's wall.
        Vector3d expected = Vector3d::Zero();
        const Vector3d lo(-20, -15, 0), hi(20, 15, 30);
        for (int a = 0; a < 3; ++a) {
            if (std::abs(p[a] - lo[a]) < 1e-3) expected[a] -= 1.0;
            if (std::abs(p[a] - hi[a]) < 1e-3) expected[a] += 1.0;
        }
        const Vector3d radial(p.x(), 0.0, p.z() - 18.0);
        if (std::abs(radial.norm() - 5.0) < 1e-3) {
            EXPECT_EQ(lm.candidate.kind, hg::plan::FeatureKind::Hole) << lm.id;
            expected = expected.normalized() - radial.normalized();
        }
        ASSERT_GT(expected.norm(), 0.5) << lm.id << " at " << p.transpose() << " is on no face of the part";
        EXPECT_NEAR((lm.candidate.normal - expected.normalized()).norm(), 0.0, 1e-6) << lm.id;
    }
}

// The file's unit is the file's: a part written in metres is read in millimetres.
TEST(StepPart, AFileInMetresIsReadInMillimetres)
{
    hgtest::TempDir dir;
    STEPControl_Controller::Init(); // declares the parameter
    const std::string before = Interface_Static::CVal("write.step.unit");
    ASSERT_TRUE(Interface_Static::SetCVal("write.step.unit", "M"));
    writeStep(steppedBlock(), dir / "m.step");
    Interface_Static::SetCVal("write.step.unit", before.c_str());
    std::ifstream in(dir / "m.step");
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_EQ(text.find(".MILLI."), std::string::npos);
    const auto model = hg::model::StepModel::read(dir / "m.step");
    EXPECT_NEAR(model.summary().volumeMm3, 54000.0, 1e-6);
}

// The STEP part and its STL twin (config/sim), inspected from the same
// frames: the same verdict and landmark statuses, nominal and face-low.
TEST(StepPartCli, InspectedLikeItsStlTwin)
{
    hgtest::TempDir dir;
    const fs::path sim = hgtest::sourceDir() / "config/sim";
    std::ifstream in(sim / "stepped-block.yaml");
    const std::string program((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::string stlLine = "mesh: stepped-block.stl";
    ASSERT_NE(program.find(stlLine), std::string::npos);
    std::string stepProgram = program, stlProgram = program;
    stepProgram.replace(program.find(stlLine), stlLine.size(), "mesh: stepped-block.step");
    stlProgram.replace(program.find(stlLine), stlLine.size(), "mesh: " + (sim / "stepped-block.stl").string());
    writeStep(steppedBlock(), dir / "stepped-block.step");
    hgtest::writeFile(dir / "step.yaml", stepProgram);
    hgtest::writeFile(dir / "stl.yaml", stlProgram);
    for (const std::string variant : {"stepped-block", "stepped-block-face-low"}) {
        const auto views = dir / variant;
        const auto simulate =
            hgtest::run(exe() + " simulate --mesh " + (sim / (variant + ".stl")).string() + " --station " +
                        (sim / "station.yaml").string() + " --poses " + (sim / "stepped-block-views.yaml").string() +
                        " --noise 1.5 --seed 3 --out " + views.string());
        ASSERT_EQ(simulate.status, 0) << simulate.err;
        const std::string inspect = exe() + " inspect --views " + (views / "manifest.json").string() + " --part ";
        const auto step = hgtest::run(inspect + (dir / "step.yaml").string());
        const auto stl = hgtest::run(inspect + (dir / "stl.yaml").string());
        EXPECT_EQ(step.status, variant == "stepped-block" ? 0 : 1) << step.err;
        EXPECT_EQ(step.status, stl.status) << variant;
        const auto js = nlohmann::json::parse(step.out), jl = nlohmann::json::parse(stl.out);
        EXPECT_EQ(js["verdict"], jl["verdict"]);
        ASSERT_EQ(js["landmarks"].size(), jl["landmarks"].size());
        for (std::size_t i = 0; i < js["landmarks"].size(); ++i)
            EXPECT_EQ(js["landmarks"][i]["status"], jl["landmarks"][i]["status"]) << js["landmarks"][i]["id"];
    }
}

TEST(StepPartCli, CheckPartReportsWhatWasRead)
{
    hgtest::TempDir dir;
    writeStep(boxWithBore(), dir / "part.step");
    hgtest::writeFile(dir / "part.yaml",
                      programYaml("part.step", 7, "  - {id: top, position: [10, 5, 20], tolerance_mm: 0.2}\n"));
    const auto r = hgtest::run(exe() + " check-part --json --part " + (dir / "part.yaml").string());
    ASSERT_EQ(r.status, 0) << r.err;
    const auto j = nlohmann::json::parse(r.out);
    const double exact = 24000.0 - kPi * 36.0 * 20.0;
    EXPECT_EQ(j["step"]["solids"], 1);
    EXPECT_GE(j["step"]["faces"].get<int>(), 7);
    EXPECT_NEAR(j["step"]["volume_mm3"].get<double>(), exact, 1e-6 * exact);
    EXPECT_DOUBLE_EQ(j["step"]["linear_deflection_mm"].get<double>(),
                     j["octree"]["voxel_size_mm"].get<double>() / 20.0);
    EXPECT_EQ(j["step"]["triangles"], j["mesh"]["triangles"]);
    EXPECT_EQ(j["landmarks"][0]["on_brep"], true);
    const auto text = hgtest::run(exe() + " check-part --part " + (dir / "part.yaml").string());
    EXPECT_EQ(text.status, 0);
    EXPECT_NE(text.out.find("step        1 solid, "), std::string::npos) << text.out;
    EXPECT_NE(text.out.find("tessellated deflection"), std::string::npos) << text.out;
}

/// check-part on a program whose mesh is `file`: exit 2, one line on stderr naming the file.
std::string refusal(const hgtest::TempDir& dir, const std::string& file)
{
    hgtest::writeFile(dir / "part.yaml",
                      programYaml(file, 5, "  - {id: top, position: [10, 5, 20], tolerance_mm: 0.2}\n"));
    const auto r = hgtest::run(exe() + " check-part --part " + (dir / "part.yaml").string());
    EXPECT_EQ(r.status, 2) << r.out;
    EXPECT_EQ(r.out, "");
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_NE(r.err.find("part.yaml:2: mesh: "), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(file), std::string::npos) << r.err;
    return r.err;
}

TEST(StepPartCli, TruncatedFileIsRefused)
{
    hgtest::TempDir dir;
    writeStep(boxWithBore(), dir / "whole.step");
    std::ifstream in(dir / "whole.step");
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    hgtest::writeFile(dir / "half.step", text.substr(0, text.size() / 2));
    const std::string err = refusal(dir, "half.step");
    EXPECT_NE(err.find("truncated"), std::string::npos) << err;
}

TEST(StepPartCli, FileWithAFaceOrAShellButNoSolidIsRefused)
{
    hgtest::TempDir dir;
    writeStep(BRepBuilderAPI_MakeFace(gp_Pln(gp::XOY()), 0, 10, 0, 10).Shape(), dir / "face.step");
    std::string err = refusal(dir, "face.step");
    EXPECT_NE(err.find("holds no solid, only "), std::string::npos) << err;
    EXPECT_NE(err.find("1 face"), std::string::npos) << err;

    const TopoDS_Shape box = BRepPrimAPI_MakeBox(gp_Pnt(0, 0, 0), gp_Pnt(40, 30, 20)).Shape();
    writeStep(TopExp_Explorer(box, TopAbs_SHELL).Current(), dir / "shell.step");
    err = refusal(dir, "shell.step");
    EXPECT_NE(err.find("holds no solid, only 1 shell, 6 faces"), std::string::npos) << err;
}

// A solid whose shell lacks a face (the box's first, struck from its
// CLOSED_SHELL record: Open CASCADE's writer would write such a solid as a
// bare shell) bounds no volume; the reader's shape healing makes it an open
// shell, refused with its 4 free edges.
TEST(StepPartCli, SolidThatIsNotClosedIsRefused)
{
    hgtest::TempDir dir;
    writeStep(BRepPrimAPI_MakeBox(gp_Pnt(0, 0, 0), gp_Pnt(40, 30, 20)).Shape(), dir / "box.step");
    std::ifstream in(dir / "box.step");
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::size_t shell = text.find("CLOSED_SHELL('',(");
    ASSERT_NE(shell, std::string::npos);
    const std::size_t first = shell + std::string("CLOSED_SHELL('',(").size();
    const std::size_t comma = text.find(',', first);
    ASSERT_NE(comma, std::string::npos);
    text.erase(first, comma + 1 - first);
    hgtest::writeFile(dir / "open.step", text);
    const std::string err = refusal(dir, "open.step");
    EXPECT_NE(err.find("holds no solid, only 1 shell, 5 faces"), std::string::npos) << err;
    EXPECT_NE(err.find("(4 free edges: the surface is not closed)"), std::string::npos) << err;
}

// Assemblies (docs/part-program.md, "STEP parts"): `mesh_solid` chooses one
// solid of the product tree by name. The bracket (box less the bore) and the
// pin (r = 5, 30 long) placed at (100, 0, 0).
std::string assemblyProgram(const std::string& solidLine, const std::string& landmarks)
{
    return "part: p\nmesh: assembly.step\n" + solidLine + "octree:\n  depth: 7\n  adjacency_depth: 3\nlandmarks:\n" +
           landmarks;
}

PartProgram loadAssemblyPart(const hgtest::TempDir& dir, const std::string& solidLine, const std::string& landmarks)
{
    hgtest::writeFile(dir / "part.yaml", assemblyProgram(solidLine, landmarks));
    return hg::model::loadPartProgram(dir / "part.yaml");
}

/// The exact bounding box (BRepBndLib's optimal box) is `box` within 1 nm.
void expectBox(const Eigen::AlignedBox3d& bounds, const Eigen::AlignedBox3d& box)
{
    EXPECT_NEAR((bounds.min() - box.min()).norm(), 0.0, 1e-6) << bounds.min().transpose();
    EXPECT_NEAR((bounds.max() - box.max()).norm(), 0.0, 1e-6) << bounds.max().transpose();
}

const double kPinVolume = kPi * hgtest::kPinRadius * hgtest::kPinRadius * hgtest::kPinLength;
const double kBracketVolume = 40.0 * 30.0 * 20.0 - kPi * kBoreRadius * kBoreRadius * 20.0;

TEST(StepAssembly, MeshSolidPinIsTheCylinderAlonePlacedByItsInstance)
{
    hgtest::TempDir dir;
    hgtest::writeBracketAndPin(dir / "assembly.step");
    const PartProgram p =
        loadAssemblyPart(dir, "mesh_solid: pin\n", "  - {id: cap, position: [100, 0, 30], tolerance_mm: 0.2}\n");
    ASSERT_TRUE(p.brep);
    EXPECT_EQ(p.meshSolid, "pin");
    const auto& s = p.brep->summary();
    EXPECT_EQ(s.chosen, "pin");
    EXPECT_EQ(s.solids, 2u);
    ASSERT_EQ(s.tree.size(), 2u);
    EXPECT_EQ(s.tree[0].name, "bracket");
    EXPECT_EQ(s.tree[1].name, "pin");
    // The writer's link to the product ("=>[0:1:1:2]") is no instance name.
    EXPECT_EQ(s.tree[0].instance, "");
    EXPECT_FALSE(s.tree[0].chosen);
    EXPECT_TRUE(s.tree[1].chosen);
    EXPECT_NEAR(s.tree[0].volumeMm3, kBracketVolume, 1e-6 * kBracketVolume);
    EXPECT_NEAR(s.volumeMm3, kPinVolume, 1e-6 * kPinVolume);
    const Eigen::AlignedBox3d cylinder(Vector3d(95, -5, 0), Vector3d(105, 5, 30));
    expectBox(s.bounds, cylinder);
    // The tessellation of a convex cylinder lies inside it by at most (curved area) · δ.
    const double mesh = p.solid->mesh().signedVolume();
    const double bound = 2.0 * kPi * hgtest::kPinRadius * hgtest::kPinLength * p.tessellationDeflectionMm();
    std::cout << "pin: mesh volume error " << mesh - kPinVolume << " mm³ (bound " << bound << ")\n";
    EXPECT_LT(mesh, kPinVolume);
    EXPECT_LT(kPinVolume - mesh, bound);
    const Eigen::AlignedBox3d meshBounds = p.solid->mesh().bounds();
    EXPECT_TRUE(cylinder.contains(meshBounds));
    EXPECT_NEAR((p.landmarks[0].normal - Vector3d(0, 0, 1)).norm(), 0.0, 1e-9);
}

TEST(StepAssembly, WithoutMeshSolidThePartIsTheUnionOfAllSolids)
{
    hgtest::TempDir dir;
    hgtest::writeBracketAndPin(dir / "assembly.step");
    const PartProgram p = loadAssemblyPart(dir, "", "  - {id: top, position: [10, 5, 20], tolerance_mm: 0.2}\n");
    const auto& s = p.brep->summary();
    EXPECT_EQ(s.chosen, "");
    EXPECT_EQ(s.solids, 2u);
    EXPECT_NEAR(s.volumeMm3, kBracketVolume + kPinVolume, 1e-6 * (kBracketVolume + kPinVolume));
    expectBox(s.bounds, Eigen::AlignedBox3d(Vector3d(0, -5, 0), Vector3d(105, 30, 30)));
    const double bore = 2.0 * kPi * kBoreRadius * 20.0, pin = 2.0 * kPi * hgtest::kPinRadius * hgtest::kPinLength;
    EXPECT_LT(std::abs(p.solid->mesh().signedVolume() - s.volumeMm3), (bore + pin) * p.tessellationDeflectionMm());
}

/// loadPartProgram's refusal, as text ("part.yaml:3: mesh_solid: ...").
std::string refusedProgram(const fs::path& file)
{
    try {
        hg::model::loadPartProgram(file);
    } catch (const hg::InputError& e) {
        return e.what();
    }
    ADD_FAILURE() << file << " was accepted";
    return {};
}

TEST(StepAssembly, AnUnknownNameIsRefusedAtItsLineListingTheNames)
{
    hgtest::TempDir dir;
    hgtest::writeBracketAndPin(dir / "assembly.step");
    hgtest::writeFile(dir / "part.yaml", assemblyProgram("mesh_solid: nut\n",
                                                         "  - {id: top, position: [10, 5, 20], tolerance_mm: 0.2}\n"));
    const std::string err = refusedProgram(dir / "part.yaml");
    EXPECT_NE(err.find("part.yaml:3: mesh_solid: "), std::string::npos) << err;
    EXPECT_NE(err.find("no solid named 'nut'; the file's 2 solids are: 'bracket', 'pin'"), std::string::npos) << err;
}

// A product without a name is called "solid N", N its place in the file's
// order; the third product here, a 5 mm cube placed at (-100, 0, 0).
TEST(StepAssembly, AnUnnamedSolidIsCalledByItsPlaceInTheFile)
{
    hgtest::TempDir dir;
    const TopoDS_Shape cube = BRepPrimAPI_MakeBox(5.0, 5.0, 5.0).Shape();
    hgtest::writeStepAssembly({{"bracket", hgtest::bracketShape(), {{"", Vector3d::Zero()}}},
                               {"pin", hgtest::pinShape(), {{"", Vector3d(100, 0, 0)}}},
                               {"", cube, {{"", Vector3d(-100, 0, 0)}}}},
                              dir / "assembly.step");
    const PartProgram p =
        loadAssemblyPart(dir, "mesh_solid: solid 3\n", "  - {id: top, position: [-97.5, 2.5, 5], tolerance_mm: 0.2}\n");
    const auto& s = p.brep->summary();
    ASSERT_EQ(s.tree.size(), 3u);
    EXPECT_EQ(s.tree[2].name, "solid 3");
    EXPECT_TRUE(s.tree[2].chosen);
    EXPECT_NEAR(s.volumeMm3, 125.0, 1e-9);
    expectBox(s.bounds, Eigen::AlignedBox3d(Vector3d(-100, 0, 0), Vector3d(-95, 5, 5)));
}

// Two instances of one product: its name is ambiguous, an instance's name is not.
TEST(StepAssembly, AProductPlacedTwiceIsAmbiguousAndItsInstanceNamesChoose)
{
    hgtest::TempDir dir;
    hgtest::writeStepAssembly(
        {{"bracket", hgtest::bracketShape(), {{"", Vector3d::Zero()}}},
         {"pin", hgtest::pinShape(), {{"pin:1", Vector3d(100, 0, 0)}, {"pin:2", Vector3d(0, 100, 0)}}}},
        dir / "assembly.step");
    hgtest::writeFile(dir / "part.yaml", assemblyProgram("mesh_solid: pin\n",
                                                         "  - {id: cap, position: [0, 100, 30], tolerance_mm: 0.2}\n"));
    const std::string err = refusedProgram(dir / "part.yaml");
    EXPECT_NE(err.find("part.yaml:3: mesh_solid: "), std::string::npos) << err;
    EXPECT_NE(err.find("'pin' names 2 solids (ambiguous): 'pin' (instance 'pin:1'), 'pin' (instance 'pin:2')"),
              std::string::npos)
        << err;
    const PartProgram p =
        loadAssemblyPart(dir, "mesh_solid: pin:2\n", "  - {id: cap, position: [0, 100, 30], tolerance_mm: 0.2}\n");
    const auto& s = p.brep->summary();
    EXPECT_NEAR(s.volumeMm3, kPinVolume, 1e-6 * kPinVolume);
    expectBox(s.bounds, Eigen::AlignedBox3d(Vector3d(-5, 95, 0), Vector3d(5, 105, 30)));
    EXPECT_TRUE(s.tree[2].chosen);
    EXPECT_EQ(s.tree[2].instance, "pin:2");
}

TEST(StepAssembly, MeshSolidOnAMeshFileIsRefusedNamingWhy)
{
    hgtest::TempDir dir;
    hgtest::writeFile(dir / "part.yaml",
                      "part: p\nmesh: " + (hgtest::sourceDir() / "config/sim/stepped-block.stl").string() +
                          "\nmesh_solid: pin\noctree:\n  depth: 5\n  adjacency_depth: 3\n"
                          "landmarks:\n  - {id: t, position: [15, 0, 15], tolerance_mm: 0.2}\n");
    const std::string err = refusedProgram(dir / "part.yaml");
    EXPECT_NE(err.find("part.yaml:3: mesh_solid: stepped-block.stl is a mesh (STL, OBJ, PLY or OFF)"),
              std::string::npos)
        << err;
}

// `hullgauge landmarks suggest --solid` reads the model as mesh_solid does.
TEST(StepAssembly, CadModelOfOneSolidIsThatSolidAndItsTessellation)
{
    hgtest::TempDir dir;
    hgtest::writeBracketAndPin(dir / "assembly.step");
    const hg::model::CadModel cad = hg::model::loadCadModel(dir / "assembly.step", 7, 3, "pin");
    ASSERT_TRUE(cad.brep);
    EXPECT_NEAR(cad.brep->summary().volumeMm3, kPinVolume, 1e-6 * kPinVolume);
    EXPECT_TRUE(Eigen::AlignedBox3d(Vector3d(95, -5, 0), Vector3d(105, 5, 30)).contains(cad.solid->mesh().bounds()));
    try {
        hg::model::loadCadModel(dir / "assembly.step", 7, 3, "nut");
        ADD_FAILURE() << "an unknown solid was accepted";
    } catch (const hg::InputError& e) {
        EXPECT_EQ(e.field(), "--solid");
        EXPECT_NE(e.problem().find("'bracket', 'pin'"), std::string::npos) << e.what();
    }
    EXPECT_THROW(hg::model::loadCadModel(hgtest::sourceDir() / "config/sim/stepped-block.stl", 7, 3, "pin"),
                 hg::InputError);
}

// The sphere of r = 5 mm Open CASCADE writes (tests/fuzz/corpus/step/sphere.step);
// @BOUNDS@ stands for more bounds of its one face after #18.
const std::string kSphereStep = "ISO-10303-21;\n"
                                "HEADER;\n"
                                "FILE_DESCRIPTION(('Open CASCADE Model'),'2;1');\n"
                                "FILE_NAME('Open CASCADE Shape Model','2026-01-01T00:00:00',('Author'),(\n"
                                "    'Open CASCADE'),'Open CASCADE STEP processor 7.6','Open CASCADE 7.6'\n"
                                "  ,'Unknown');\n"
                                "FILE_SCHEMA(('AUTOMOTIVE_DESIGN { 1 0 10303 214 1 1 1 1 }'));\n"
                                "ENDSEC;\n"
                                "DATA;\n"
                                "#1 = APPLICATION_PROTOCOL_DEFINITION('international standard',\n"
                                "  'automotive_design',2000,#2);\n"
                                "#2 = APPLICATION_CONTEXT(\n"
                                "  'core data for automotive mechanical design processes');\n"
                                "#3 = SHAPE_DEFINITION_REPRESENTATION(#4,#10);\n"
                                "#4 = PRODUCT_DEFINITION_SHAPE('','',#5);\n"
                                "#5 = PRODUCT_DEFINITION('design','',#6,#9);\n"
                                "#6 = PRODUCT_DEFINITION_FORMATION('','',#7);\n"
                                "#7 = PRODUCT('Open CASCADE STEP translator 7.6 5',\n"
                                "  'Open CASCADE STEP translator 7.6 5','',(#8));\n"
                                "#8 = PRODUCT_CONTEXT('',#2,'mechanical');\n"
                                "#9 = PRODUCT_DEFINITION_CONTEXT('part definition',#2,'design');\n"
                                "#10 = ADVANCED_BREP_SHAPE_REPRESENTATION('',(#11,#15),#27);\n"
                                "#11 = AXIS2_PLACEMENT_3D('',#12,#13,#14);\n"
                                "#12 = CARTESIAN_POINT('',(0.,0.,0.));\n"
                                "#13 = DIRECTION('',(0.,0.,1.));\n"
                                "#14 = DIRECTION('',(1.,0.,-0.));\n"
                                "#15 = MANIFOLD_SOLID_BREP('',#16);\n"
                                "#16 = CLOSED_SHELL('',(#17));\n"
                                "#17 = ADVANCED_FACE('',(#18@BOUNDS@),#22,.T.);\n"
                                "#18 = FACE_BOUND('',#19,.T.);\n"
                                "#19 = VERTEX_LOOP('',#20);\n"
                                "#20 = VERTEX_POINT('',#21);\n"
                                "#21 = CARTESIAN_POINT('',(3.061616997868E-16,-7.498798913309E-32,-5.));\n"
                                "#22 = SPHERICAL_SURFACE('',#23,5.);\n"
                                "#23 = AXIS2_PLACEMENT_3D('',#24,#25,#26);\n"
                                "#24 = CARTESIAN_POINT('',(0.,0.,0.));\n"
                                "#25 = DIRECTION('',(0.,0.,1.));\n"
                                "#26 = DIRECTION('',(1.,0.,-0.));\n"
                                "#27 = ( GEOMETRIC_REPRESENTATION_CONTEXT(3) \n"
                                "GLOBAL_UNCERTAINTY_ASSIGNED_CONTEXT((#31)) GLOBAL_UNIT_ASSIGNED_CONTEXT(\n"
                                "(#28,#29,#30)) REPRESENTATION_CONTEXT('Context #1',\n"
                                "  '3D Context with UNIT and UNCERTAINTY') );\n"
                                "#28 = ( LENGTH_UNIT() NAMED_UNIT(*) SI_UNIT(.MILLI.,.METRE.) );\n"
                                "#29 = ( NAMED_UNIT(*) PLANE_ANGLE_UNIT() SI_UNIT($,.RADIAN.) );\n"
                                "#30 = ( NAMED_UNIT(*) SI_UNIT($,.STERADIAN.) SOLID_ANGLE_UNIT() );\n"
                                "#31 = UNCERTAINTY_MEASURE_WITH_UNIT(LENGTH_MEASURE(1.E-07),#28,\n"
                                "  'distance_accuracy_value','confusion accuracy');\n"
                                "#32 = PRODUCT_RELATED_PRODUCT_CATEGORY('part',$,(#7));\n"
                                "ENDSEC;\n"
                                "END-ISO-10303-21;\n";

std::string sphereStep(const std::string& moreBounds)
{
    std::string text = kSphereStep;
    text.replace(text.find("@BOUNDS@"), 8, moreBounds);
    return text;
}

// Found by the STEP harness (docs/fuzzing.md): a face bound naming an entity
// the file does not hold (#99) was loaded as a null that Open CASCADE's
// transfer dereferenced (a segmentation fault in StepShape_FaceBound::Bound).
TEST(StepPart, ReferenceToAnEntityTheFileDoesNotHoldIsRefusedNamingTheEntity)
{
    hgtest::TempDir dir;
    hgtest::writeFile(dir / "dangling.step", sphereStep(",#99"));
    try {
        (void)hg::model::StepModel::read(dir / "dangling.step");
        FAIL() << "a dangling reference was read";
    } catch (const hg::InputError& e) {
        const std::string what = e.what();
        EXPECT_NE(what.find("not a consistent STEP file: entity #17: "), std::string::npos) << what;
        EXPECT_NE(what.find("face_bound"), std::string::npos) << what;
    }
    // The same file without the second bound is the sphere: 4/3 pi r^3.
    hgtest::writeFile(dir / "sphere.step", sphereStep(""));
    const auto sphere = hg::model::StepModel::read(dir / "sphere.step");
    EXPECT_NEAR(sphere.summary().volumeMm3, 4.0 / 3.0 * kPi * 125.0, 1e-6 * 524.0);
    EXPECT_EQ(sphere.summary().solids, 1u);
}

/// The bored box seed with its first `from` replaced by `to`, written as `name` in `dir`.
fs::path boreBoxWith(const hgtest::TempDir& dir, const std::string& name, const std::string& from,
                     const std::string& to)
{
    std::ifstream in(hgtest::sourceDir() / "tests/fuzz/corpus/step/box-with-bore.step");
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    return hgtest::writeFile(dir / name, hgtest::replaced(text, from, to));
}

/// What StepModel::read says refusing `file`; a failure of the test when it reads it.
std::string readRefusal(const fs::path& file)
{
    try {
        (void)hg::model::StepModel::read(file);
    } catch (const hg::InputError& e) {
        return e.what();
    }
    ADD_FAILURE() << file << " was read";
    return "";
}

// Found by the STEP harness (docs/fuzzing.md): an oriented edge that is its
// own edge (the fuzzed file's #346 named an entity the file lost, which
// Open CASCADE's reader resolved to the oriented edge itself) sent the
// reader's own checks into endless recursion, a stack overflow inside its
// ReadFile. The checks now run between the parse and the reader's.
TEST(StepPart, AnOrientedEdgeThatIsItsOwnEdgeIsRefusedNamingIt)
{
    hgtest::TempDir dir;
    const std::string err = readRefusal(
        boreBoxWith(dir, "loop.step", "#20 = ORIENTED_EDGE('',*,*,#21,.F.);", "#20 = ORIENTED_EDGE('',*,*,#20,.F.);"));
    EXPECT_NE(err.find("entity #20 refers to itself (#20 -> #20)"), std::string::npos) << err;
    // The fuzzed file itself, kept as a seed of the harness.
    EXPECT_THROW(
        hg::model::StepModel::read(hgtest::sourceDir() / "tests/fuzz/corpus/step/oriented-edge-its-own-edge.step"),
        hg::InputError);
}

// Found by the STEP harness (docs/fuzzing.md): a surface curve whose 3D
// curve was itself (#349 of the fuzzed file) overflowed the stack in Open
// CASCADE's StepToGeom::MakeCurve during the transfer. Any cycle of
// references is refused before the transfer, naming the entities around it.
TEST(StepPart, AnEntityThatRefersToItselfIsRefusedNamingTheCycle)
{
    hgtest::TempDir dir;
    const std::string own = "#26 = SURFACE_CURVE('',#27,(#31,#43),.PCURVE_S1.);";
    std::string err =
        readRefusal(boreBoxWith(dir, "own.step", own, "#26 = SURFACE_CURVE('',#26,(#31,#43),.PCURVE_S1.);"));
    EXPECT_NE(err.find("entity #26 refers to itself (#26 -> #26)"), std::string::npos) << err;
    // Through another: #26's 3D curve #27 made a surface curve whose 3D curve is #26.
    err = readRefusal(
        boreBoxWith(dir, "two.step", "#27 = LINE('',#28,#29);", "#27 = SURFACE_CURVE('',#26,(#31,#43),.PCURVE_S1.);"));
    EXPECT_TRUE(err.find("(#26 -> #27 -> #26)") != std::string::npos ||
                err.find("(#27 -> #26 -> #27)") != std::string::npos)
        << err;
    // The fuzzed file, kept as a seed of the harness.
    err = readRefusal(hgtest::sourceDir() / "tests/fuzz/corpus/step/surface-curve-its-own-curve.step");
    EXPECT_NE(err.find("entity #349 refers to itself (#349 -> #349)"), std::string::npos) << err;
}

// Found by the STEP harness (docs/fuzzing.md): a fuzzed stepped block that
// names 36 instances twice hung in Open CASCADE's parser (its second pass over
// the references, on tables it leaves partly unset), and only as what memory
// held had it. A name defined twice is refused before the parse, naming both
// lines; a name in a string or a comment is no definition.
TEST(StepPart, AnEntityDefinedTwiceIsRefusedNamingBothLines)
{
    hgtest::TempDir dir;
    const std::string line27 = "#27 = LINE('',#28,#29);"; // line 39 of the file
    std::string err = readRefusal(boreBoxWith(dir, "twice.step", line27, line27 + "\n" + line27));
    EXPECT_NE(err.find("not a consistent STEP file: entity #27 is defined twice (lines 39 and 40)"), std::string::npos)
        << err;
    // Leading zeros name the same instance.
    err = readRefusal(boreBoxWith(dir, "zeros.step", line27, line27 + "\n#0027 = LINE('',#28,#29);"));
    EXPECT_NE(err.find("entity #27 is defined twice (lines 39 and 40)"), std::string::npos) << err;
    // The name in a comment over two lines and in a string with a quote in it
    // is no definition: the box is read, 40 x 30 x 20 mm less its bore of 6 mm.
    const auto box = hg::model::StepModel::read(boreBoxWith(
        dir, "quoted.step", line27, "/* #27 = LINE,\n #28 = x; */ #27 = LINE('#27 = it''s ''#28 = ('';',#28,#29);"));
    EXPECT_NEAR(box.summary().volumeMm3, kBracketVolume, 1e-6 * kBracketVolume);
    // The fuzzed file, kept as a seed: its first repeated name at depth 0 is #22
    // (its #21 repeats inside the parentheses of an entity the garbling left open).
    err = readRefusal(hgtest::sourceDir() / "tests/fuzz/corpus/step/instances-defined-twice.step");
    EXPECT_NE(err.find("entity #22 is defined twice (lines 35 and 71)"), std::string::npos) << err;
}

// Found by the STEP harness (docs/fuzzing.md): a pcurve whose definitional
// representation's item had a garbled entity name was translated as a null
// 2D curve and dereferenced in Open CASCADE's StepToGeom::MakeCurve2d.
TEST(StepPart, APcurveWhoseRepresentationHoldsNoCurveIsRefusedNamingIt)
{
    hgtest::TempDir dir;
    // #388 is the bore's pcurve on the cylinder, #389 its representation, #390 its line.
    std::string err = readRefusal(boreBoxWith(dir, "point.step", "#389 = DEFINITIONAL_REPRESENTATION('',(#390),#394);",
                                              "#389 = DEFINITIONAL_REPRESENTATION('',(#391),#394);"));
    EXPECT_NE(err.find("entity #388: a curve in a face's parameters whose representation does not begin with a curve"),
              std::string::npos)
        << err;
    // The fuzzed file, kept as a seed: its garbled name is no keyword, refused before the parse.
    err = readRefusal(hgtest::sourceDir() / "tests/fuzz/corpus/step/pcurve-item-garbled.step");
    EXPECT_NE(err.find("entity #390 (line 456): no entity type after '='"), std::string::npos) << err;
}

// Found by the STEP harness (docs/fuzzing.md): `#21 =
// 14StepShape_EdgeEDGE_CURVE(...)`, an entity type that is no keyword, was
// loaded by Open CASCADE's parser as a null it dereferenced while still
// parsing. The text is checked first: a keyword or a complex instance's '('.
TEST(StepPart, AnInstanceWhoseTypeIsNoKeywordIsRefusedNamingIt)
{
    hgtest::TempDir dir;
    const std::string edge = "#21 = EDGE_CURVE('',#22,#24,#26,.T.);"; // line 33 of the file
    std::string err = readRefusal(boreBoxWith(dir, "digits.step", edge, "#21 = 14EDGE_CURVE('',#22,#24,#26,.T.);"));
    EXPECT_NE(err.find("entity #21 (line 33): no entity type after '=', found '14EDGE_CURVE('','"), std::string::npos)
        << err;
    // A name the reader's int cannot hold, defined or referred to: refused
    // from 2^31 on, where it wrapped into the reader's markers for lists.
    err = readRefusal(boreBoxWith(dir, "big.step", edge, "#2147483648 = EDGE_CURVE('',#22,#24,#26,.T.);"));
    EXPECT_NE(err.find("line 33: the entity name #2147483648 is beyond 2147483647"), std::string::npos) << err;
    err = readRefusal(boreBoxWith(dir, "bigref.step", edge, "#21 = EDGE_CURVE('',#0200000000266,#24,#26,.T.);"));
    EXPECT_NE(err.find("line 33: the entity name #200000000266 is beyond 2147483647"), std::string::npos) << err;
    err = readRefusal(boreBoxWith(dir, "maxref.step", edge, "#21 = EDGE_CURVE('',#2147483647,#24,#26,.T.);"));
    EXPECT_EQ(err.find("beyond"), std::string::npos) << err; // the largest int: a dangling reference, not beyond
    // A complex instance: the keyword of its first part after its own '('.
    err = readRefusal(boreBoxWith(dir, "complex.step", "#42 = ( GEOMETRIC_REPRESENTATION_CONTEXT(2) ",
                                  "#42 = ( 2D GEOMETRIC_REPRESENTATION_CONTEXT(2) "));
    EXPECT_NE(err.find("entity #42 (line 54): no entity type after '=', found '( 2D GEOMETRIC_R'"), std::string::npos)
        << err;
    // The fuzzed file, kept as a seed: a name of 12 digits among its garbled lines.
    err = readRefusal(hgtest::sourceDir() / "tests/fuzz/corpus/step/entity-name-beyond-int.step");
    EXPECT_NE(err.find("the entity name #200000000266 is beyond 2147483647"), std::string::npos) << err;
    // A keyword may stand apart from its parameters, on the next line too.
    const auto box =
        hg::model::StepModel::read(boreBoxWith(dir, "apart.step", edge, "#21 = EDGE_CURVE \n ('',#22,#24,#26,.T.);"));
    EXPECT_NEAR(box.summary().volumeMm3, kBracketVolume, 1e-6 * kBracketVolume);
    // The fuzzed file, kept as a seed.
    err = readRefusal(hgtest::sourceDir() / "tests/fuzz/corpus/step/entity-type-not-a-keyword.step");
    EXPECT_NE(err.find("no entity type after '=', found '14StepShape_Edge"), std::string::npos) << err;
}

TEST(StepPart, AVertexWhosePointIsNotACartesianPointIsRefusedNamingIt)
{
    hgtest::TempDir dir;
    // The vertex's point a point on its edge's line: a point, but not a cartesian one.
    std::string err = readRefusal(
        boreBoxWith(dir, "vertex.step", "#23 = CARTESIAN_POINT('',(0.,0.,0.));", "#23 = POINT_ON_CURVE('',#27,0.);"));
    EXPECT_NE(err.find("entity #22: a vertex whose point is not a cartesian point"), std::string::npos) << err;
    // A cartesian point without its coordinates, as the parser read the fuzzed
    // file's garbled point.
    err = readRefusal(
        boreBoxWith(dir, "empty.step", "#23 = CARTESIAN_POINT('',(0.,0.,0.));", "#23 = CARTESIAN_POINT('',());"));
    EXPECT_NE(err.find("entity #22: a vertex whose point is not a cartesian point of three"), std::string::npos) << err;
    // The fuzzed file, kept as a seed: its garbled name is no keyword, refused before the parse.
    err = readRefusal(hgtest::sourceDir() / "tests/fuzz/corpus/step/vertex-point-garbled.step");
    EXPECT_NE(err.find("entity #196 (line 232): no entity type after '='"), std::string::npos) << err;
}

// Found with the STEP harness (docs/fuzzing.md): a part placed a kilometre
// from its origin, 10^12 weld tolerances, overflowed the weld's integer cell
// hash (signed overflow, undefined behaviour; meaningful under the `asan`
// preset). The box's six faces tessellate into 12 triangles on 4 points
// each, which the weld merges into the box's 8 corners.
TEST(StepPart, PartAKilometreFromItsOriginIsWeldedIntoItsCorners)
{
    hgtest::TempDir dir;
    const gp_Pnt low(1e6, 0, 0), high(1e6 + 40, 30, 20);
    writeStep(BRepPrimAPI_MakeBox(low, high).Shape(), dir / "far.step");
    auto part = hg::model::StepModel::read(dir / "far.step");
    EXPECT_NEAR(part.summary().volumeMm3, 40.0 * 30.0 * 20.0, 1e-6 * 24000.0);
    const hg::model::TriangleMesh mesh = part.tessellate(0.05, 0.1);
    EXPECT_EQ(mesh.triangles.size(), 12u);
    ASSERT_EQ(mesh.vertices.size(), 8u);
    for (const Vector3d& v : mesh.vertices) {
        EXPECT_TRUE(v.x() == low.X() || v.x() == high.X()) << v.transpose();
        EXPECT_TRUE(v.y() == low.Y() || v.y() == high.Y()) << v.transpose();
        EXPECT_TRUE(v.z() == low.Z() || v.z() == high.Z()) << v.transpose();
    }
}

// StepModel::read answers from its child process what the read in this
// process finds: the same summary, and the same exact surface.
TEST(StepPart, ReadInAProcessOfItsOwnIsTheReadInThisProcess)
{
    const fs::path file = hgtest::sourceDir() / "tests/fuzz/corpus/step/box-with-bore.step";
    const auto here = hg::model::StepModel::readInThisProcess(file);
    const auto apart = hg::model::StepModel::read(file);
    EXPECT_EQ(apart.summary().solids, here.summary().solids);
    EXPECT_EQ(apart.summary().faces, here.summary().faces);
    EXPECT_EQ(apart.summary().volumeMm3, here.summary().volumeMm3);
    EXPECT_TRUE(apart.summary().bounds.isApprox(here.summary().bounds, 0.0)) << "bounds differ";
    ASSERT_EQ(apart.summary().tree.size(), here.summary().tree.size());
    EXPECT_EQ(apart.summary().tree[0].name, here.summary().tree[0].name);
    // A point on the bore's wall (radius 6 about (20, 15)) and one off a flat face.
    for (const Vector3d& q : {Vector3d(20.0 + 5.0, 15.0, 10.0), Vector3d(-1.0, 10.0, 10.0)}) {
        const auto a = apart.closestPoint(q, 0.01), h = here.closestPoint(q, 0.01);
        EXPECT_LT((a.point - h.point).norm(), 1e-9) << q.transpose();
        EXPECT_LT((a.normal - h.normal).norm(), 1e-9) << q.transpose();
        EXPECT_NEAR(a.distance, h.distance, 1e-9);
    }
}

// Found by the STEP harness (docs/fuzzing.md): a garbled bored box that sends
// Open CASCADE's reader of entities it does not know into endless recursion
// (StepData_UndefinedEntity::ReadRecord), a fault no check before the reader
// names. Read as the programs read it, in a process of its own, it is a
// refusal naming the signal, and the caller goes on reading.
TEST(StepPart, AFaultOfTheReaderIsARefusalNamingTheSignalAndTheCallerGoesOn)
{
    const std::string err = readRefusal(hgtest::sourceDir() / "tests/model/data/reader-stack-overflow.step");
#if defined(__SANITIZE_ADDRESS__)
    // AddressSanitizer catches the overflow in the child and ends it with status 1.
    EXPECT_NE(err.find("the reader's process failed: the child ended with status 1"), std::string::npos) << err;
#else
    EXPECT_NE(err.find("Open CASCADE's reader ended with signal 11 ("), std::string::npos) << err;
#endif
    const auto box = hg::model::StepModel::read(hgtest::sourceDir() / "tests/fuzz/corpus/step/box-with-bore.step");
    EXPECT_NEAR(box.summary().volumeMm3, kBracketVolume, 1e-6 * kBracketVolume);
}

TEST(StepPart, MissingFileIsAnInputErrorNamingIt)
{
    hgtest::TempDir dir;
    EXPECT_THROW(hg::model::StepModel::read(dir / "none.stp"), hg::InputError);
    EXPECT_TRUE(hg::model::isStepFile("A.STP"));
    EXPECT_FALSE(hg::model::isStepFile("a.stl"));
}

} // namespace
