#include "hullgauge/store/master_cycles.h"

#include "hullgauge/common/error.h"

namespace hg::store {
namespace {

/// The master's pass/fail cycles of purpose `master` with its serial, oldest
/// first, as uncorrected readings; the program versions they were run with.
std::vector<study::StudyRecord> masterCycles(const ResultReader& store, const study::MasterCertificate& m,
                                             const MasterCycleSelection& s, std::set<int>& versions)
{
    ResultQuery q;
    q.verdicts = {"pass", "fail"};
    q.purpose = "master";
    q.program = s.program;
    q.serial = m.serial;
    q.sinceMs = s.sinceMs;
    q.untilMs = s.untilMs;
    if (!s.only.empty()) q.afterId = *s.only.begin() - 1;
    q.newestFirst = false;
    std::vector<study::StudyRecord> records;
    for (auto& row : store.select(q)) {
        if (!s.only.empty() && !s.only.contains(row["id"].get<std::int64_t>())) continue;
        versions.insert(row.value("program_version", nlohmann::json()).is_number() ? row["program_version"].get<int>()
                                                                                   : 0);
        records.push_back(
            {row["id"].get<std::int64_t>(), row["serial"].get<std::string>(), std::move(row["landmarks"])});
    }
    if (records.size() < s.minCycles)
        throw InputError(m.file.string(), "master",
                         std::to_string(records.size()) + " pass/fail master cycles of program " +
                             std::to_string(s.program) + " with serial '" + m.serial + "' in " + store.file().string() +
                             ", " + std::to_string(s.minCycles) + " needed (" + s.minCyclesOption + ")");
    return study::uncorrectedRecords(std::move(records));
}

/// "20260412T081500Z" from the store's "2026-04-12T08:15:00.000Z".
std::string compactUtc(std::int64_t unixMs)
{
    std::string s = formatUtc(unixMs).substr(0, 19);
    std::erase(s, '-');
    std::erase(s, ':');
    return s + "Z";
}

} // namespace

inspect::CorrectionSet masterCorrectionSet(const ResultReader& store,
                                           const std::vector<study::MasterCertificate>& masters,
                                           const MasterCycleSelection& selection, const std::string& material,
                                           std::int64_t createdUnixMs)
{
    std::set<int> versions;
    std::vector<std::vector<study::StudyRecord>> cycles;
    for (const auto& m : masters) cycles.push_back(masterCycles(store, m, selection, versions));
    if (versions.size() > 1)
        throw InputError("", "--since",
                         "the master cycles span several versions of program " + std::to_string(selection.program) +
                             ": choose the window of one");
    study::MasteringTarget target;
    target.program = selection.program;
    if (*versions.begin() > 0) target.programVersion = *versions.begin();
    target.material = material;
    target.createdUnixMs = createdUnixMs;
    target.createdUtc = compactUtc(createdUnixMs);
    return study::computeCorrections(masters, cycles, target);
}

nlohmann::json landmarkSummary(const inspect::CorrectionSet& set)
{
    auto landmarks = nlohmann::json::array();
    for (const auto& l : set.landmarks)
        landmarks.push_back({{"id", l.id},
                             {"offset_mm", l.offsetMm()},
                             {"gain", l.gain()},
                             {"spread_mm", l.points[0].spreadMm},
                             {"uncertainty_mm", l.uncertaintyAt(l.points[0].measuredMm)},
                             {"cycles", l.points[0].cycles}});
    return landmarks;
}

} // namespace hg::store
