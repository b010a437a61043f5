// Released versions (docs/workbench.md, "Proving and releasing"): the release
// of the verified draft, the rollback to an earlier version as a new one, the
// list of versions, and history.jsonl. Comparing versions: diff.cpp.
#include "hullgauge/common/config_node.h"
#include "hullgauge/common/digest.h"
#include "hullgauge/common/log.h"
#include "hullgauge/model/part_program.h"
#include "hullgauge/plan/plan_report.h"
#include "hullgauge/workbench/commissioning.h"
#include "hullgauge/workbench/workspace.h"

#include "draft.h"
#include "part_files.h"

#include <algorithm>

namespace hg::workbench {
namespace {

[[noreturn]] void refuse(const std::string& why)
{
    throw ReleaseRefused("", "", why);
}

/// Every condition of a release on the verification (docs/workbench.md): of
/// the draft as it is now, of the station as it is now, released by it.
void checkVerified(const PartRecord& record, const std::string& draftSha, const fs::path& stationFile,
                   const fs::path& folder)
{
    if (!record.verified)
        refuse("the draft of " + record.part +
               " has not been verified on the twin: commission it (hullgauge part commission) before releasing it");
    const Verified& v = *record.verified;
    if (v.revision != record.revision)
        refuse("the last verification is of revision " + std::to_string(v.revision) + " of the draft of " +
               record.part + ", which is at revision " + std::to_string(record.revision) + " now: commission it again");
    if (v.draftSha256 != draftSha)
        refuse("the draft of " + record.part +
               " changed since its verification (its SHA-256 is not the one verified): commission it again");
    if (v.stationSha256 != sha256OfFile(stationFile))
        refuse("the station file " + stationFile.string() +
               " changed since the draft was verified (its SHA-256 is not the one verified on): commission it again "
               "on this station");
    if (!files::exists(folder / files::kVerificationJson) ||
        sha256OfFile(folder / files::kVerificationJson) != v.verificationSha256)
        refuse("verification.json of " + record.part +
               " is not the verification recorded (its SHA-256 differs): commission the draft again");
    if (!v.released)
        refuse("the verification of revision " + std::to_string(v.revision) + " does not release the draft of " +
               record.part + ": verification.md names what fails and what would fix it");
}

/// The PLC programs of the workspace's other released parts (`plc_program` in their records).
std::vector<std::pair<std::string, int>> otherPrograms(const fs::path& workspace, const std::string& part)
{
    std::vector<std::pair<std::string, int>> out;
    std::error_code ec;
    for (auto it = fs::directory_iterator(workspace, ec); !ec && it != fs::directory_iterator(); it.increment(ec)) {
        const std::string name = it->path().filename().string();
        if (name == part || !validPartName(name) || !files::exists(it->path() / files::kRecord)) continue;
        try {
            const PartRecord r = files::readRecord(it->path());
            if (r.plcProgram) out.emplace_back(name, *r.plcProgram);
        } catch (const InputError&) {
            // A broken record holds no number the station runs.
        }
    }
    return out;
}

int plcProgramFor(const PartRecord& record, std::optional<int> given, const std::vector<int>& taken,
                  const std::vector<std::pair<std::string, int>>& others)
{
    if (!given && !record.plcProgram)
        throw InputError("", "plc_program",
                         "give the PLC program number (PART_PROGRAM, 1..65535) " + record.part +
                             " is selected by at its first release");
    const int n = given ? *given : *record.plcProgram;
    if (n < 1 || n > 65535) throw InputError("", "plc_program", std::to_string(n) + " is outside 1..65535");
    if (std::find(taken.begin(), taken.end(), n) != taken.end())
        refuse("PLC program " + std::to_string(n) + " is already a program of the daemon's programs: table; give " +
               record.part + " another number");
    for (const auto& [name, number] : others)
        if (number == n)
            refuse("PLC program " + std::to_string(n) + " is already part " + name + "'s; give " + record.part +
                   " another number");
    return n;
}

/// The views of the verification (its views in travel order) as the poses file writes them.
std::string viewsOfVerification(const std::string& verificationJson, geometry::FixtureType type)
{
    const nlohmann::json report = nlohmann::json::parse(verificationJson, nullptr, false);
    if (!report.is_object() || !report.contains("views")) refuse("verification.json holds no views");
    plan::ViewPlan views;
    for (const nlohmann::json& v : report["views"]) {
        plan::PlannedView view;
        view.pose.rotationDeg = v["pose"].value("rotation_deg", 0.0);
        view.pose.declinationDeg = v["pose"].value("declination_deg", 0.0);
        view.pose.railMm = v["pose"].value("rail_mm", 0.0);
        views.views.push_back(view);
    }
    return plan::posesYaml(views, type);
}

Version versionOf(const Released& released, const std::string& by, const std::string& verificationSha,
                  std::optional<int> rolledBackFrom)
{
    return {released.version, by, released.releasedAt, verificationSha, rolledBackFrom, true};
}

/// The comment above a released program; `folder` gives the version it will be (under the part's lock).
std::string header(const fs::path& folder, const std::string& part, const std::string& how)
{
    return "# Part program of " + part + " " + how + " (docs/workbench.md).\n# Its views: " + part +
           "-views.yaml; its verification: releases/" + part + ".v" + std::to_string(nextVersion(folder, part)) +
           "/verification.json.\n";
}

} // namespace

Version Workspace::release(std::string_view part, int revision, const fs::path& stationFile,
                           std::optional<int> plcProgram, const std::vector<int>& takenPrograms, const Actor& by)
{
    const fs::path folder = partFolder(part);
    const auto others = otherPrograms(folder_, std::string(part));
    files::PartLock lock(folder, true);
    PartRecord record = files::readRecord(folder);
    files::checkRevision(record, revision);
    const fs::path draftPath = files::draftFile(folder, record.part);
    const std::string draftText = files::readText(draftPath);
    checkVerified(record, sha256Hex(draftText), stationFile, folder);
    const int plc = plcProgramFor(record, plcProgram, takenPrograms, others);

    const geometry::Station station = geometry::loadStation(stationFile);
    const model::PartProgram program = files::loadProgramAs(draftPath, draftPath.filename().string());
    ReleaseInput input;
    input.folder = folder;
    input.part = record.part;
    input.program = files::loadDraftNode(draftPath);
    input.meshFile = program.meshFile;
    input.verificationJson = files::readText(folder / files::kVerificationJson);
    input.viewsYaml = viewsOfVerification(input.verificationJson, station.fixture.type);
    input.evidenceFolder = folder;
    input.releasedBy = by.name;
    input.header =
        header(folder, record.part,
               "released by hullgauge part release, revision " + std::to_string(record.revision) + " of its draft");
    const Released released = releaseVersion(input);
    record.plcProgram = plc;
    files::writeRecord(folder, record);
    const std::string sha = sha256Hex(input.verificationJson);
    files::appendHistory(folder, {{"version", released.version},
                                  {"action", "release"},
                                  {"by", by.name},
                                  {"at", released.releasedAt},
                                  {"what", "revision " + std::to_string(record.revision) + " of the draft released"},
                                  {"revision", record.revision},
                                  {"plc_program", plc},
                                  {"verification_sha256", sha},
                                  {"rolled_back_from", nullptr}});
    return versionOf(released, by.name, sha, std::nullopt);
}

Version Workspace::rollback(std::string_view part, int version, const Actor& by)
{
    const fs::path folder = partFolder(part);
    files::PartLock lock(folder, true);
    const PartRecord record = files::readRecord(folder);
    const fs::path kept = files::keptFolder(folder, record.part, version);
    const fs::path keptProgram = kept / (record.part + ".yaml");
    if (!files::exists(keptProgram))
        throw InputError("", "version", "part " + record.part + " has no version " + std::to_string(version));
    ReleaseInput input;
    input.folder = folder;
    input.part = record.part;
    input.program = files::loadDraftNode(keptProgram);
    input.program.remove("release");
    if (!input.program["mesh"]) throw InputError(keptProgram.string(), "mesh", "the kept program names no CAD model");
    input.meshFile = kept / fs::path(input.program["mesh"].as<std::string>()).filename();
    input.viewsYaml = files::readText(kept / (record.part + "-views.yaml"));
    input.verificationJson = files::readText(kept / files::kVerificationJson);
    input.evidenceFolder = kept;
    input.releasedBy = by.name;
    input.rolledBackFrom = version;
    input.header = header(folder, record.part, "version " + std::to_string(version) + " in force again (rollback)");
    const Released released = releaseVersion(input);
    const std::string sha = sha256Hex(input.verificationJson);
    files::appendHistory(
        folder, {{"version", released.version},
                 {"action", "rollback"},
                 {"by", by.name},
                 {"at", released.releasedAt},
                 {"what", "version " + std::to_string(version) + " in force again"},
                 {"revision", nullptr},
                 {"plc_program", record.plcProgram ? nlohmann::json(*record.plcProgram) : nlohmann::json(nullptr)},
                 {"verification_sha256", sha},
                 {"rolled_back_from", version}});
    return versionOf(released, by.name, sha, version);
}

namespace {

} // namespace

std::vector<Version> Workspace::versions(std::string_view part) const
{
    const fs::path folder = partFolder(part);
    files::PartLock lock(folder, false);
    const PartRecord record = files::readRecord(folder);
    const auto inForce = files::releaseRecordOf(files::releasedFile(folder, record.part));
    std::vector<Version> out;
    const fs::path releases = folder / "releases";
    const std::string prefix = record.part + ".v";
    std::error_code ec;
    for (auto it = fs::directory_iterator(releases, ec); !ec && it != fs::directory_iterator(); it.increment(ec)) {
        const std::string name = it->path().filename().string();
        if (name.rfind(prefix, 0) != 0) continue;
        if (auto v = files::releaseRecordOf(it->path() / (record.part + ".yaml"))) {
            v->inForce = inForce && inForce->version == v->version;
            out.push_back(*v);
        }
    }
    std::sort(out.begin(), out.end(), [](const Version& a, const Version& b) { return a.version < b.version; });
    return out;
}

std::vector<ReleasedPart> Workspace::releasedParts() const
{
    std::vector<ReleasedPart> out;
    std::error_code ec;
    for (auto it = fs::directory_iterator(folder_, ec); !ec && it != fs::directory_iterator(); it.increment(ec)) {
        const std::string name = it->path().filename().string();
        if (!validPartName(name) || !files::exists(it->path() / files::kRecord)) continue;
        try {
            files::PartLock lock(it->path(), false);
            const PartRecord record = files::readRecord(it->path());
            const auto inForce = files::releaseRecordOf(files::releasedFile(it->path(), record.part));
            if (!record.plcProgram || !inForce) continue;
            out.push_back({record.part, *record.plcProgram, inForce->version,
                           files::releasedFile(it->path(), record.part), files::viewsFile(it->path(), record.part),
                           it->path() / record.cad});
        } catch (const InputError& e) {
            log::category("workbench")->warn("{}: {}", name, e.what());
        }
    }
    std::sort(out.begin(), out.end(), [](const ReleasedPart& a, const ReleasedPart& b) { return a.part < b.part; });
    return out;
}

} // namespace hg::workbench
