// Suggested landmarks proven on the twin (include/hullgauge/commission/screen.h,
// docs/commissioning.md "Suggestions proven on the twin"), on the simulated
// line's stepped block (tall block x in [-30, 0] up to z = 30, step x in
// [0, 30] up to z = 15, y in [-20, 20]) at the simulated station, with the
// simulated line's nest (play 0.3 mm, 0.3°): two landmarks on the top faces
// (tolerance 0.4 mm) both pass on the twin's frames of the part as drawn; on
// frames of a part that comes out with a 1 mm burr at the step's top (2.5 ×
// the tolerance) the step's landmark is refused as a false reject and the
// tall block's passes.
#include "hgtest/paths.h"
#include "hullgauge/commission/screen.h"
#include "hullgauge/plan/program_plan.h"

#include <gtest/gtest.h>

namespace hg::commission {
namespace {

struct Block {
    geometry::Station station = geometry::loadStation(hgtest::sourceDir() / "config/sim/station.yaml");
    model::CadModel cad = model::loadCadModel(hgtest::sourceDir() / "config/sim/stepped-block.stl", 8, 4);
};

/// The two landmarks planned together, as the suggestion plans its picks.
std::vector<plan::Refusal> screened(const Block& b, const std::vector<plan::LandmarkCandidate>& chosen,
                                    const FrameSourceFactory& frames = {})
{
    plan::PlanProblem problem;
    problem.part = "stepped-block";
    problem.solid = b.cad.solid.get();
    problem.station = &b.station;
    problem.frame = {b.cad.octree.cubeOrigin, b.cad.octree.cubeSize, b.cad.octree.depth};
    // Decided to U by the sub-voxel deviation, the views resolve ΔV (program_plan.h planProblem).
    const double dv = b.cad.octree.voxelSize();
    for (std::size_t i = 0; i < chosen.size(); ++i)
        problem.landmarks.push_back(
            {{"candidate-" + std::to_string(i + 1), chosen[i].position, chosen[i].normal, std::max(dv, 0.4)},
             {},
             std::nullopt});
    plan::PlanOptions options;
    options.pareLayers = 4;
    const plan::ViewPlan plan = plan::planViews(problem, options);
    EXPECT_TRUE(plan.feasible);
    model::AlignmentSettings alignment; // the simulated line's nest: play 0.3 mm, 0.3°
    alignment.maxShiftMm = alignment.maxRotationDeg = 0.3 / plan::kPlayOfLimits;
    const model::PartProgram base = draftProgram(b.cad, "stepped-block", alignment);
    const inspect::DeviationGauge gauge(b.cad.solid, b.station.calibration);
    plan::PlayProblem play{&b.cad.solid->mesh(), {}, b.cad.octree.voxelSize(), &gauge, base.alignment};
    for (const auto& l : problem.landmarks) play.landmarks.push_back({l.id, l.position, l.normal, 0.4});
    std::vector<geometry::FixturePose> poses;
    for (const auto& v : plan.views) poses.push_back(v.pose);
    ScreenOptions screen;
    screen.seats = 4;
    screen.toleranceMm = 0.4;
    return twinScreen(base, b.station, screen, frames)(chosen, plan, plan::capabilityOverPlay(play, b.station, poses));
}

const plan::LandmarkCandidate kTallTop{plan::FeatureKind::Face, {-15, 0, 30}, {0, 0, 1}, "tall block's top"};
const plan::LandmarkCandidate kStepTop{plan::FeatureKind::Face, {15, 0, 15}, {0, 0, 1}, "step's top"};

TEST(TwinScreen, PassesLandmarksTheTwinAccepts)
{
    const Block b;
    for (const auto& r : screened(b, {kTallTop, kStepTop})) ADD_FAILURE() << r.index << " " << r.rule << ": " << r.why;
}

TEST(TwinScreen, RefusesTheLandmarkWhereTheTwinRejectsTheGoodPart)
{
    const Block b;
    const model::TriangleMesh burr =
        seedDefect(b.cad.solid->mesh(), kStepTop.position, kStepTop.normal, {DefectKind::Added, 1.0}, 2.0);
    const FrameSourceFactory twin = twinFrames(b.station, 1);
    const auto refused = screened(b, {kTallTop, kStepTop}, [&](const model::TriangleMesh&) { return twin(burr); });
    ASSERT_EQ(refused.size(), 1u);
    EXPECT_EQ(refused[0].index, 1u);
    EXPECT_EQ(refused[0].rule, "twin_false_reject") << refused[0].why;
    EXPECT_NE(refused[0].why.find("4 seats on the twin"), std::string::npos) << refused[0].why;
}

} // namespace
} // namespace hg::commission
