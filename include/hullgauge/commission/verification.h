// Verification of a part program on the station's digital twin
// (docs/commissioning.md): before a program is released, the station proves
// it on its own twin, as a CMM program is run on the simulated machine before
// a part is touched.
//
// 1. The nominal part, seated at random within the nest's play (N seats,
//    twin.h drawSeat), is taken through the planned poses as the daemon takes
//    it (runCycle) and inspected: every landmark must be observable and
//    accepted at every seat (a rejected good part is a false reject).
// 2. Per landmark, defects are seeded (defects.h) — material added and
//    removed along the normal at each multiple of the tolerance — and each
//    defective part inspected at a seat of its own: a defect is caught when
//    its landmark is not accepted.
// 3. The capability check's prediction (docs/inspection.md, "Capability") is
//    compared with what the twin measured: the program's U must not exceed
//    1.25 × the predicted U at any seat.
// 4. Every view must hold the whole seated part inside its frame.
// A program is released only when the nominal part passes at every seat, the
// release multiple (2 × tolerance) is caught at every landmark, U is bounded
// by its prediction and no view cuts the part. Each failure names its
// landmark or view, the test, the numbers and what would fix it.
//
// Pure computation on values: frames come from a FrameSource per part as made.
#pragma once

#include "hullgauge/commission/defects.h"
#include "hullgauge/commission/twin.h"
#include "hullgauge/inspect/capability.h"
#include "hullgauge/model/part_program.h"

#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace hg::commission {

/// What a failure asks of the engineer; `--fix` applies DropLandmark.
enum class Fix { DropLandmark, MoveLandmark, AddView, ChangeDepth, ChangeLens, WidenTolerance };
constexpr auto nameTable(Fix)
{
    using enum Fix;
    return std::to_array<EnumName<Fix>>({{DropLandmark, "drop_landmark"},
                                         {MoveLandmark, "move_landmark"},
                                         {AddView, "add_view"},
                                         {ChangeDepth, "change_depth"},
                                         {ChangeLens, "change_lens"},
                                         {WidenTolerance, "widen_tolerance"}});
}

struct Finding {
    std::string subject; ///< the landmark's or the view's id
    std::string test;    ///< "observable", "false_reject", "defect", "prediction", "in_frame"
    std::string what;    ///< the failure in words, with the numbers
    std::vector<Fix> fixes;
    std::string fixText; ///< the fixes in words
};

struct DefectTrial {
    SeededDefect defect;
    double multiple = 0.0; ///< depth / tolerance
    inspect::LandmarkStatus status = inspect::LandmarkStatus::NotInspected;
    std::optional<double> deviationMm;
    std::optional<double> uncertaintyMm;
    /// Why the defect could not be seeded (a boolean of the CAD mesh failed):
    /// the trial is then not run and counts as not caught.
    std::string error;
    bool caught() const { return error.empty() && status != inspect::LandmarkStatus::Ok; }
};

struct LandmarkVerification {
    std::string id;
    double toleranceMm = 0.0;
    std::size_t seats = 0;
    std::size_t observableSeats = 0;
    std::size_t acceptedSeats = 0;
    std::map<inspect::LandmarkStatus, std::size_t> statuses; ///< nominal seats per status
    double predictedUMm = 0.0;
    std::optional<double> measuredUMaxMm; ///< largest U over the nominal seats
    std::optional<double> measuredUMedianMm;
    /// The budget (standard uncertainties, mm) of the seat with the largest U.
    std::optional<inspect::DeviationBudget> worstBudget;
    std::optional<double> deviationMaxAbsMm; ///< largest |deviation| of the nominal part
    /// What the measured seat's error alone does to the landmark (docs/commissioning.md,
    /// "The seat"): the largest distance from the CAD surface of the landmark
    /// moved by the seat's error, over the nominal seats, and at how many of
    /// them it exceeded the landmark's U.
    std::optional<double> seatErrorMaxMm;
    std::size_t seatErrorJudged = 0; ///< nominal seats at which the landmark's U was measured
    std::size_t seatErrorBeyondU = 0;
    std::vector<DefectTrial> defects;
    /// The smallest multiple of the tolerance from which every trial (added
    /// and removed, that size and every larger one) was caught.
    std::optional<double> smallestCaughtMultiple;
    bool passed = false;
};

