// Commissioning as `hullgauge commission` and `hullgauge part commission`
// both do it (docs/commissioning.md, "The flow", steps 2–5): a part program
// loaded as the daemon loads it, planned, verified on the station's digital
// twin, the plan and the report written, and — when the verification passes
// and the caller asks for it — released as the next version with its record,
// its views and every earlier version kept (docs/commissioning.md, "Release").
//
// These functions read and write files (an application layer over
// hg::commission, which computes on values).
#pragma once

#include "hullgauge/commission/verification.h"
#include "hullgauge/common/clock.h"
#include "hullgauge/geometry/station.h"
#include "hullgauge/model/part_program.h"
#include "hullgauge/plan/program_plan.h"

#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <map>
#include <optional>
#include <string>

namespace hg::workbench {

/// Wall time of the phases, as the progress callback marks them (a phase
/// starts at done = 0 and ends at done = total).
class PhaseClock {
  public:
    void start(const std::string& phase) { started_.insert_or_assign(phase, Stopwatch()); }
    void stop(const std::string& phase) { ms_[phase] += started_.at(phase).ms(); }
    const std::map<std::string, double>& ms() const { return ms_; }

  private:
    std::map<std::string, Stopwatch> started_;
    std::map<std::string, double> ms_;
};

/// One round: the program as loaded, its plan, and the verification when the
/// plan is feasible.
struct CommissionRound {
    model::PartProgram program;
    plan::ProgramPlan planned;
    std::optional<commission::VerificationReport> report;
};

/// The planner's options commissioning plans a program with.
plan::PlanOptions commissioningPlanOptions(const model::PartProgram& program);

/// Loads `programFile` (InputError in the loader's words), plans it (phase
/// "plan") and, when the plan is feasible, verifies it on the twin
/// (commission::twinFrames of the station, seeded with options.seed).
/// `progress` is called for the verification's phases after `clock` marked
/// them; returning false cancels (commission::Cancelled).
CommissionRound commissionRound(const std::filesystem::path& programFile, const geometry::Station& station,
                                const commission::VerificationOptions& options, const commission::Progress& progress,
                                PhaseClock& clock);

/// plan.json and plan.md in `folder`.
void writePlanFiles(const std::filesystem::path& folder, const plan::ProgramPlan& planned);
/// verification.json and verification.md in `folder`; returns the JSON text
/// (its SHA-256 is what a release rests on).
std::string writeVerificationFiles(const std::filesystem::path& folder, const commission::VerificationReport& report);

/// What a release writes (docs/commissioning.md, "Release").
struct ReleaseInput {
    std::filesystem::path folder;   ///< where `<part>.yaml`, `<part>-views.yaml` and releases/ are
    std::string part;               ///< names the files
    YAML::Node program;             ///< the program as released, without a `release` record
    std::filesystem::path meshFile; ///< the CAD model kept with the version
    std::string viewsYaml;          ///< the poses file (plan::posesYaml)
    std::string verificationJson;   ///< the verification it rests on (its digest goes in the record)
    /// Where verification.json, verification.md and plan.json are copied from into the kept version.
    std::filesystem::path evidenceFolder;
    std::string releasedBy;
    std::optional<int> rolledBackFrom; ///< `release.rolled_back_from`
    std::string header;                ///< comment lines above the program
};

struct Released {
    int version = 0;
    std::filesystem::path programFile, viewsFile, keptFolder;
    std::string releasedAt;
};

/// The version a release in `folder` gets: one more than the newest of the
/// program in force and the versions kept under releases/ (1 for the first).
int nextVersion(const std::filesystem::path& folder, const std::string& part);

/// Writes the version: `releases/<part>.v<N>/` whole (the CAD model, the
/// evidence, the views, the program), then the views and the program in
/// force, each replaced durably.
Released releaseVersion(const ReleaseInput& input);

/// Who runs the program: SUDO_USER first, else the user's name.
std::string currentUser();

} // namespace hg::workbench
