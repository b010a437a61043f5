// hullgauge master --store DB --program N --master CERT.yaml [--master CERT2.yaml] --out FILE:
// the correction set of docs/mastering.md from the master cycles of the
// result store (read read-only, beside the daemon). The computation is pure
// (hullgauge/study/mastering.h).
#include "command.h"
#include "hullgauge/common/clock.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/format.h"
#include "hullgauge/common/log.h"
#include "hullgauge/store/result_reader.h"
#include "hullgauge/study/mastering.h"

#include <iostream>
#include <memory>
#include <set>

namespace hg::cli {
namespace {

struct MasterOptions {
    std::string store;
    int program = 0;
    std::vector<std::string> masters;
    std::string since, until;
    std::size_t minCycles = 5;
    std::string material;
    std::string out;
};

/// The master's pass/fail cycles of purpose `master` with its serial, oldest
/// first, as uncorrected readings; the program versions they were run with.
std::vector<study::StudyRecord> masterCycles(const store::ResultReader& store, const study::MasterCertificate& m,
                                             const MasterOptions& o, std::set<int>& versions)
{
    store::ResultQuery q;
    q.verdicts = {"pass", "fail"};
    q.purpose = "master";
    q.program = o.program;
    q.serial = m.serial;
    if (!o.since.empty()) q.sinceMs = store::parseUtc(o.since, "--since");
    if (!o.until.empty()) q.untilMs = store::parseUtc(o.until, "--until");
    q.newestFirst = false;
    std::vector<study::StudyRecord> records;
    for (auto& row : store.select(q)) {
        versions.insert(row.value("program_version", nlohmann::json()).is_number() ? row["program_version"].get<int>()
                                                                                   : 0);
        records.push_back(
            {row["id"].get<std::int64_t>(), row["serial"].get<std::string>(), std::move(row["landmarks"])});
    }
    if (records.size() < o.minCycles)
        throw InputError(m.file.string(), "master",
                         std::to_string(records.size()) + " pass/fail master cycles of program " +
                             std::to_string(o.program) + " with serial '" + m.serial + "' in " + o.store + ", " +
                             std::to_string(o.minCycles) + " needed (--min-cycles)");
    return study::uncorrectedRecords(std::move(records));
}

/// "20260412T081500Z" from the store's "2026-04-12T08:15:00.000Z".
std::string compactUtc(std::int64_t unixMs)
{
    std::string s = store::formatUtc(unixMs).substr(0, 19);
    std::erase(s, '-');
    std::erase(s, ':');
    return s + "Z";
}

int run(const MasterOptions& o)
{
    std::vector<study::MasterCertificate> masters;
    for (const std::string& file : o.masters) masters.push_back(study::loadMasterCertificate(file));
    if (masters.size() == 2 && masters[0].serial == masters[1].serial)
        throw InputError(o.masters[1], "master", "both masters have the serial '" + masters[0].serial + "'");
    const store::ResultReader store(o.store);
    std::set<int> versions;
    std::vector<std::vector<study::StudyRecord>> cycles;
    for (const auto& m : masters) cycles.push_back(masterCycles(store, m, o, versions));
    if (versions.size() > 1)
        throw InputError("", "--since",
                         "the master cycles span several versions of program " + std::to_string(o.program) +
                             ": choose the window of one");
    study::MasteringTarget target;
    target.program = o.program;
    if (*versions.begin() > 0) target.programVersion = *versions.begin();
    target.material = o.material;
    target.createdUnixMs = Clock::steady().wallMs();
    target.createdUtc = compactUtc(target.createdUnixMs);
    const inspect::CorrectionSet set = study::computeCorrections(masters, cycles, target);
    inspect::saveCorrectionSet(set, o.out);
    std::cout << "correction set " << set.id << " (" << enumName(set.method()) << ") written to " << o.out << "\n";
    std::cout << "landmark            offset mm    gain     s mm  U_corr mm  cycles\n";
    for (const auto& l : set.landmarks)
        std::cout << fmt::format("{:<18} {:>10} {:>7} {:>8} {:>10} {:>7}\n", l.id, formatNumber(l.offsetMm(), 4),
                                 formatNumber(l.gain(), 5), formatNumber(l.points[0].spreadMm, 3),
                                 formatNumber(l.uncertaintyAt(l.points[0].measuredMm), 3), l.points[0].cycles);
    hg::log::category("study")->info("mastering of program {}: set {}", o.program, set.id);
    return 0;
}

std::function<int()> factory(CLI::App& app)
{
    auto o = std::make_shared<MasterOptions>();
    auto* cmd = app.add_subcommand("master", "the correction set of a master part (one-point) or two (two-point) "
                                             "from its master cycles in the result store (docs/mastering.md)");
    cmd->add_option("--store", o->store, "the result store (SQLite, read read-only)")->required();
    cmd->add_option("--program", o->program, "the part program the master cycles ran")
        ->required()
        ->check(CLI::Range(1, 65535));
    cmd->add_option("--master", o->masters, "a master's certificate (YAML); twice for two-point mastering")
        ->required()
        ->expected(1, 2)
        ->check(CLI::ExistingFile);
    cmd->add_option("--since", o->since, "only cycles started at or after this UTC time (YYYY-MM-DD[THH:MM[:SS]])");
    cmd->add_option("--until", o->until, "only cycles started before this UTC time");
    cmd->add_option("--min-cycles", o->minCycles, "fewest cycles per master (default 5)")
        ->check(CLI::Range(2, 1000000));
    cmd->add_option("--material", o->material, "the material the set is for (the program's material.name)");
    cmd->add_option("--out", o->out, "the correction set file to write")->required();
    return [=]() { return run(*o); };
}

} // namespace

HG_REGISTER_COMMAND("master", factory);

} // namespace hg::cli