struct ViewVerification {
    std::string id;
    geometry::FixturePose pose;
    std::vector<std::string> landmarks;          ///< the plan's: the landmarks this view observes
    double minFrameMarginPx = 0.0;               ///< over every cycle
    std::map<std::string, std::size_t> observes; ///< landmark → nominal seats this view observed it in
};

struct VerificationOptions {
    std::size_t seats = 20;
    std::vector<double> defectMultiples{1.0, 2.0, 3.0};
    /// The multiple that must be caught at every landmark for release.
    double releaseMultiple = 2.0;
    /// Seats drawn within this play; < 0: 80 % of the program's alignment limits.
    double seatShiftMm = -1.0;
    double seatRotationDeg = -1.0;
    /// Measured U may be at most this times the predicted U.
    double uncertaintyRatio = 1.25;
    /// Half-width of a seeded defect's patch; 0: max(0.5 mm, 4 ΔV).
    double defectHalfWidthMm = 0.0;
    /// The seated part must stay this far (px) inside every frame.
    double minFrameMarginPx = 1.0;
    std::uint64_t seed = 1;
};

/// What is verified.
struct VerificationProblem {
    const model::PartProgram* program = nullptr;
    const geometry::Station* station = nullptr;
    std::vector<geometry::FixturePose> poses; ///< planned, in travel order
    /// The landmarks each planned view observes (plan.json `views[].landmarks`).
    std::vector<std::vector<std::string>> viewLandmarks;
    std::vector<inspect::LandmarkCapability> capability; ///< predicted U per landmark
    vision::SegmentationSettings segmentation;
};

/// Frames of a part as made; the twin's own renderer by default (renderedFrames).
using FrameSourceFactory = std::function<FrameSource(const model::TriangleMesh& asMade)>;
/// Called as work proceeds; return false to cancel (verifyProgram then throws Cancelled).
using Progress = std::function<bool(const std::string& phase, std::size_t done, std::size_t total)>;

struct Cancelled : std::runtime_error {
    Cancelled() : std::runtime_error("commissioning cancelled") {}
};

struct VerificationReport {
    std::string part;
    VerificationOptions options;
    double seatShiftMm = 0.0, seatRotationDeg = 0.0, defectHalfWidthMm = 0.0;
    std::size_t nominalCycles = 0;
    std::size_t nominalPassed = 0;
    std::size_t seatingFaults = 0;
    /// The measured seat against the true one over the nominal seats: the
    /// largest error of the reference point's place, mm, and of the turn, °.
    double seatErrorMaxShiftMm = 0.0;
    double seatErrorMaxRotationDeg = 0.0;
    std::vector<LandmarkVerification> landmarks;
    std::vector<ViewVerification> views;
    std::vector<Finding> findings;
    bool released = false;
    /// Wall time per phase, ms, as the caller measured it (the progress
    /// callback marks each phase's start and end): left empty here.
    std::map<std::string, double> phaseMs;
    /// The twin's inspection time per cycle (the traversal after the last frame), median, ms.
    double inspectionMedianMs = 0.0;
    /// The plan's predicted cycle time from the home pose (docs/planning.md,
    /// "Cycle time"), and the same model over the poses the twin's fixture
    /// was actually sent to (corrected for each seat): median and largest, s.
    double plannedCycleS = 0.0;
    double twinCycleMedianS = 0.0;
    double twinCycleMaxS = 0.0;
    double falseRejectRate() const
    {
        return nominalCycles == 0 ? 0.0 : 1.0 - static_cast<double>(nominalPassed) / nominalCycles;
    }
};

/// The verification of the header. `frames` defaults to the twin's renderer
/// with `render` (twinRenderOptions of the station's image quality).
VerificationReport verifyProgram(const VerificationProblem& problem, const VerificationOptions& options,
                                 const FrameSourceFactory& frames, const Progress& progress = {});

/// The twin's frames for the station: renderedFrames with twinRenderOptions.
FrameSourceFactory twinFrames(const geometry::Station& station, std::uint64_t seed);

} // namespace hg::commission
