// Verification on the twin (docs/commissioning.md) on the simulated line's
// part program: the program as the line runs it is released; a camera that
// cannot see the defects (it is shown the nominal part whatever was made)
// makes every landmark fail the defect test with its fix named; a part that
// is really made wrong at one landmark gives false rejects at that landmark
// alone; a lens too long for the part makes the plan refuse it.
#include "hgtest/paths.h"
#include "hullgauge/commission/report.h"
#include "hullgauge/commission/verification.h"
#include "hullgauge/plan/program_plan.h"

#include <gtest/gtest.h>

namespace hg::commission {
namespace {

namespace fs = std::filesystem;

struct SimLine {
    model::PartProgram program;
    geometry::Station station;
    plan::ProgramPlan planned;
    VerificationProblem problem;

    explicit SimLine(const std::string& config = "config/sim")
        : SimLine(model::loadPartProgram(hgtest::sourceDir() / config / "stepped-block.yaml"),
                  geometry::loadStation(hgtest::sourceDir() / config / "station.yaml"))
    {
    }

    // The problem points into the line's own members: it is never copied.
    SimLine(const SimLine&) = delete;
    SimLine& operator=(const SimLine&) = delete;

    SimLine(model::PartProgram p, geometry::Station s) : program(std::move(p)), station(std::move(s))
    {
        plan::PlanOptions options;
        options.pareLayers = program.octree.adjacencyDepth;
        planned = plan::planProgram(program, station, options);
        problem.program = &program;
        problem.station = &station;
        for (const plan::PlannedView& v : planned.plan.views) {
            problem.poses.push_back(v.pose);
            std::vector<std::string> ids;
            for (std::size_t l : v.landmarks) ids.push_back(program.landmarks[l].id);
            problem.viewLandmarks.push_back(ids);
        }
        if (planned.capability) problem.capability = *planned.capability;
    }
};

VerificationOptions quick(std::size_t seats)
{
    VerificationOptions o;
    o.seats = seats;
    o.defectMultiples = {2.0};
    // The simulated line's nest (config/sim/hullgauged.yaml, simulation.seating).
    o.seatShiftMm = 0.3;
    o.seatRotationDeg = 0.3;
    return o;
}

const Finding* findingOf(const VerificationReport& r, const std::string& subject, const std::string& test)
{
    for (const Finding& f : r.findings)
        if (f.subject == subject && f.test == test) return &f;
    return nullptr;
}

TEST(Verification, TheSimulatedLinesProgramIsReleased)
{
    SimLine line;
    ASSERT_TRUE(line.planned.plan.feasible);
    const VerificationReport r = verifyProgram(line.problem, quick(4), twinFrames(line.station, 1));
    for (const Finding& f : r.findings) ADD_FAILURE() << f.subject << " (" << f.test << "): " << f.what;
    EXPECT_TRUE(r.released);
    EXPECT_EQ(r.nominalPassed, 4u);
    for (const LandmarkVerification& v : r.landmarks) {
        EXPECT_EQ(v.observableSeats, 4u) << v.id;
        ASSERT_EQ(v.defects.size(), 2u) << v.id;
        for (const DefectTrial& t : v.defects) EXPECT_TRUE(t.caught()) << v.id << " " << hg::enumName(t.defect.kind);
        EXPECT_EQ(v.smallestCaughtMultiple, 2.0) << v.id;
    }
    const std::string md = toMarkdown(r);
    EXPECT_NE(md.find("**Released**"), std::string::npos);
    EXPECT_EQ(toJson(r)["landmarks"].size(), line.program.landmarks.size());
}

TEST(Verification, ACameraBlindToTheDefectsFailsEveryLandmarkWithItsFix)
{
    SimLine line;
    const model::TriangleMesh nominal = line.program.solid->mesh();
    const FrameSourceFactory twin = twinFrames(line.station, 1);
    // Whatever part is made, the frames show the nominal one.
    const FrameSourceFactory blind = [&](const model::TriangleMesh&) { return twin(nominal); };
    const VerificationReport r = verifyProgram(line.problem, quick(2), blind);
    EXPECT_FALSE(r.released);
    EXPECT_EQ(r.nominalPassed, 2u);
    for (const LandmarkVerification& v : r.landmarks) {
        EXPECT_FALSE(v.passed) << v.id;
        EXPECT_FALSE(v.smallestCaughtMultiple.has_value()) << v.id;
        const Finding* f = findingOf(r, v.id, "defect");
        ASSERT_NE(f, nullptr) << v.id;
        EXPECT_NE(std::find(f->fixes.begin(), f->fixes.end(), Fix::DropLandmark), f->fixes.end());
        EXPECT_NE(f->what.find("2 × tolerance (0.8 mm"), std::string::npos) << f->what;
    }
}

// The simulated telecentric line (docs/telecentric.md): two parallel-ray
// views of an extrusion — the planner's, level along it and along x from 5°
// above — leave its seat open, and the aligner settles on seats that are not
// the part's; the twin knows the true seat and finds what the error does to
// the landmarks. With the program's views for the seat first (30° above at
// 45°, then the level view) the seat is measured from them, and holds. The
// play is the twin's default, 80 % of the program's limits.
TEST(Verification, SeatViewsThatLeaveTheSeatOpenAreFoundOnTheTwin)
{
    VerificationOptions o = quick(8);
    o.defectMultiples = {};
    o.seatShiftMm = o.seatRotationDeg = -1.0;
    const auto verify = [&](bool seatViews) {
        const fs::path dir = hgtest::sourceDir() / "config/sim-telecentric";
        model::PartProgram program = model::loadPartProgram(dir / "stepped-block.yaml");
        if (!seatViews) program.alignment.seatViews.clear();
        const SimLine line(std::move(program), geometry::loadStation(dir / "station.yaml"));
        EXPECT_TRUE(line.planned.plan.feasible);
        EXPECT_EQ(line.problem.poses.size(), seatViews ? 3u : 2u);
        return verifyProgram(line.problem, o, twinFrames(line.station, 1));
    };
    const VerificationReport planned = verify(false);
    const Finding* f = findingOf(planned, "stepped-block", "seat");
    ASSERT_NE(f, nullptr);
    EXPECT_EQ(f->fixes, std::vector<Fix>{Fix::AddView});
    EXPECT_FALSE(planned.released);
    std::size_t beyond = 0;
    for (const LandmarkVerification& v : planned.landmarks) beyond += v.seatErrorBeyondU;
    EXPECT_GT(beyond, 0u);

    const VerificationReport seated = verify(true);
    EXPECT_EQ(findingOf(seated, "stepped-block", "seat"), nullptr);
    EXPECT_LT(seated.seatErrorMaxShiftMm, 0.002);
    EXPECT_LT(seated.seatErrorMaxRotationDeg, 0.01);
    for (const LandmarkVerification& v : seated.landmarks) {
        EXPECT_EQ(v.seatErrorBeyondU, 0u) << v.id;
        ASSERT_TRUE(v.seatErrorMaxMm.has_value()) << v.id;
        EXPECT_LT(*v.seatErrorMaxMm, 0.002) << v.id;
    }
}

TEST(Verification, APartMadeWrongAtOneLandmarkIsRejectedThereAlone)
{
    SimLine line;
    const model::Landmark* lm = line.program.findLandmark("step-top");
    ASSERT_NE(lm, nullptr);
    // Every "nominal" part comes out with a 1 mm burr at step-top (2.5 × its 0.4 mm tolerance).
    const model::TriangleMesh low =
        seedDefect(line.program.solid->mesh(), lm->position, lm->normal, {DefectKind::Added, 1.0}, 2.0);
    const FrameSourceFactory twin = twinFrames(line.station, 1);
    const FrameSourceFactory made = [&](const model::TriangleMesh&) { return twin(low); };
    VerificationOptions o = quick(3);
    o.defectMultiples = {};
    const VerificationReport r = verifyProgram(line.problem, o, made);
    EXPECT_FALSE(r.released);
    EXPECT_EQ(r.nominalPassed, 0u);
    for (const LandmarkVerification& v : r.landmarks) {
        if (v.id == "step-top") {
            EXPECT_EQ(v.acceptedSeats, 0u);
            ASSERT_NE(findingOf(r, v.id, "false_reject"), nullptr);
        } else {
            EXPECT_EQ(v.acceptedSeats, 3u) << v.id;
            EXPECT_EQ(findingOf(r, v.id, "false_reject"), nullptr) << v.id;
        }
    }
}

TEST(ProgramPlan, ALensTooLongForThePartIsRefusedNamingTheView)
{
    SimLine line;
    // f = 9000 px at 400 mm: the 1280 px frame spans 57 mm, less than the 60 mm block.
    line.station.camera.K(0, 0) = line.station.camera.K(1, 1) = 9000.0;
    plan::PlanOptions options;
    options.pareLayers = line.program.octree.adjacencyDepth;
    const plan::ProgramPlan p = plan::planProgram(line.program, line.station, options);
    EXPECT_FALSE(p.plan.feasible);
    bool named = false;
    for (const std::string& problem : p.plan.problems)
        named = named || problem.find("does not hold the whole part in its frame") != std::string::npos;
    EXPECT_TRUE(named);
    EXPECT_FALSE(p.capability.has_value());
}

} // namespace
} // namespace hg::commission
