// Suggested landmarks proven on the twin (the method is in the header; the
// contract in docs/commissioning.md, "Suggestions proven on the twin").
#include "hullgauge/commission/screen.h"

#include "hullgauge/plan/program_plan.h"

#include <algorithm>
#include <map>
#include <set>

namespace hg::commission {

model::PartProgram draftProgram(const model::CadModel& cad, const std::string& part,
                                const model::AlignmentSettings& alignment)
{
    model::PartProgram program;
    program.part = part;
    program.meshFile = cad.file;
    program.solid = cad.solid;
    program.brep = cad.brep;
    program.octree = cad.octree;
    program.alignment = alignment;
    return program;
}

VerificationProblem verificationProblem(const model::PartProgram& program, const geometry::Station& station,
                                        const plan::ViewPlan& plan,
                                        const std::vector<inspect::LandmarkCapability>& capability)
{
    VerificationProblem problem;
    problem.program = &program;
    problem.station = &station;
    for (const plan::PlannedView& v : plan.views) {
        problem.poses.push_back(v.pose);
        std::vector<std::string> ids;
        for (std::size_t l : v.landmarks) ids.push_back(program.landmarks.at(l).id);
        problem.viewLandmarks.push_back(ids);
    }
    problem.capability = capability;
    if (station.document && station.document->has("segmentation"))
        problem.segmentation = vision::parseSegmentation((*station.document)["segmentation"]);
    return problem;
}

namespace {

/// The findings of the twin that refuse a landmark: not observed, a good
/// part rejected, U beyond its prediction (the program-wide ones — seating,
/// frames — are the plan's and the commissioning's to judge).
const std::set<std::string> kScreenTests{"observable", "capability", "false_reject", "prediction"};

} // namespace

plan::SuggestScreen twinScreen(const model::PartProgram& base, const geometry::Station& station,
                               const ScreenOptions& options, FrameSourceFactory frames)
{
    if (!frames) frames = twinFrames(station, options.seed);
    return [base, &station, options, frames](const std::vector<plan::LandmarkCandidate>& chosen, const plan::ViewPlan&,
                                             const std::vector<inspect::LandmarkCapability>&) {
        model::PartProgram program = base;
        std::map<std::string, std::size_t> indexOf;
        for (std::size_t i = 0; i < chosen.size(); ++i) {
            // As the landmarks list writes it and the loader reads it back.
            const plan::LandmarkCandidate written = plan::asWritten(chosen[i]);
            model::Landmark lm;
            lm.id = "candidate-" + std::to_string(i + 1);
            lm.position = written.position;
            lm.normal = written.normal;
            lm.toleranceMm = options.toleranceMm;
            program.landmarks.push_back(lm);
            indexOf[lm.id] = i;
        }
        // Planned and predicted as commissioning plans the program it is
        // written into (the planner breaks ties between mirror poses on the
        // last digit), so that the screen and the verification judge the same views.
        plan::PlanOptions planOptions;
        planOptions.pareLayers = std::max(1, program.octree.adjacencyDepth);
        const plan::ProgramPlan planned = plan::planProgram(program, station, planOptions);
        if (!planned.plan.feasible || !planned.capability) {
            // A landmark the program's own plan refuses goes; a plan refused
            // for the lens is the commissioning's to report.
            std::vector<plan::Refusal> refused;
            for (std::size_t i = 0; i < chosen.size(); ++i)
                if (!planned.plan.landmarks[i].inspectable())
                    refused.push_back({i, std::string(enumName(planned.plan.landmarks[i].verdict)),
                                       planned.plan.landmarks[i].reason});
            return refused;
        }
        VerificationOptions verify;
        verify.seats = options.seats;
        verify.defectMultiples = {};
        verify.seed = options.seed;
        verify.uncertaintyRatio = options.uncertaintyRatio;
        const VerificationReport report =
            verifyProgram(verificationProblem(program, station, planned.plan, *planned.capability), verify, frames);
        std::vector<plan::Refusal> refused;
        std::set<std::size_t> seen;
        for (const Finding& f : report.findings) {
            const auto it = indexOf.find(f.subject);
            if (it == indexOf.end() || !kScreenTests.count(f.test)) continue;
            // A seat measured beyond the alignment limits is inspected at no
            // landmark: the program's views are to blame, not the landmark.
            if (f.test == "observable" && report.seatingFaults > 0) continue;
            if (!seen.insert(it->second).second) continue;
            refused.push_back({it->second, "twin_" + f.test,
                               f.what + " (" + std::to_string(report.nominalCycles) + " seats on the twin)"});
        }
        return refused;
    };
}

} // namespace hg::commission
