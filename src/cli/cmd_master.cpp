// hullgauge master --store DB --program N --master CERT.yaml [--master CERT2.yaml] --out FILE:
// the correction set of docs/mastering.md from the master cycles of the
// result store (read read-only, beside the daemon). With --run N the command
// first runs the N master cycles itself through the daemon's maintenance
// socket, computes the set from exactly those cycles, writes it into the
// daemon's mastering folder and has the daemon reload it (docs/mastering.md,
// "The command"). The computation is pure (hullgauge/study/mastering.h).
#include "command.h"
#include "daemon_socket.h"
#include "hullgauge/common/clock.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/format.h"
#include "hullgauge/common/log.h"
#include "hullgauge/store/result_reader.h"
#include "hullgauge/study/mastering.h"

#include <csignal>
#include <filesystem>
#include <iostream>
#include <memory>
#include <set>

namespace hg::cli {
namespace {

using namespace std::chrono_literals;

struct MasterOptions {
    std::string store;
    int program = 0;
    std::vector<std::string> masters;
    std::string since, until;
    std::size_t minCycles = 5;
    std::string material;
    std::string out;
    std::size_t run = 0;     ///< --run N: the master cycles run through the daemon first; 0: none
    std::string socket;      ///< --socket: the daemon's maintenance socket (with --run)
    double timeoutS = 120.0; ///< --timeout: the wait for each cycle's result and for the reload
};

/// The master's pass/fail cycles of purpose `master` with its serial, oldest
/// first, as uncorrected readings (only the rows `only` names, when it names
/// any); the program versions they were run with.
std::vector<study::StudyRecord> masterCycles(const store::ResultReader& store, const study::MasterCertificate& m,
                                             const MasterOptions& o, const std::set<std::int64_t>& only,
                                             std::set<int>& versions)
{
    store::ResultQuery q;
    q.verdicts = {"pass", "fail"};
    q.purpose = "master";
    q.program = o.program;
    q.serial = m.serial;
    if (!o.since.empty()) q.sinceMs = store::parseUtc(o.since, "--since");
    if (!o.until.empty()) q.untilMs = store::parseUtc(o.until, "--until");
    if (!only.empty()) q.afterId = *only.begin() - 1;
    q.newestFirst = false;
    std::vector<study::StudyRecord> records;
    for (auto& row : store.select(q)) {
        if (!only.empty() && !only.contains(row["id"].get<std::int64_t>())) continue;
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

/// The set of the masters' cycles (those of `only` when it names any), written to --out and printed.
inspect::CorrectionSet computeSet(const MasterOptions& o, const std::vector<study::MasterCertificate>& masters,
                                  const std::set<std::int64_t>& only)
{
    const store::ResultReader store(o.store);
    std::set<int> versions;
    std::vector<std::vector<study::StudyRecord>> cycles;
    for (const auto& m : masters) cycles.push_back(masterCycles(store, m, o, only, versions));
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
    inspect::CorrectionSet set = study::computeCorrections(masters, cycles, target);
    inspect::saveCorrectionSet(set, o.out);
    std::cout << "correction set " << set.id << " (" << enumName(set.method()) << ") written to " << o.out << "\n";
    std::cout << "landmark            offset mm    gain     s mm  U_corr mm  cycles\n";
    for (const auto& l : set.landmarks)
        std::cout << fmt::format("{:<18} {:>10} {:>7} {:>8} {:>10} {:>7}\n", l.id, formatNumber(l.offsetMm(), 4),
                                 formatNumber(l.gain(), 5), formatNumber(l.points[0].spreadMm, 3),
                                 formatNumber(l.uncertaintyAt(l.points[0].measuredMm), 3), l.points[0].cycles);
    hg::log::category("study")->info("mastering of program {}: set {}", o.program, set.id);
    return set;
}

// ---- --run: the master cycles through the daemon (docs/mastering.md, "The command") ----

/// Set by SIGTERM and SIGINT: the run stops at its next wait, the purpose goes back to production.
volatile std::sig_atomic_t cancelSignal = 0;

extern "C" void onMasterRunCancelled(int signal)
{
    cancelSignal = signal;
}

/// A wait of the run: polls every 100 ms on the steady clock until `done()`
/// or `timeout`; a SIGINT or SIGTERM ends it at once. Throws hg::FaultError
/// naming `what` when it ends without `done()`.
template <class Done> void waitFor(const std::string& what, double timeoutS, Done done)
{
    Clock& clock = Clock::steady();
    const auto deadline =
        clock.now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(timeoutS));
    while (!done()) {
        if (cancelSignal != 0)
            throw FaultError(std::string("cancelled (") + (cancelSignal == SIGINT ? "SIGINT" : "SIGTERM") +
                             ") waiting for " + what);
        if (clock.now() > deadline)
            throw FaultError(fmt::format("{} not within {} s (--timeout)", what, formatNumber(timeoutS, 0)));
        clock.sleepUntil(clock.now() + 100ms, [] { return cancelSignal != 0; });
    }
}

/// The daemon's side of the run: its socket, its result store and where its
/// mastering folder keeps the set of the program (empty without one).
struct Daemon {
    std::string socket;
    std::string store;
    std::string setFile;
};

Daemon askDaemon(const MasterOptions& o)
{
    Daemon d{daemonSocketPath(o.socket), {}, {}};
    const auto status = daemonRequest(d.socket, {{"command", "status"}});
    d.store = status.at("results").at("database").get<std::string>();
    const auto mastering = status.value("mastering", nlohmann::json());
    if (mastering.is_object() && mastering.value("folder", nlohmann::json()).is_string())
        d.setFile = (std::filesystem::path(mastering["folder"].get<std::string>()) /
                     ("program-" + std::to_string(o.program) + ".json"))
                        .string();
    return d;
}

/// One manual trigger of the master (as `ctl trigger`); a station busy with
/// another cycle is asked again until the deadline, any other refusal ends the run.
void triggerMaster(const Daemon& d, const MasterOptions& o, const std::string& serial)
{
    const nlohmann::json trigger{{"command", "trigger"}, {"program", o.program}, {"serial", serial}};
    waitFor("the station to take the master's trigger", o.timeoutS, [&] {
        const auto answer = daemonAnswer(d.socket, trigger);
        if (answer.value("ok", false)) return true;
        const auto refusal = answer.value("error", std::string("trigger refused"));
        if (refusal != "trigger refused: busy") throw FaultError("daemon: " + refusal);
        return false;
    });
}

/// The row the master cycle triggered after row `afterId` was stored as: the
/// next manual cycle of purpose master with the master's serial.
nlohmann::json waitForResult(const store::ResultReader& store, const MasterOptions& o, const std::string& serial,
                             std::int64_t afterId, std::size_t k)
{
    store::ResultQuery q;
    q.program = o.program;
    q.serial = serial;
    q.purpose = "master";
    q.manual = true;
    q.afterId = afterId;
    q.newestFirst = false;
    q.limit = 1;
    nlohmann::json row;
    waitFor(fmt::format("the result of master cycle {} of {}", k, o.run), o.timeoutS, [&] {
        auto rows = store.select(q);
        if (rows.empty()) return false;
        row = std::move(rows[0]);
        return true;
    });
    return row;
}

/// Runs the --run master cycles with the purpose master and returns their
/// rows' ids; the purpose is production again however it ends (a refusal, a
/// cycle not judged, a timeout, SIGINT or SIGTERM).
std::set<std::int64_t> runMasterCycles(const Daemon& d, const MasterOptions& o, const std::string& serial)
{
    const store::ResultReader store(d.store);
    store::ResultQuery newest;
    newest.limit = 1;
    const auto last = store.select(newest);
    std::int64_t afterId = last.empty() ? 0 : last[0]["id"].get<std::int64_t>();
    const auto production = [&] {
        daemonRequest(d.socket, {{"command", "purpose"}, {"purpose", "production"}});
        std::cerr << "purpose: production" << std::endl;
    };
    std::set<std::int64_t> ids;
    daemonRequest(d.socket, {{"command", "purpose"}, {"purpose", "master"}});
    try {
        for (std::size_t k = 1; k <= o.run; ++k) {
            triggerMaster(d, o, serial);
            const auto row = waitForResult(store, o, serial, afterId, k);
            afterId = row["id"].get<std::int64_t>();
            const auto verdict = row["verdict"].get<std::string>();
            std::cerr << fmt::format("master cycle {} of {}: {} (result {})", k, o.run, verdict, afterId) << std::endl;
            if (verdict != "pass" && verdict != "fail")
                throw FaultError(fmt::format("master cycle {} of {} (result {}) ended {} with fault code {}: run the "
                                             "master again once the station is ready",
                                             k, o.run, afterId, verdict, row.value("fault_code", 0)));
            ids.insert(afterId);
        }
    } catch (...) {
        try {
            production();
        } catch (const std::exception& e) {
            std::cerr << "the purpose could not be set back to production (" << e.what()
                      << "): set it with `hullgauge ctl purpose production`" << std::endl;
        }
        throw;
    }
    production();
    return ids;
}

/// --run: the cycles, the set from them, and the daemon reloading it. The
/// purpose is the station's: production triggers of the PLC meanwhile would
/// run as master cycles too, so the line is stopped while the master runs.
int runThroughDaemon(MasterOptions o, const study::MasterCertificate& master)
{
    const Daemon d = askDaemon(o);
    if (o.store.empty()) o.store = d.store;
    if (o.out.empty()) {
        if (d.setFile.empty())
            throw InputError("", "--out",
                             "the daemon has no mastering.folder (docs/mastering.md, \"In the daemon\"): give --out");
        o.out = d.setFile;
    }
    o.minCycles = o.run;
    struct sigaction action {};
    action.sa_handler = onMasterRunCancelled;
    sigemptyset(&action.sa_mask);
    sigaction(SIGTERM, &action, nullptr);
    sigaction(SIGINT, &action, nullptr);
    const auto ids = runMasterCycles(d, o, master.serial);
    const auto set = computeSet(o, {master}, ids);
    daemonRequest(d.socket, {{"command", "reload"}});
    std::error_code ec;
    if (d.setFile.empty() || !std::filesystem::equivalent(o.out, d.setFile, ec)) {
        std::cout << "the daemon reads program " << o.program << "'s set from "
                  << (d.setFile.empty() ? std::string("its mastering.folder") : d.setFile) << "\n";
        return 0;
    }
    // In force once the reloaded configuration names it (a refused reload keeps the running one).
    waitFor("the daemon to take correction set " + set.id + " (a refused reload is in its journal)", o.timeoutS, [&] {
        const auto status = daemonRequest(d.socket, {{"command", "status"}});
        const auto sets = status.value("mastering", nlohmann::json()).value("sets", nlohmann::json());
        return sets.value(std::to_string(o.program), std::string()) == set.id;
    });
    std::cout << "correction set " << set.id << " in force for program " << o.program << "\n";
    return 0;
}

int run(const MasterOptions& o)
{
    std::vector<study::MasterCertificate> masters;
    for (const std::string& file : o.masters) masters.push_back(study::loadMasterCertificate(file));
    if (masters.size() == 2 && masters[0].serial == masters[1].serial)
        throw InputError(o.masters[1], "master", "both masters have the serial '" + masters[0].serial + "'");
    if (o.run > 0) {
        if (masters.size() > 1)
            throw InputError("", "--run",
                             "runs one master's cycles: for two-point mastering measure each master, then compute "
                             "the set from the store without --run");
        return runThroughDaemon(o, masters[0]);
    }
    if (o.store.empty()) throw InputError("", "--store", "required without --run");
    if (o.out.empty()) throw InputError("", "--out", "required without --run");
    computeSet(o, masters, {});
    return 0;
}

std::function<int()> factory(CLI::App& app)
{
    auto o = std::make_shared<MasterOptions>();
    auto* cmd = app.add_subcommand("master", "the correction set of a master part (one-point) or two (two-point) "
                                             "from its master cycles in the result store (docs/mastering.md); "
                                             "with --run, the master cycles run through the daemon first");
    cmd->add_option("--store", o->store, "the result store (SQLite, read read-only); with --run the daemon's");
    cmd->add_option("--program", o->program, "the part program the master cycles ran")
        ->required()
        ->check(CLI::Range(1, 65535));
    cmd->add_option("--master", o->masters, "a master's certificate (YAML); twice for two-point mastering")
        ->required()
        ->expected(1, 2)
        ->check(CLI::ExistingFile);
    auto* since =
        cmd->add_option("--since", o->since, "only cycles started at or after this UTC time (YYYY-MM-DD[THH:MM[:SS]])");
    auto* until = cmd->add_option("--until", o->until, "only cycles started before this UTC time");
    auto* minCycles = cmd->add_option("--min-cycles", o->minCycles, "fewest cycles per master (default 5)")
                          ->check(CLI::Range(2, 1000000));
    cmd->add_option("--material", o->material, "the material the set is for (the program's material.name)");
    cmd->add_option("--out", o->out,
                    "the correction set file to write; with --run the daemon's mastering.folder/program-<N>.json");
    auto* runs = cmd->add_option("--run", o->run,
                                 "run N master cycles through the daemon (purpose master, the certificate's serial), "
                                 "compute the set from them and have the daemon reload it")
                     ->check(CLI::Range(2, 10000));
    cmd->add_option("--socket", o->socket,
                    "with --run: the maintenance socket (default $HULLGAUGE_SOCKET, else " +
                        std::string(kDefaultSocket) + ")")
        ->needs(runs);
    cmd->add_option("--timeout", o->timeoutS, "with --run: seconds to wait for each cycle's result and the reload")
        ->check(CLI::Range(1.0, 86400.0))
        ->needs(runs);
    runs->excludes(since)->excludes(until)->excludes(minCycles);
    return [=]() { return run(*o); };
}

} // namespace

HG_REGISTER_COMMAND("master", factory);

} // namespace hg::cli
