#include "hullgauge/commission/verification.h"

#include "hullgauge/common/format.h"
#include "hullgauge/inspect/program_inspector.h"
#include "hullgauge/plan/cycle_time.h"
#include "hullgauge/plan/program_plan.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

namespace hg::commission {
namespace {

using inspect::LandmarkStatus;

double median(std::vector<double> v)
{
    if (v.empty()) return 0.0;
    std::sort(v.begin(), v.end());
    const std::size_t n = v.size();
    return n % 2 == 1 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/// The inspector the daemon configures for the program (inspect::makeProgramInspector),
/// at the station's calibration. The landmarks the capability check over the play
/// cannot prove are inspected as never ok rather than refused: verification reports
/// them as its `capability` finding, which refuses the release (docs/commissioning.md).
inspect::ProgramInspector makeInspector(const VerificationProblem& problem)
{
    return inspect::makeProgramInspector(
        *problem.program, {problem.station->calibration, inspect::CapabilityCheck{problem.capability, true, ""}});
}

const inspect::LandmarkResult* findResult(const inspect::InspectionResult& r, const std::string& id)
{
    for (const auto& l : r.landmarks)
        if (l.id == id) return &l;
    return nullptr;
}

/// The depth of a seeded defect at `multiple` of the landmark's tolerance:
/// of the limit on its side where the program gives asymmetric limits.
double defectDepth(const model::Landmark& lm, DefectKind kind, double multiple)
{
    double limit = lm.toleranceMm;
    if (lm.limitsMm) {
        const double side = kind == DefectKind::Added ? lm.limitsMm->second : -lm.limitsMm->first;
        if (side > 0.0) limit = side;
    }
    return multiple * limit;
}

class Verifier {
  public:
    Verifier(const VerificationProblem& problem, const VerificationOptions& options, const FrameSourceFactory& frames,
             const Progress& progress)
        : problem_(problem), program_(*problem.program), options_(options), frames_(frames), progress_(progress),
          inspector_(makeInspector(problem)), rng_(options.seed)
    {
        report_.part = program_.part;
        report_.options = options;
        // The alignment limits are where a seat is refused; a nest's play lies
        // inside them with room for the seat's measurement (docs/commissioning.md).
        report_.seatShiftMm =
            options.seatShiftMm >= 0.0 ? options.seatShiftMm : plan::kPlayOfLimits * program_.alignment.maxShiftMm;
        report_.seatRotationDeg = options.seatRotationDeg >= 0.0
                                      ? options.seatRotationDeg
                                      : plan::kPlayOfLimits * program_.alignment.maxRotationDeg;
        report_.defectHalfWidthMm = options.defectHalfWidthMm > 0.0 ? options.defectHalfWidthMm
                                                                    : std::max(0.5, 4.0 * program_.octree.voxelSize());
        centre_ = program_.solid->mesh().bounds().center();
        for (const auto& lm : program_.landmarks) {
            LandmarkVerification v;
            v.id = lm.id;
            v.toleranceMm = lm.toleranceMm;
            for (const auto& c : problem.capability)
                if (c.id == lm.id) v.predictedUMm = c.expectedMm;
            report_.landmarks.push_back(v);
        }
        for (std::size_t k = 0; k < problem.poses.size(); ++k) {
            ViewVerification v;
            v.id = "v" + std::to_string(k);
            v.pose = problem.poses[k];
            if (k < problem.viewLandmarks.size()) v.landmarks = problem.viewLandmarks[k];
            v.minFrameMarginPx = std::numeric_limits<double>::infinity();
            report_.views.push_back(v);
        }
    }

    VerificationReport run()
    {
        nominalCycles();
        defectCycles();
        conclude();
        report_.inspectionMedianMs = median(inspectionMs_);
        report_.plannedCycleS =
            plan::predictCycleTime(problem_.poses, motion_, plan::homePose(problem_.station->fixture)).totalS;
        report_.twinCycleMedianS = median(cycleS_);
        report_.twinCycleMaxS = cycleS_.empty() ? 0.0 : *std::max_element(cycleS_.begin(), cycleS_.end());
        return report_;
    }

  private:
    void tick(const std::string& phase, std::size_t done, std::size_t total) const
    {
        if (progress_ && !progress_(phase, done, total)) throw Cancelled();
    }

    TwinCycle cycle(const model::TriangleMesh& asMade, const FrameSource& frames)
    {
        const geometry::RigidTransform seat = drawSeat(rng_, report_.seatShiftMm, report_.seatRotationDeg, centre_);
        TwinCycle c = runCycle(*inspector_.inspector, *problem_.station, problem_.poses, inspector_.setup.seatViews,
                               problem_.segmentation, seat, asMade, frames, frame_);
        frame_ += problem_.poses.size();
        inspectionMs_.push_back(c.result.reconstructionTime.count());
        cycleS_.push_back(
            plan::predictCycleTime(c.commanded, motion_, plan::homePose(problem_.station->fixture)).totalS);
        for (std::size_t k = 0; k < report_.views.size() && k < c.frameMarginPx.size(); ++k)
            report_.views[k].minFrameMarginPx = std::min(report_.views[k].minFrameMarginPx, c.frameMarginPx[k]);
        return c;
    }

    void nominalCycles()
    {
        const model::TriangleMesh& nominal = program_.solid->mesh();
        const FrameSource frames = frames_(nominal);
        for (std::size_t s = 0; s < options_.seats; ++s) {
            tick("nominal", s, options_.seats);
            const TwinCycle c = cycle(nominal, frames);
            ++report_.nominalCycles;
            if (c.result.pass) ++report_.nominalPassed;
            if (c.result.seatingFault) ++report_.seatingFaults;
            recordSeatError(c);
            for (LandmarkVerification& v : report_.landmarks) recordNominal(v, c.result);
        }
        tick("nominal", options_.seats, options_.seats);
    }

    // The inspection places the part by the measured seat Ŝ while it lies at
    // the true one S: the map sees the part's surface moved by Ŝ⁻¹S, and at a
    // landmark X that adds the distance of S⁻¹Ŝ(X) from the CAD surface to the
    // measured deviation (docs/commissioning.md, "The seat"). The distance
    // from the surface, not from X: a part symmetric under a turn (a ring
    // about its axis) is the same part turned, and so is its surface.
    void recordSeatError(const TwinCycle& c)
    {
        const auto& measured = c.result.alignment;
        if (!measured || !measured->measured || c.result.seatingFault) return;
        const geometry::RigidTransform back = c.seat.inverse() * measured->seat;
        report_.seatErrorMaxShiftMm =
            std::max(report_.seatErrorMaxShiftMm, (measured->seat.apply(centre_) - c.seat.apply(centre_)).norm());
        report_.seatErrorMaxRotationDeg =
            std::max(report_.seatErrorMaxRotationDeg, geometry::rotationAngleDeg(measured->seat.R, c.seat.R));
        for (std::size_t i = 0; i < program_.landmarks.size(); ++i) {
            const model::Landmark& lm = program_.landmarks[i];
            LandmarkVerification& v = report_.landmarks[i];
            const double e = program_.solid->closestPoint(back.apply(lm.position)).distance;
            v.seatErrorMaxMm = std::max(v.seatErrorMaxMm.value_or(0.0), e);
            const inspect::LandmarkResult* r = findResult(c.result, lm.id);
            if (!r || !r->deviation || !r->deviation->measured) continue;
            ++v.seatErrorJudged;
            if (e > r->deviation->uncertaintyMm) ++v.seatErrorBeyondU;
        }
    }

    void recordNominal(LandmarkVerification& v, const inspect::InspectionResult& result)
    {
        const inspect::LandmarkResult* r = findResult(result, v.id);
        ++v.seats;
        if (!r) return;
        ++v.statuses[r->status];
        if (r->status != LandmarkStatus::NotObservable && r->status != LandmarkStatus::NotInspected)
            ++v.observableSeats;
        if (r->status == LandmarkStatus::Ok) ++v.acceptedSeats;
        if (r->deviation && r->deviation->measured) {
            const double u = r->deviation->uncertaintyMm;
            if (!v.measuredUMaxMm || u > *v.measuredUMaxMm) v.worstBudget = r->deviation->budget;
            v.measuredUMaxMm = std::max(v.measuredUMaxMm.value_or(0.0), u);
            uByLandmark_[v.id].push_back(u);
            v.deviationMaxAbsMm = std::max(v.deviationMaxAbsMm.value_or(0.0), std::abs(r->deviation->deviationMm));
        }
        for (std::size_t k = 0; k < r->views.size(); ++k) {
            if (!r->views[k].discrimination.observes) continue;
            for (ViewVerification& view : report_.views)
                if (view.id == r->views[k].viewId) ++view.observes[v.id];
        }
    }

    void defectCycles()
    {
        const model::TriangleMesh& nominal = program_.solid->mesh();
        const std::size_t total = program_.landmarks.size() * options_.defectMultiples.size() * 2;
        std::size_t done = 0;
        for (std::size_t i = 0; i < program_.landmarks.size(); ++i) {
            const model::Landmark& lm = program_.landmarks[i];
            for (double multiple : options_.defectMultiples) {
                for (DefectKind kind : {DefectKind::Removed, DefectKind::Added}) {
                    tick("defects", done++, total);
                    DefectTrial t;
                    t.defect = {kind, defectDepth(lm, kind, multiple)};
                    t.multiple = multiple;
                    runTrial(t, lm, nominal);
                    report_.landmarks[i].defects.push_back(t);
                }
            }
        }
        tick("defects", total, total);
    }

    void runTrial(DefectTrial& t, const model::Landmark& lm, const model::TriangleMesh& nominal)
    {
        model::TriangleMesh asMade;
        try {
            asMade =
                seedDefect(nominal, lm.position, lm.normal, t.defect, report_.defectHalfWidthMm, sightDirections(lm));
        } catch (const std::exception& e) {
            t.error = e.what();
            return;
        }
        const TwinCycle c = cycle(asMade, frames_(asMade));
        if (const inspect::LandmarkResult* r = findResult(c.result, lm.id)) {
            t.status = r->status;
            if (r->deviation && r->deviation->measured) {
                t.deviationMm = r->deviation->deviationMm;
                t.uncertaintyMm = r->deviation->uncertaintyMm;
            }
        }
    }

    const inspect::LandmarkCapability* capabilityOf(const std::string& id) const
    {
        for (const auto& c : problem_.capability)
            if (c.id == id) return &c;
        return nullptr;
    }

    /// The lines of sight (from the camera to the landmark) of the planned views that observe it.
    std::vector<geometry::Vec3> sightDirections(const model::Landmark& lm) const
    {
        std::vector<geometry::Vec3> sights;
        for (std::size_t k = 0; k < problem_.poses.size() && k < problem_.viewLandmarks.size(); ++k) {
            const auto& ids = problem_.viewLandmarks[k];
            if (std::find(ids.begin(), ids.end(), lm.id) == ids.end()) continue;
            sights.push_back(problem_.station->cameraAt(problem_.poses[k]).lineOfSight(lm.position));
        }
        return sights;
    }

    void conclude();
    void concludeLandmark(LandmarkVerification& v);
    void concludeSeat();
    void addFinding(const std::string& subject, const std::string& test, const std::string& what,
                    std::vector<Fix> fixes, const std::string& fixText)
    {
        report_.findings.push_back({subject, test, what, std::move(fixes), fixText});
    }

    const VerificationProblem& problem_;
    const model::PartProgram& program_;
    VerificationOptions options_;
    FrameSourceFactory frames_;
    Progress progress_;
    inspect::ProgramInspector inspector_;
    std::mt19937_64 rng_;
    geometry::Vec3 centre_ = geometry::Vec3::Zero();
    std::size_t frame_ = 0;
    std::vector<double> inspectionMs_;
    std::vector<double> cycleS_;
    geometry::FixtureMotion motion_ = geometry::stationMotion(*problem_.station);
    std::map<std::string, std::vector<double>> uByLandmark_;
    VerificationReport report_;
};

/// The smallest multiple from which every trial of that size and every larger one was caught.
std::optional<double> smallestCaught(const std::vector<DefectTrial>& trials)
{
    std::vector<double> multiples;
    for (const DefectTrial& t : trials) multiples.push_back(t.multiple);
    std::sort(multiples.begin(), multiples.end());
    multiples.erase(std::unique(multiples.begin(), multiples.end()), multiples.end());
    std::optional<double> smallest;
    for (auto m = multiples.rbegin(); m != multiples.rend(); ++m) {
        const bool all = std::all_of(trials.begin(), trials.end(),
                                     [&](const DefectTrial& t) { return t.multiple != *m || t.caught(); });
        if (!all) break;
        smallest = *m;
    }
    return smallest;
}

void Verifier::concludeLandmark(LandmarkVerification& v)
{
    const std::size_t before = report_.findings.size();
    const std::string seats = " of " + std::to_string(v.seats) + " seats";
    if (v.observableSeats < v.seats)
        addFinding(v.id, "observable",
                   "landmark " + v.id + " is not observable at " + std::to_string(v.seats - v.observableSeats) + seats +
                       " within the nest's play",
                   {Fix::MoveLandmark, Fix::AddView, Fix::DropLandmark},
                   "move it onto an outline a planned view grazes, add a view that sees it, or drop it");
    const inspect::LandmarkCapability* capability = capabilityOf(v.id);
    if (capability && !capability->capable)
        addFinding(v.id, "capability",
                   "the station cannot prove its tolerance at every seat of the play: " +
                       inspect::describe(*capability) + " (it is inspected as never ok)",
                   {Fix::ChangeLens, Fix::WidenTolerance, Fix::DropLandmark},
                   "a camera closer to the part or a longer lens (smaller U), a wider tolerance, or drop it");
    else if (v.acceptedSeats < v.observableSeats) {
        const auto uncertainSeats = v.statuses.find(inspect::LandmarkStatus::Uncertain);
        const std::size_t uncertain = uncertainSeats == v.statuses.end() ? 0 : uncertainSeats->second;
        std::string what = "the nominal part is rejected at " + std::to_string(v.observableSeats - v.acceptedSeats) +
                           seats + " (false rejects)";
        if (v.deviationMaxAbsMm) what += ", |deviation| up to " + formatNumber(*v.deviationMaxAbsMm, 4) + " mm";
        if (v.measuredUMaxMm) what += ", U up to " + formatNumber(*v.measuredUMaxMm, 4) + " mm";
        what += " against a tolerance of " + formatNumber(v.toleranceMm, 4) + " mm";
        if (uncertain * 2 >= v.observableSeats - v.acceptedSeats)
            addFinding(v.id, "false_reject", what, {Fix::ChangeLens, Fix::WidenTolerance, Fix::DropLandmark},
                       "a camera closer to the part or a longer lens (smaller U), a wider tolerance, or drop it");
        else
            addFinding(v.id, "false_reject", what, {Fix::DropLandmark, Fix::MoveLandmark, Fix::ChangeDepth},
                       "drop it or move it away from the feature that biases it, or a finer octree depth");
    }
    v.smallestCaughtMultiple = smallestCaught(v.defects);
    for (const DefectTrial& t : v.defects) {
        if (t.multiple < options_.releaseMultiple - 1e-9 || t.caught()) continue;
        std::string what = "a defect of " + formatNumber(t.multiple) + " × tolerance (" +
                           formatNumber(t.defect.depthMm, 4) + " mm " + std::string(enumName(t.defect.kind)) +
                           ") is accepted";
        if (t.deviationMm) what += ": deviation measured " + formatNumber(*t.deviationMm, 4) + " mm";
        if (!t.error.empty())
            what = "a defect of " + formatNumber(t.multiple) +
                   " × tolerance could not be "
                   "seeded in the CAD mesh (" +
                   t.error + "): the landmark is not verified";
        addFinding(v.id, "defect", what, {Fix::MoveLandmark, Fix::ChangeDepth, Fix::DropLandmark},
                   "move it onto an outline a view sees square on, a finer octree depth, or drop it");
    }
    if (v.measuredUMaxMm && v.predictedUMm > 0.0 && *v.measuredUMaxMm > options_.uncertaintyRatio * v.predictedUMm)
        addFinding(v.id, "prediction",
                   "U measured up to " + formatNumber(*v.measuredUMaxMm, 4) + " mm exceeds " +
                       formatNumber(options_.uncertaintyRatio) + " × the predicted " + formatNumber(v.predictedUMm, 4) +
                       " mm",
                   {Fix::AddView, Fix::DropLandmark},
                   "add a view that sees it square on (the prediction then holds), or drop it");
    v.passed = report_.findings.size() == before;
}

// The seat test: the seat measured on the twin must place the landmarks
// within their U of where the true seat puts them — at k = 2 U covers 95 %
// of the measurements, so at more than 5 % of the landmark-seats U does not
// cover the seat's error alone: the views the seat is measured from leave it
// undetermined, or settle on a seat that is not the part's (docs/alignment.md).
void Verifier::concludeSeat()
{
    constexpr double kCoverage = 0.95;
    const LandmarkVerification* worst = nullptr;
    std::size_t beyond = 0, judged = 0;
    for (const LandmarkVerification& v : report_.landmarks) {
        beyond += v.seatErrorBeyondU;
        judged += v.seatErrorJudged;
        if (v.seatErrorBeyondU > 0 && (!worst || *v.seatErrorMaxMm > *worst->seatErrorMaxMm)) worst = &v;
    }
    if (!worst || static_cast<double>(beyond) <= (1.0 - kCoverage) * static_cast<double>(judged)) return;
    addFinding(report_.part, "seat",
               "the seat measured on the twin is up to " + formatNumber(1000.0 * report_.seatErrorMaxShiftMm, 3) +
                   " µm and " + formatNumber(report_.seatErrorMaxRotationDeg, 3) +
                   "° from the true one; its error alone moves landmarks beyond their U at " + std::to_string(beyond) +
                   " of " + std::to_string(judged) + " landmark-seats, more than 5 % (" + worst->id + " by up to " +
                   formatNumber(*worst->seatErrorMaxMm, 4) + " mm)",
               {Fix::AddView},
               "put first a view that sees the part's outline from another side (the seat is measured on the first "
               "alignment.correct_poses_after views), or a smaller play");
}

void Verifier::conclude()
{
    for (LandmarkVerification& v : report_.landmarks) {
        if (auto u = uByLandmark_.find(v.id); u != uByLandmark_.end()) v.measuredUMedianMm = median(u->second);
        concludeLandmark(v);
    }
    concludeSeat();
    if (report_.seatingFaults > 0)
        addFinding(report_.part, "seating",
                   "the twin's part, seated within the play (shift " + formatNumber(report_.seatShiftMm) + " mm, " +
                       formatNumber(report_.seatRotationDeg) + "°), was measured beyond the alignment limits at " +
                       std::to_string(report_.seatingFaults) + " of " + std::to_string(report_.nominalCycles) +
                       " seats",
                   {Fix::AddView}, "plan views that show more of the part's outline, or widen alignment limits");
    for (const ViewVerification& view : report_.views)
        if (view.minFrameMarginPx < options_.minFrameMarginPx)
            addFinding(view.id, "in_frame",
                       "view " + view.id + " does not hold the whole part in its frame at every seat (margin " +
                           formatNumber(view.minFrameMarginPx, 3) + " px, at least " +
                           formatNumber(options_.minFrameMarginPx) + " px needed)",
                       {Fix::ChangeLens}, "a shorter lens or the camera farther from the part");
    report_.released = report_.findings.empty() && report_.nominalPassed == report_.nominalCycles;
}

} // namespace

VerificationReport verifyProgram(const VerificationProblem& problem, const VerificationOptions& options,
                                 const FrameSourceFactory& frames, const Progress& progress)
{
    Verifier verifier(problem, options, frames, progress);
    return verifier.run();
}

FrameSourceFactory twinFrames(const geometry::Station& station, std::uint64_t seed)
{
    const sim::RenderOptions render = twinRenderOptions(station.imageQuality, seed);
    return [render](const model::TriangleMesh& asMade) { return renderedFrames(asMade, render); };
}

} // namespace hg::commission
