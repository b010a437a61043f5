// Part program loading (docs/contracts.md §1): the fields, the derived cube and
// normals, and a precise error (file, line, field) for each kind of mistake.
#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "hgtest/paths.h"
#include "hullgauge/common/error.h"
#include "hullgauge/model/mesh_io.h"
#include "hullgauge/model/part_program.h"
#include "hullgauge/model/primitives.h"

namespace hg::model {
namespace {

using Eigen::Vector3d;

// A 10 x 10 x 10 mm block at the origin, beside the YAML that names it.
class PartProgramTest : public ::testing::Test {
  protected:
    void SetUp() override
    {
        std::filesystem::create_directories(dir / "meshes");
        saveMesh(makeBox(Vector3d(0, 0, 0), Vector3d(10, 10, 10)), dir / "meshes/block.stl");
    }

    std::filesystem::path write(const std::string& yaml) { return hgtest::writeFile(dir / "part.yaml", yaml); }

    InputError error(const std::string& yaml)
    {
        try {
            loadPartProgram(write(yaml));
        } catch (const InputError& e) {
            return e;
        }
        ADD_FAILURE() << "no error for:\n" << yaml;
        return InputError("", "", "");
    }

    hgtest::TempDir dir;
};

const std::string kGood = R"(part: block-1
mesh: meshes/block.stl
octree:
  depth: 6
  adjacency_depth: 3
landmarks:
  - id: face
    position: [10, 5, 5]
    tolerance_mm: 0.2
  - id: corner
    position: [10, 10, 10]
    tolerance_mm: 0.3
    best_views:
      - any_of:
          - {rotation_deg: 0, declination_deg: 30}
          - {rotation_deg: 180, declination_deg: 30}
      - {rotation_deg: 90}
  - id: edge
    position: [0, 0, 5]
    normal: [-1, 0, 0]
    tolerance_mm: 0.2
parameters:
  - id: width
    kind: distance
    landmarks: [face, edge]
    nominal_mm: 10
    tolerance_mm: 0.1
  - id: triangle
    kind: area
    landmarks: [face, corner, edge]
    nominal_mm: 70.7
    tolerance_mm: 1
)";

TEST_F(PartProgramTest, LoadsEveryField)
{
    const PartProgram p = loadPartProgram(write(kGood));
    EXPECT_EQ(p.part, "block-1");
    EXPECT_EQ(p.meshFile, dir / "meshes/block.stl");
    ASSERT_TRUE(p.solid);
    // The vertex kept is the one the file writes first (here the top face's): the block with that corner
    // moved, 1000 + 0.05 · 100 / 3 mm³ (the pyramid over the face x = 10).
    TriangleMesh moved = makeBox(Vector3d(0, 0, 0), Vector3d(10, 10, 10));
    moved.vertices[7] = Vector3d(10.05, 10, 10);
    const double volume = p.solid->mesh().signedVolume();
    EXPECT_TRUE(std::abs(volume - 1000.0) < 1e-9 || std::abs(volume - moved.signedVolume()) < 1e-4)
        << volume; // 10.05 in single precision

    // Default cube: 4 voxels (adjacency 3 + 1) of margin around the 10 mm part
    // at depth 6: S = 10 / (1 - 8/64) = 80/7 mm, centred on (5, 5, 5).
    const double S = 80.0 / 7.0;
    EXPECT_TRUE(p.octree.cubeFromMesh);
    EXPECT_NEAR(p.octree.cubeSize, S, 1e-12);
    EXPECT_TRUE(p.octree.cubeOrigin.isApprox(Vector3d::Constant(5.0 - S / 2), 1e-12));
    EXPECT_NEAR(p.octree.voxelSize(), S / 64.0, 1e-15);
    EXPECT_NEAR(p.octree.cubeOrigin.x() + 4 * p.octree.voxelSize(), 0.0, 1e-12); // margin is exactly 4 voxels
    EXPECT_EQ(p.octree.depth, 6);
    EXPECT_EQ(p.octree.adjacencyDepth, 3);
    EXPECT_NEAR(p.surfaceToleranceMm(), S / 64.0 / 4.0, 1e-15);

    ASSERT_EQ(p.landmarks.size(), 3u);
    const Landmark& face = p.landmarks[0];
    EXPECT_TRUE(face.normalFromMesh);
    EXPECT_TRUE(face.normal.isApprox(Vector3d(1, 0, 0), 1e-12));
    EXPECT_DOUBLE_EQ(face.toleranceMm, 0.2);
    const Landmark& corner = *p.findLandmark("corner");
    EXPECT_TRUE(corner.normal.isApprox(Vector3d(1, 1, 1).normalized(), 1e-12)); // corner: the bisector
    ASSERT_EQ(corner.bestViews.size(), 2u);
    ASSERT_EQ(corner.bestViews[0].size(), 2u);
    EXPECT_DOUBLE_EQ(corner.bestViews[0][1].rotationDeg, 180.0);
    EXPECT_DOUBLE_EQ(corner.bestViews[0][1].declinationDeg, 30.0);
    ASSERT_EQ(corner.bestViews[1].size(), 1u);
    EXPECT_DOUBLE_EQ(corner.bestViews[1][0].rotationDeg, 90.0);
    EXPECT_EQ(p.bestViewFixture, geometry::FixtureType::RotationDeclination);
    const Landmark& edge = *p.findLandmark("edge");
    EXPECT_FALSE(edge.normalFromMesh);
    EXPECT_TRUE(edge.normal.isApprox(Vector3d(-1, 0, 0), 1e-15));
    EXPECT_EQ(p.findLandmark("nope"), nullptr);

    ASSERT_EQ(p.parameters.size(), 2u);
    EXPECT_EQ(p.parameters[0].kind, ParameterKind::Distance);
    EXPECT_EQ(p.parameters[0].landmarkIndices, (std::vector<std::size_t>{0, 2}));
    EXPECT_EQ(p.parameters[1].kind, ParameterKind::Area);
}

TEST_F(PartProgramTest, GivenCubeIsKept)
{
    std::string yaml = kGood;
    yaml.replace(yaml.find("  depth: 6"), 10, "  cube_origin: [-3, -3, -3]\n  cube_size: 16\n  depth: 7");
    const PartProgram p = loadPartProgram(write(yaml));
    EXPECT_FALSE(p.octree.cubeFromMesh);
    EXPECT_DOUBLE_EQ(p.octree.voxelSize(), 0.125); // 16 / 2^7, eq. 4.5.1-1
    EXPECT_TRUE(p.octree.cubeOrigin.isApprox(Vector3d(-3, -3, -3)));
    EXPECT_DOUBLE_EQ(p.octree.maxMeasurableErrorMm(), 0.375);
}

TEST_F(PartProgramTest, WrongTypeNamesLineAndField)
{
    std::string yaml = kGood;
    yaml.replace(yaml.find("depth: 6"), 8, "depth: nine");
    const InputError e = error(yaml);
    EXPECT_EQ(e.line(), 4);
    EXPECT_EQ(e.field(), "octree.depth");
    EXPECT_NE(std::string(e.what()).find("part.yaml:4: octree.depth: expected an integer"), std::string::npos)
        << e.what();
}

TEST_F(PartProgramTest, LandmarkOffTheSurfaceNamesIdAndDistance)
{
    std::string yaml = kGood;
    yaml.replace(yaml.find("position: [0, 0, 5]"), 19, "position: [-5, 5, 5]");
    const InputError e = error(yaml);
    EXPECT_EQ(e.field(), "landmarks[2].position");
    EXPECT_EQ(e.line(), 19);
    EXPECT_NE(std::string(e.what()).find(
                  "part.yaml:19: landmarks[2].position: landmark 'edge' is 5.000 mm from the surface (nearest point "
                  "(0.0000, 5.0000, 5.0000)"),
              std::string::npos)
        << e.what();
}

TEST_F(PartProgramTest, LandmarkJustWithinTheSurfaceToleranceIsAccepted)
{
    // Tolerance here is ΔV/4 = 80/7/64/4 ≈ 0.0446 mm.
    std::string yaml = kGood;
    yaml.replace(yaml.find("position: [10, 5, 5]"), 20, "position: [10.04, 5, 5]");
    const PartProgram p = loadPartProgram(write(yaml));
    EXPECT_NEAR(p.landmarks[0].distanceToSurfaceMm, 0.04, 1e-12);
    yaml.replace(yaml.find("position: [10.04, 5, 5]"), 23, "position: [10.05, 5, 5]");
    EXPECT_NE(std::string(error(yaml).what()).find("is 0.050 mm from the surface"), std::string::npos);
}

struct Mistake {
    std::string from, to, expected;
};

// Asymmetric limits instead of a tolerance, and the decision rule at the top
// level (docs/part-program.md; docs/contracts.md §8).
TEST_F(PartProgramTest, LimitsReplaceTheToleranceAndTheDecisionRuleMayStandAtTheTop)
{
    std::string yaml = kGood;
    yaml.replace(yaml.find("tolerance_mm: 0.3"), 17, "limits_mm: [-0.05, 0.15]");
    yaml.replace(yaml.find("part: block-1\n"), 14, "part: block-1\ndecision_rule: simple\n");
    const PartProgram p = loadPartProgram(write(yaml));
    const Landmark& corner = *p.findLandmark("corner");
    ASSERT_TRUE(corner.limitsMm);
    EXPECT_EQ(corner.limitsMm->first, -0.05);
    EXPECT_EQ(corner.limitsMm->second, 0.15);
    EXPECT_DOUBLE_EQ(corner.toleranceMm, 0.1); // half the zone
    EXPECT_FALSE(p.findLandmark("face")->limitsMm);
    EXPECT_TRUE(p.inspection.simpleDecision);
}

// A version a rollback made names the earlier version it puts in force again
// (docs/workbench.md, rollback); only an earlier one.
TEST_F(PartProgramTest, AReleaseRecordMayNameTheVersionItRollsBackFrom)
{
    const std::string record = "release:\n  version: 3\n  verification_sha256: " + std::string(64, 'a') +
                               "\n  released_by: jdoe\n  released_at: 2026-12-07T10:32:05+01:00\n";
    const PartProgram plain = loadPartProgram(write(kGood + record));
    ASSERT_TRUE(plain.release.has_value());
    EXPECT_FALSE(plain.release->rolledBackFrom.has_value());
    const PartProgram rolled = loadPartProgram(write(kGood + record + "  rolled_back_from: 1\n"));
    EXPECT_EQ(rolled.release->rolledBackFrom, 1);
    const InputError e = error(kGood + record + "  rolled_back_from: 3\n");
    EXPECT_EQ(e.field(), "release.rolled_back_from");
    EXPECT_EQ(e.problem(), "version 3 can only roll back to an earlier version, not 3");
}

TEST_F(PartProgramTest, EachMistakeIsNamed)
{
    const std::vector<Mistake> mistakes = {
        {"tolerance_mm: 0.2\n  - id: corner", "tolerence_mm: 0.2\n  - id: corner",
         "landmarks[0].tolerence_mm: unknown key 'tolerence_mm'"},
        {"id: corner", "id: face", "landmarks[1].id: duplicate landmark id 'face'"},
        {"tolerance_mm: 0.3", "tolerance_mm: 0", "landmarks[1].tolerance_mm: expected a positive number"},
        // The inspection map holds 15 levels (its voxel keys keep the level in 4 bits): 16 is refused at loading,
        // not by a fault at every trigger.
        {"depth: 6", "depth: 16", "octree.depth: value 16 is outside [1, 15]"},
        {"depth: 6", "depth: 21", "octree.depth: value 21 is outside [1, 15]"},
        {"adjacency_depth: 3", "adjacency_depth: 0", "octree.adjacency_depth: value 0 is outside"},
        {"depth: 6", "depth: 3", "octree.depth: depth 3 gives 8 voxels per edge, too few"},
        {"landmarks: [face, edge]", "landmarks: [face, nose]", "parameters[0].landmarks[1]: unknown landmark 'nose'"},
        {"landmarks: [face, edge]", "landmarks: [face, edge, corner]",
         "parameters[0].landmarks: a distance needs exactly 2 landmarks, found 3"},
        {"landmarks: [face, corner, edge]", "landmarks: [face, corner]",
         "parameters[1].landmarks: a area needs at least 3 landmarks"},
        {"kind: area", "kind: volume", "parameters[1].kind: unknown kind 'volume'"},
        {"normal: [-1, 0, 0]", "normal: [1, 0, 0]",
         "landmarks[2].normal: normal (1.0000, 0.0000, 0.0000) of landmark "
         "'edge' points into the part"},
        {"normal: [-1, 0, 0]", "normal: [0, 0, 0]", "landmarks[2].normal: normal has zero length"},
        {"- {rotation_deg: 90}", "- {rail_mm: 90}", "best views mix rail poses and rotation/declination poses"},
        {"- {rotation_deg: 90}", "- {rotation_deg: 90, rail_mm: 3}", "either rail_mm or rotation_deg"},
        {"mesh: meshes/block.stl", "mesh: meshes/none.stl", "part.yaml:2: mesh: "},
        {"mesh: meshes/block.stl", "mesh: [a, b]", "mesh: expected a string"},
        {"part: block-1\n", "", "missing required key 'part'"},
        {"  depth: 6\n", "  cube_origin: [0, 0, 0]\n  depth: 6\n", "octree.cube_origin: cube_origin needs cube_size"},
        {"  depth: 6\n", "  cube_origin: [2, 0, 0]\n  cube_size: 16\n  depth: 6\n",
         "octree.cube_origin: the part (bounding box"},
        {"tolerance_mm: 0.3", "tolerance_mm: 0.3\n    limits_mm: [-0.1, 0.2]",
         "landmarks[1].limits_mm: give either tolerance_mm or limits_mm, not both"},
        {"tolerance_mm: 0.3", "limits_mm: [0.2, -0.1]",
         "landmarks[1].limits_mm: expected [lower, upper] with lower < upper"},
        {"tolerance_mm: 0.3", "limits_mm: [0.1]", "landmarks[1].limits_mm: "},
        {"part: block-1\n", "part: block-1\ndecision_rule: careful\n",
         "decision_rule: unknown decision rule 'careful'"},
        {"part: block-1\n", "part: block-1\ndecision_rule: simple\ninspection: {decision_rule: guarded}\n",
         "decision_rule: decision_rule disagrees with inspection.decision_rule"},
    };
    for (const auto& m : mistakes) {
        std::string yaml = kGood;
        const auto at = yaml.find(m.from);
        ASSERT_NE(at, std::string::npos) << m.from;
        yaml.replace(at, m.from.size(), m.to);
        const InputError e = error(yaml);
        EXPECT_NE(std::string(e.what()).find(m.expected), std::string::npos)
            << "expected '" << m.expected << "' in: " << e.what();
        EXPECT_NE(std::string(e.what()).find("part.yaml:"), std::string::npos) << e.what();
        EXPECT_TRUE(e.line().has_value()) << e.what();
    }
}

TEST_F(PartProgramTest, InspectionSectionIsOptionalWithTheToolsDefaults)
{
    const InspectionSettings defaults = loadPartProgram(write(kGood)).inspection;
    EXPECT_EQ(defaults.level, -1);
    EXPECT_EQ(defaults.adjacency, -1);
    EXPECT_FALSE(defaults.centrePointTest);
    EXPECT_TRUE(defaults.requireResolution);
    EXPECT_FALSE(defaults.earlyExit);
    EXPECT_TRUE(defaults.deviation);       // docs/part-program.md: decided on the sub-voxel deviation
    EXPECT_FALSE(defaults.simpleDecision); // guarded

    const InspectionSettings s = loadPartProgram(write(kGood + "inspection:\n  level: 5\n  adjacency: 2\n"
                                                               "  method: centre\n  resolution_check: false\n"
                                                               "  early_exit: true\n  deviation: false\n"
                                                               "  decision_rule: simple\n"))
                                     .inspection;
    EXPECT_EQ(s.level, 5);
    EXPECT_EQ(s.adjacency, 2);
    EXPECT_TRUE(s.centrePointTest);
    EXPECT_FALSE(s.requireResolution);
    EXPECT_TRUE(s.earlyExit);
    EXPECT_FALSE(s.deviation);
    EXPECT_TRUE(s.simpleDecision);
}

TEST_F(PartProgramTest, InspectionSectionMistakesNameLineAndKey)
{
    // kGood has 32 lines: "inspection:" is line 33, its key line 34.
    const std::vector<Mistake> mistakes = {
        {"level: 7", "", "part.yaml:34: inspection.level: value 7 is outside [1, 6]"},
        {"adjacency: 4", "", "part.yaml:34: inspection.adjacency: value 4 is outside [1, 3]"},
        {"method: volume-source", "", "part.yaml:34: inspection.method: unknown method 'volume-source'"},
        {"resolution_check: maybe", "", "part.yaml:34: inspection.resolution_check"},
        {"masked_landmarks: [face]", "", "part.yaml:34: inspection.masked_landmarks: unknown key"},
        {"early_exit: 1.5", "", "part.yaml:34: inspection.early_exit"},
        {"deviation: maybe", "", "part.yaml:34: inspection.deviation: expected true or false"},
        {"decision_rule: lenient", "",
         "part.yaml:34: inspection.decision_rule: unknown decision rule 'lenient' (expected guarded or simple)"},
    };
    for (const auto& m : mistakes) {
        const InputError e = error(kGood + "inspection:\n  " + m.from + "\n");
        EXPECT_NE(std::string(e.what()).find(m.expected), std::string::npos)
            << "expected '" << m.expected << "' in: " << e.what();
    }
}

TEST_F(PartProgramTest, AlignmentSectionIsOptionalWithSilhouetteWithinOneMillimetreAndOneDegree)
{
    const AlignmentSettings defaults = loadPartProgram(write(kGood)).alignment;
    EXPECT_EQ(defaults.method, AlignmentMethod::Silhouette);
    EXPECT_TRUE(defaults.datums.empty());
    EXPECT_DOUBLE_EQ(defaults.maxShiftMm, 1.0);
    EXPECT_DOUBLE_EQ(defaults.maxRotationDeg, 1.0);
    EXPECT_EQ(defaults.correctPosesAfter, 2); // the daemon corrects poses after the first two views

    const AlignmentSettings d = loadPartProgram(write(kGood + "alignment:\n  method: datums\n"
                                                              "  datums: [edge, face, corner]\n"
                                                              "  max_shift_mm: 0.5\n  max_rotation_deg: 10\n"
                                                              "  correct_poses_after: 0\n"))
                                    .alignment;
    EXPECT_EQ(d.method, AlignmentMethod::Datums);
    EXPECT_EQ(d.datums, (std::vector<std::string>{"edge", "face", "corner"})); // priority order kept
    EXPECT_DOUBLE_EQ(d.maxShiftMm, 0.5);
    EXPECT_DOUBLE_EQ(d.maxRotationDeg, 10.0);
    EXPECT_EQ(d.correctPosesAfter, 0);
    EXPECT_TRUE(d.seatViews.empty());

    // Views for the seat: poses in the order given.
    const AlignmentSettings seat =
        loadPartProgram(write(kGood + "alignment:\n  seat_views: [{rotation_deg: 45, declination_deg: 30}, "
                                      "{rotation_deg: -10}]\n"))
            .alignment;
    ASSERT_EQ(seat.seatViews.size(), 2u);
    EXPECT_EQ(seat.seatViews[0], (geometry::FixturePose{45.0, 30.0}));
    EXPECT_EQ(seat.seatViews[1], (geometry::FixturePose{-10.0, 0.0}));

    EXPECT_EQ(loadPartProgram(write(kGood + "alignment:\n  method: none\n")).alignment.method, AlignmentMethod::None);
    EXPECT_EQ(hg::enumName(AlignmentMethod::Silhouette), "silhouette");
    EXPECT_EQ(hg::enumName(AlignmentMethod::Datums), "datums");
    EXPECT_EQ(hg::enumName(AlignmentMethod::None), "none");
}

TEST_F(PartProgramTest, AlignmentSectionMistakesNameLineAndKey)
{
    // kGood has 32 lines: "alignment:" is line 33, the first key line 34.
    const std::vector<Mistake> mistakes = {
        {"method: icp", "",
         "part.yaml:34: alignment.method: unknown method 'icp' (expected silhouette, datums or none)"},
        {"method: datums", "", "part.yaml:34: alignment: method datums needs datums"},
        {"method: datums", "  datums: []", "part.yaml:35: alignment.datums: method datums needs at least one datum"},
        {"method: datums", "  datums: face", "part.yaml:35: alignment.datums: expected a sequence"},
        {"method: datums", "  datums: [face, nose]", "part.yaml:35: alignment.datums[1]: unknown landmark 'nose'"},
        {"method: datums", "  datums: [face, edge, face]",
         "part.yaml:35: alignment.datums[2]: datum 'face' is listed twice"},
        {"datums: [face]", "",
         "part.yaml:34: alignment.datums: datums are read by method datums only (method is "
         "silhouette)"},
        {"method: none", "  datums: [face]",
         "part.yaml:35: alignment.datums: datums are read by method datums only "
         "(method is none)"},
        {"max_shift_mm: 0", "", "part.yaml:34: alignment.max_shift_mm: expected a positive number, found 0"},
        {"max_shift_mm: -1", "", "part.yaml:34: alignment.max_shift_mm: expected a positive number"},
        {"max_shift_mm: .inf", "", "part.yaml:34: alignment.max_shift_mm: expected a finite number"},
        {"max_shift_mm: .nan", "", "part.yaml:34: alignment.max_shift_mm: expected a finite number"},
        {"max_rotation_deg: 0", "", "part.yaml:34: alignment.max_rotation_deg: expected a positive number"},
        {"max_rotation_deg: 10.5", "", "part.yaml:34: alignment.max_rotation_deg: value 10.5 is outside (0, 10]"},
        {"max_rotation_deg: .inf", "", "part.yaml:34: alignment.max_rotation_deg: expected a finite number"},
        {"max_shift: 1", "", "part.yaml:34: alignment.max_shift: unknown key 'max_shift'"},
        {"correct_poses_after: -1", "", "part.yaml:34: alignment.correct_poses_after: value -1 is outside [0, 64]"},
        {"correct_poses_after: 2.5", "", "part.yaml:34: alignment.correct_poses_after: expected an integer"},
        {"method: none", "  seat_views: [{rotation_deg: 0}]",
         "part.yaml:35: alignment.seat_views: views for the seat are read only when the part is aligned"},
        {"seat_views: []", "", "part.yaml:34: alignment.seat_views: expected at least one pose, or no seat_views"},
        {"seat_views: [{rotation_deg: 45, declination_deg: 30}, {rotation_deg: 45, declination_deg: 30}]", "",
         "part.yaml:34: alignment.seat_views[1]: this pose is listed twice"},
        {"seat_views: [{rotation_deg: 0}, {rail_mm: 5}]", "",
         "part.yaml:34: alignment.seat_views[1]: views for the seat mix rail poses and rotation/declination poses"},
        {"seat_views: [{declination_deg: 30}]", "", "missing required key 'rotation_deg'"},
    };
    for (const auto& m : mistakes) {
        const std::string section = "alignment:\n  " + m.from + "\n" + (m.to.empty() ? "" : m.to + "\n");
        const InputError e = error(kGood + section);
        EXPECT_NE(std::string(e.what()).find(m.expected), std::string::npos)
            << "expected '" << m.expected << "' in: " << e.what();
    }
    EXPECT_NE(
        std::string(error(kGood + "alignment: silhouette\n").what()).find("part.yaml:33: alignment: expected a map"),
        std::string::npos);
}

TEST_F(PartProgramTest, BrokenMeshIsReportedAtTheMeshKey)
{
    TriangleMesh open = makeBox(Vector3d(0, 0, 0), Vector3d(10, 10, 10));
    open.triangles.pop_back();
    saveMesh(open, dir / "meshes/block.stl");
    const InputError e = error(kGood);
    EXPECT_EQ(e.field(), "mesh");
    EXPECT_EQ(e.line(), 2);
    EXPECT_NE(std::string(e.what()).find("block.stl: mesh: not closed: 3 open edges"), std::string::npos) << e.what();
}

// docs/part-program.md, "Meshes as they come": `mesh_gap_mm` sets the gap
// the repair closes, and the program keeps the repair report.
TEST_F(PartProgramTest, MeshGapToleranceClosesAGapOfThatWidthOnly)
{
    // The corner (10, 10, 10) written 0.05 mm off in the top face's triangles: a slit.
    TriangleMesh block = makeBox(Vector3d(0, 0, 0), Vector3d(10, 10, 10));
    block.vertices.push_back(Vector3d(10.05, 10, 10));
    for (std::size_t i = 0; i < block.triangles.size(); ++i)
        for (int& v : block.triangles[i])
            if (v == 7 && block.faceNormal(i).z() > 0.5) v = 8;
    saveMesh(block, dir / "meshes/block.stl");
    const std::string withGap = "mesh_gap_mm: 0.1\n";
    std::string yaml = kGood;
    EXPECT_NE(std::string(error(yaml).what()).find("gaps up to 0.02 mm are closed; this one is wider"),
              std::string::npos);
    yaml.insert(yaml.find("octree:"), withGap);
    const PartProgram p = loadPartProgram(write(yaml));
    EXPECT_DOUBLE_EQ(p.meshRepair.gapToleranceMm, 0.1);
    EXPECT_EQ(p.meshRepair.mode, MeshRepairMode::Repair);
    EXPECT_EQ(p.meshRepairReport.mergedVertices, 1u);
    // The vertex kept is the one the file writes first (here the top face's): the block with that corner
    // moved, 1000 + 0.05 · 100 / 3 mm³ (the pyramid over the face x = 10).
    TriangleMesh moved = makeBox(Vector3d(0, 0, 0), Vector3d(10, 10, 10));
    moved.vertices[7] = Vector3d(10.05, 10, 10);
    const double volume = p.solid->mesh().signedVolume();
    EXPECT_TRUE(std::abs(volume - 1000.0) < 1e-9 || std::abs(volume - moved.signedVolume()) < 1e-4)
        << volume; // 10.05 in single precision
    yaml.replace(yaml.find(withGap), withGap.size(), "mesh_gap_mm: 2\n");
    const InputError e = error(yaml);
    EXPECT_EQ(e.field(), "mesh_gap_mm");
    EXPECT_EQ(e.line(), 3);
}

} // namespace
} // namespace hg::model
