#include "hullgauge/workbench/commissioning.h"

#include "hullgauge/commission/report.h"
#include "hullgauge/commission/screen.h" // verificationProblem
#include "hullgauge/common/config_node.h"
#include "hullgauge/common/digest.h"
#include "hullgauge/common/durable_file.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/format.h"
#include "hullgauge/plan/plan_report.h"

#include "part_files.h"

#include <pwd.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <regex>

namespace hg::workbench {

namespace fs = std::filesystem;

plan::PlanOptions commissioningPlanOptions(const model::PartProgram& program)
{
    plan::PlanOptions options;
    options.pareLayers = std::max(1, program.octree.adjacencyDepth);
    return options;
}

CommissionRound commissionRound(const fs::path& programFile, const geometry::Station& station,
                                const commission::VerificationOptions& options, const commission::Progress& progress,
                                PhaseClock& clock)
{
    clock.start("plan");
    CommissionRound r{model::loadPartProgram(programFile), {}, std::nullopt};
    r.planned = plan::planProgram(r.program, station, commissioningPlanOptions(r.program));
    clock.stop("plan");
    if (!r.planned.plan.feasible) return r;
    const commission::VerificationProblem problem =
        commission::verificationProblem(r.program, station, r.planned.plan, *r.planned.capability);
    const auto timed = [&](const std::string& phase, std::size_t done, std::size_t total) {
        if (done == 0) clock.start(phase);
        if (done == total) clock.stop(phase);
        return !progress || progress(phase, done, total);
    };
    r.report = commission::verifyProgram(problem, options, commission::twinFrames(station, options.seed), timed);
    return r;
}

void writePlanFiles(const fs::path& folder, const plan::ProgramPlan& planned)
{
    replaceFileDurably(folder / "plan.json", plan::toJson(planned).dump(2) + "\n");
    replaceFileDurably(folder / "plan.md", plan::planMarkdown(planned.plan, planned.problem));
}

std::string writeVerificationFiles(const fs::path& folder, const commission::VerificationReport& report)
{
    const std::string json = commission::toJson(report).dump(2) + "\n";
    replaceFileDurably(folder / "verification.json", json);
    replaceFileDurably(folder / "verification.md", commission::toMarkdown(report));
    return json;
}

namespace {

/// The version of the program in a file: its `release.version`, 0 for none.
int versionIn(const fs::path& program)
{
    if (!files::exists(program)) return 0;
    const ConfigNode root = ConfigNode::loadFile(program);
    if (!root.isMap() || !root.has("release")) return 0;
    const ConfigNode release = root["release"];
    return release.isMap() && release.has("version") ? static_cast<int>(release["version"].asIntIn(1, 1000000)) : 0;
}

/// The newest version kept under releases/ (`<part>.v<N>` folders), 0 for none.
int newestKept(const fs::path& folder, const std::string& part)
{
    const fs::path releases = folder / "releases";
    std::error_code ec;
    if (!fs::is_directory(releases, ec)) return 0;
    int newest = 0;
    const std::string prefix = part + ".v";
    for (const auto& entry : fs::directory_iterator(releases, ec)) {
        const std::string name = entry.path().filename().string();
        if (name.rfind(prefix, 0) != 0) continue;
        const std::string number = name.substr(prefix.size());
        if (number.empty() || number.size() > 7 || number.find_first_not_of("0123456789") != std::string::npos)
            continue;
        newest = std::max(newest, std::stoi(number));
    }
    return newest;
}

std::string emit(const YAML::Node& node, const std::string& header)
{
    YAML::Emitter out;
    out << node;
    return header + out.c_str() + "\n";
}

} // namespace

int nextVersion(const fs::path& folder, const std::string& part)
{
    return std::max(versionIn(files::releasedFile(folder, part)), newestKept(folder, part)) + 1;
}

Released releaseVersion(const ReleaseInput& input)
{
    Released out;
    out.version = nextVersion(input.folder, input.part);
    out.releasedAt = localTimestamp();
    YAML::Node program = YAML::Clone(input.program);
    program.remove("release");
    program["release"]["version"] = out.version;
    program["release"]["verification_sha256"] = sha256Hex(input.verificationJson);
    program["release"]["released_by"] = input.releasedBy;
    program["release"]["released_at"] = out.releasedAt;
    if (input.rolledBackFrom) program["release"]["rolled_back_from"] = *input.rolledBackFrom;
    const std::string text = emit(program, input.header);

    // Every released version whole in a folder of its own (releases/<part>.v<N>/):
    // the program, its views, its model and the verification it rests on.
    out.keptFolder = files::keptFolder(input.folder, input.part, out.version);
    files::createFolders(out.keptFolder);
    files::copyFile(input.meshFile, out.keptFolder / input.meshFile.filename());
    for (const char* file : {"verification.json", "verification.md", "plan.json"})
        files::copyFile(input.evidenceFolder / file, out.keptFolder / file);
    replaceFileDurably(out.keptFolder / (input.part + "-views.yaml"), input.viewsYaml);
    replaceFileDurably(out.keptFolder / (input.part + ".yaml"), text);
    syncFolder(out.keptFolder.parent_path());

    out.viewsFile = files::viewsFile(input.folder, input.part);
    out.programFile = files::releasedFile(input.folder, input.part);
    replaceFileDurably(out.viewsFile, input.viewsYaml);
    replaceFileDurably(out.programFile, text);
    return out;
}

std::string currentUser()
{
    if (const char* sudo = std::getenv("SUDO_USER"); sudo && *sudo) return sudo;
    if (const passwd* pw = getpwuid(getuid()); pw && pw->pw_name) return pw->pw_name;
    return "uid " + std::to_string(getuid());
}

} // namespace hg::workbench
