// hullgauge master --store DB --program N --master CERT.yaml [--master CERT2.yaml] --out FILE:
// the correction set of docs/mastering.md from the master cycles of the
// result store (read read-only, beside the daemon). With --run N the daemon
// runs the master itself — its mastering run (docs/mastering.md, "The
// mastering run"), the one the HMI's maintenance page starts too — and the
// command follows it. The computation is pure (hullgauge/study/mastering.h),
// the rows chosen one way (hullgauge/store/master_cycles.h).
#include "command.h"
#include "daemon_socket.h"
#include "hullgauge/common/clock.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/format.h"
#include "hullgauge/common/log.h"
#include "hullgauge/store/master_cycles.h"

#include <csignal>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>

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
    std::size_t run = 0;     ///< --run N: the daemon runs N master cycles first; 0: none
    std::string socket;      ///< --socket: the daemon's maintenance socket (with --run)
    double timeoutS = 120.0; ///< --timeout: the daemon's wait for each cycle's result and for the reload
};

/// The table of the set's landmarks (offset, gain, spread, U_corr, cycles), from the set or the daemon's summary.
void printLandmarks(const nlohmann::json& landmarks)
{
    std::cout << "landmark            offset mm    gain     s mm  U_corr mm  cycles\n";
    for (const auto& l : landmarks)
        std::cout << fmt::format("{:<18} {:>10} {:>7} {:>8} {:>10} {:>7}\n", l.value("id", std::string()),
                                 formatNumber(l.value("offset_mm", 0.0), 4), formatNumber(l.value("gain", 1.0), 5),
                                 formatNumber(l.value("spread_mm", 0.0), 3),
                                 formatNumber(l.value("uncertainty_mm", 0.0), 3), l.value("cycles", 0));
}

/// Without --run: the set of the masters' cycles in the store, written to --out and printed.
int computeFromStore(const MasterOptions& o, const std::vector<study::MasterCertificate>& masters)
{
    store::MasterCycleSelection selection;
    selection.program = o.program;
    if (!o.since.empty()) selection.sinceMs = store::parseUtc(o.since, "--since");
    if (!o.until.empty()) selection.untilMs = store::parseUtc(o.until, "--until");
    selection.minCycles = o.minCycles;
    const auto set = store::masterCorrectionSet(store::ResultReader(o.store), masters, selection, o.material,
                                                Clock::steady().wallMs());
    inspect::saveCorrectionSet(set, o.out);
    std::cout << "correction set " << set.id << " (" << enumName(set.method()) << ") written to " << o.out << "\n";
    const auto landmarks = store::landmarkSummary(set);
    printLandmarks(landmarks);
    hg::log::category("study")->info("mastering of program {}: set {}", o.program, set.id);
    return 0;
}

// ---- --run: the daemon's mastering run (docs/mastering.md, "The mastering run") ----

/// Set by SIGTERM and SIGINT: the daemon is asked to cancel the run, which puts the purpose back.
volatile std::sig_atomic_t cancelSignal = 0;

extern "C" void onMasterRunCancelled(int signal)
{
    cancelSignal = signal;
}

std::string fileText(const std::string& file)
{
    std::ifstream in(file, std::ios::binary);
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
}

/// --run: the daemon runs the master and puts the set in force; this follows it, printing each cycle,
/// and asks the daemon to cancel on SIGINT or SIGTERM.
int runThroughDaemon(const MasterOptions& o, const std::string& certificateFile)
{
    const std::string socket = daemonSocketPath(o.socket);
    nlohmann::json request{{"command", "master"},
                           {"program", o.program},
                           {"run", o.run},
                           {"certificate", fileText(certificateFile)},
                           {"certificate_file", certificateFile},
                           {"timeout_s", static_cast<std::int64_t>(o.timeoutS)}};
    if (!o.material.empty()) request["material"] = o.material;
    struct sigaction action {};
    action.sa_handler = onMasterRunCancelled;
    sigemptyset(&action.sa_mask);
    sigaction(SIGTERM, &action, nullptr);
    sigaction(SIGINT, &action, nullptr);
    const auto started = daemonRequest(socket, request)["run"];
    std::cerr << "mastering run of program " << o.program << " started: " << o.run << " cycles of master "
              << started.value("master", std::string()) << " (purpose " << started.value("purpose_before", "?")
              << " until then)" << std::endl;
    std::size_t shown = 0;
    bool cancelled = false;
    // The daemon bounds every wait of the run by the timeout; this bound is only against a daemon that stops answering.
    const double waitS = (static_cast<double>(o.run) + 2.0) * o.timeoutS * 2.0;
    const auto run =
        followJob(socket, {{"command", "master"}}, "run", "the mastering run", waitS, [&](const nlohmann::json& job) {
            const auto& lines = job.value("progress", nlohmann::json::array());
            for (; shown < lines.size(); ++shown) std::cerr << lines[shown].get<std::string>() << std::endl;
            if (cancelSignal == 0 || cancelled) return;
            cancelled = true;
            std::cerr << "cancelled (" << (cancelSignal == SIGINT ? "SIGINT" : "SIGTERM")
                      << "): the daemon ends the run and puts the purpose back" << std::endl;
            daemonRequest(socket, {{"command", "master"}, {"cancel", true}});
        });
    const auto& set = run["set"];
    std::cout << "correction set " << set.value("id", std::string()) << " (" << set.value("method", std::string())
              << ") written to " << set.value("file", std::string()) << "\n";
    printLandmarks(set.value("landmarks", nlohmann::json::array()));
    std::cout << "correction set " << set.value("id", std::string()) << " in force for program " << o.program << "\n";
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
        return runThroughDaemon(o, o.masters[0]);
    }
    if (o.store.empty()) throw InputError("", "--store", "required without --run");
    if (o.out.empty()) throw InputError("", "--out", "required without --run");
    return computeFromStore(o, masters);
}

std::function<int()> factory(CLI::App& app)
{
    auto o = std::make_shared<MasterOptions>();
    auto* cmd = app.add_subcommand("master", "the correction set of a master part (one-point) or two (two-point) "
                                             "from its master cycles in the result store (docs/mastering.md); "
                                             "with --run, the daemon runs the master cycles first");
    auto* store = cmd->add_option("--store", o->store, "the result store (SQLite, read read-only); not with --run");
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
    cmd->add_option("--material", o->material,
                    "the material the set is for (the program's material.name); with --run by default the "
                    "program's as the daemon loaded it");
    auto* out = cmd->add_option("--out", o->out,
                                "the correction set file to write; not with --run (the daemon writes "
                                "mastering.folder/program-<N>.json)");
    auto* runs = cmd->add_option("--run", o->run,
                                 "have the daemon run N master cycles (purpose master, the certificate's serial), "
                                 "compute the set from them and put it in force; follows its progress")
                     ->check(CLI::Range(2, 10000));
    cmd->add_option("--socket", o->socket,
                    "with --run: the maintenance socket (default $HULLGAUGE_SOCKET, else " +
                        std::string(kDefaultSocket) + ")")
        ->needs(runs);
    cmd->add_option("--timeout", o->timeoutS,
                    "with --run: the daemon's longest wait, in seconds, for each cycle's result and the reload")
        ->check(CLI::Range(1.0, 86400.0))
        ->needs(runs);
    runs->excludes(since)->excludes(until)->excludes(minCycles)->excludes(store)->excludes(out);
    return [=]() { return run(*o); };
}

} // namespace

HG_REGISTER_COMMAND("master", factory);

} // namespace hg::cli
