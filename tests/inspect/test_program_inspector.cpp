// The configured inspector of a part program at a station
// (include/hullgauge/inspect/program_inspector.h): the options, aligner,
// gauge and seat views the program's sections set, and the capability check
// as docs/inspection.md ("Capability") has it — a landmark the station cannot
// prove refuses the program naming it and how to force it; forced, it is
// inspected but never ok, at best uncertain. The assessments are written by
// hand, so what is tested is the factory's handling, not the gauge's numbers.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "hgtest/parts.h"
#include "hullgauge/common/error.h"
#include "hullgauge/inspect/program_inspector.h"
#include "hullgauge/sim/renderer.h"

namespace {

using hg::inspect::CapabilityCheck;
using hg::inspect::InspectionStation;
using hg::inspect::LandmarkCapability;
using hg::inspect::LandmarkStatus;

/// The post of fig. 3.5 as a part program: its CAD solid, octree and
/// landmarks (±0.3 mm), the sections at their defaults.
hg::model::PartProgram postProgram(const hgtest::TestPart& post)
{
    hg::model::PartProgram program;
    program.file = "post.yaml";
    program.part = post.name;
    program.solid = post.solid;
    program.octree.cubeOrigin = post.geometry.cubeOrigin;
    program.octree.cubeSize = post.geometry.cubeSize;
    program.octree.depth = post.geometry.depth;
    program.octree.adjacencyDepth = post.geometry.adjacencyDepth;
    for (const hg::inspect::MapLandmark& l : post.landmarks) {
        hg::model::Landmark lm;
        lm.id = l.id;
        lm.position = l.position;
        lm.normal = l.normal;
        lm.toleranceMm = l.toleranceMm;
        program.landmarks.push_back(lm);
    }
    return program;
}

/// A hand-made assessment: every landmark capable (zone 0.6 mm ≥ 4 × 0.01
/// mm) but `unprovable`, whose zone of 0.01 mm is narrower than 4 × 0.0071
/// mm seen by 3 views.
std::vector<LandmarkCapability> assessment(const hgtest::TestPart& post, const std::vector<std::string>& unprovable)
{
    std::vector<LandmarkCapability> out;
    for (const auto& l : post.landmarks) {
        LandmarkCapability c;
        c.id = l.id;
        c.views = 3;
        const bool refused = std::find(unprovable.begin(), unprovable.end(), l.id) != unprovable.end();
        c.zoneMm = refused ? 0.01 : 0.6;
        c.expectedMm = refused ? 0.0071 : 0.01;
        c.capable = !refused;
        out.push_back(c);
    }
    return out;
}

TEST(ProgramInspector, TheProgramsSectionsSetTheOptionsAlignerGaugeAndSeatViews)
{
    const hgtest::TestPart post = hgtest::postPart();
    hg::model::PartProgram program = postProgram(post);
    program.inspection.earlyExit = true;
    program.inspection.centrePointTest = true;
    program.alignment.correctPosesAfter = 3;
    auto setup = hg::inspect::setUpInspection(program, {});
    EXPECT_TRUE(setup.options.earlyExit);
    EXPECT_EQ(setup.options.method, hg::inspect::VoxelTestMethod::CentrePoint);
    EXPECT_TRUE(setup.options.unprovenLandmarks.empty());
    EXPECT_NE(setup.aligner, nullptr);
    EXPECT_NE(setup.gauge, nullptr);
    EXPECT_EQ(setup.seatViews, 3u);
    // Without alignment every view is taken as planned; without the deviation no gauge.
    program.alignment.method = hg::model::AlignmentMethod::None;
    program.inspection.deviation = false;
    setup = hg::inspect::setUpInspection(program, {});
    EXPECT_EQ(setup.aligner, nullptr);
    EXPECT_EQ(setup.gauge, nullptr);
    EXPECT_EQ(setup.seatViews, 0u);
}

TEST(ProgramInspector, ALandmarkTheStationCannotProveRefusesTheProgramUnlessForced)
{
    const hgtest::TestPart post = hgtest::postPart();
    const hg::model::PartProgram program = postProgram(post);
    InspectionStation station;
    station.capability = CapabilityCheck{assessment(post, {"c-pn"}), false, "programs.1.force: true"};
    try {
        (void)hg::inspect::setUpInspection(program, station);
        ADD_FAILURE() << "a landmark the station cannot prove must refuse the program";
    } catch (const hg::InputError& e) {
        EXPECT_EQ(e.file(), "post.yaml");
        EXPECT_EQ(e.field(), "landmarks");
        EXPECT_EQ(e.problem(), "landmark c-pn: tolerance zone 0.01 mm is narrower than 4 U = 4 × 0.0071 mm "
                               "(sub-voxel deviation, 3 views): this station cannot prove it (test uncertainty "
                               "ratio 4:1) (programs.1.force: true inspects it anyway, never ok: at best uncertain)");
    }
    // Forced: inspected, marked unproven, and returned for the caller to report.
    station.capability->force = true;
    const auto forced = hg::inspect::setUpInspection(program, station);
    EXPECT_EQ(forced.options.unprovenLandmarks, std::vector<std::string>{"c-pn"});
    ASSERT_EQ(forced.forced.size(), 1u);
    EXPECT_EQ(forced.forced[0].id, "c-pn");
    // A masked landmark is not inspected: it neither refuses the program nor is marked.
    station.capability->force = false;
    const auto masked = hg::inspect::setUpInspection(program, station, {"c-pn"});
    EXPECT_EQ(masked.options.maskedLandmarks, std::vector<std::string>{"c-pn"});
    EXPECT_TRUE(masked.options.unprovenLandmarks.empty());
    EXPECT_TRUE(masked.forced.empty());
}

// On frames of the nominal post, the forced landmark is the only one the
// forced inspector judges differently: uncertain with the reason
// docs/inspection.md gives, where the inspector without it found it ok.
TEST(ProgramInspector, AForcedLandmarkIsNeverOkOnTheNominalPart)
{
    const hgtest::TestPart post = hgtest::postPart();
    hg::model::PartProgram program = postProgram(post);
    program.alignment.method = hg::model::AlignmentMethod::None;
    const auto made = hgtest::asDesigned(post);
    std::mt19937_64 rng(43);
    hgtest::GrazingOptions o;
    o.camera.focalPx = 6000.0;
    const auto cameras = hgtest::grazingViewSet(post, &made, 2, rng, o);
    const hg::sim::SilhouetteRenderer renderer({made.mesh});
    hg::sim::RenderOptions ro;
    ro.noiseSigma = 1.5;
    std::vector<hg::inspect::CapturedView> frames;
    for (std::size_t i = 0; i < cameras.size(); ++i) {
        ro.seed = 43 + i;
        frames.push_back({"v" + std::to_string(i), cameras[i], renderer.render(cameras[i], ro)});
    }

    const auto capable =
        hg::inspect::makeProgramInspector(program, {{}, CapabilityCheck{assessment(post, {}), false, "--force"}});
    const auto forced =
        hg::inspect::makeProgramInspector(program, {{}, CapabilityCheck{assessment(post, {"c-pn"}), true, "--force"}});
    const auto asCapable = capable.inspector->inspect(frames, {});
    const auto asForced = forced.inspector->inspect(frames, {});
    ASSERT_TRUE(asCapable.pass);
    EXPECT_FALSE(asForced.pass);
    ASSERT_EQ(asForced.landmarks.size(), asCapable.landmarks.size());
    for (std::size_t i = 0; i < asForced.landmarks.size(); ++i) {
        const auto& f = asForced.landmarks[i];
        const auto& c = asCapable.landmarks[i];
        ASSERT_EQ(c.status, LandmarkStatus::Ok) << c.id;
        if (f.id != "c-pn") {
            EXPECT_EQ(f.status, LandmarkStatus::Ok) << f.id;
            continue;
        }
        EXPECT_EQ(f.status, LandmarkStatus::Uncertain);
        ASSERT_TRUE(f.decision.has_value());
        EXPECT_EQ(*f.decision, hg::inspect::Decision::Uncertain);
        EXPECT_EQ(f.reason, "the tolerance zone is narrower than 4 U at this station (inspected with --force): "
                            "conformance cannot be proven");
        // The measurement itself is the one the capable inspector made.
        ASSERT_TRUE(f.deviation && c.deviation);
        EXPECT_EQ(f.deviation->deviationMm, c.deviation->deviationMm);
    }
}

} // namespace
