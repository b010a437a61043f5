#include "daemon.h"

#include "cycle_runner.h"
#include "hullgauge/calib/target.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/log.h"
#include "hullgauge/geometry/station.h"
#include "maintenance.h"
#include "notify.h"
#include "plc_server.h"
#include "result_store.h"

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdlib>
#include <iostream>
#include <poll.h>
#include <signal.h>
#include <sys/signalfd.h>
#include <unistd.h>

namespace hg::daemon {
namespace {

using Clock = std::chrono::steady_clock;

std::set<std::uint16_t> programNumbers(const station::DaemonConfig& cfg)
{
    std::set<std::uint16_t> numbers;
    for (const auto& [number, program] : cfg.programs) numbers.insert(number);
    return numbers;
}

// Settings the running daemon cannot change without restarting its servers or drivers.
std::vector<std::string> needsRestart(const station::DaemonConfig& a, const station::DaemonConfig& b)
{
    std::vector<std::string> keys;
    if (a.stationFile != b.stationFile) keys.push_back("station");
    if (a.plc.bindAddress != b.plc.bindAddress || a.plc.port != b.plc.port || a.plc.unitId != b.plc.unitId ||
        a.plc.allowedClients.size() != b.plc.allowedClients.size())
        keys.push_back("plc");
    if (a.results.database != b.results.database) keys.push_back("results.database");
    if (a.maintenance.socket != b.maintenance.socket) keys.push_back("maintenance.socket");
    return keys;
}

std::int64_t ageNs(std::int64_t thenNs)
{
    auto now = std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now().time_since_epoch()).count();
    return now - thenNs;
}

} // namespace

int runDaemon(int argc, char** argv, const DevicesFactory& makeDevices, const InspectorFactory& makeInspector)
{
    CLI::App app{"hullgauged: the inspection station daemon (PLC over Modbus TCP, capture, inspection, results)"};
    std::string configFile = "/etc/hullgauge/hullgauged.yaml";
    std::string logSpec;
    bool checkOnly = false;
    app.add_option("--config", configFile, "daemon configuration (YAML)")->capture_default_str();
    app.add_option("--log", logSpec, "log levels, e.g. 'info' or 'warn,plc=debug' (also $HULLGAUGE_LOG)");
    app.add_flag("--check", checkOnly, "validate the configuration and exit (0 valid, 2 invalid)");
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        int rc = app.exit(e);
        return rc == 0 ? 0 : static_cast<int>(ExitStatus::BadInput);
    }

    // Under systemd (INVOCATION_ID is set for every unit) stderr is the journal.
    if (std::getenv("INVOCATION_ID")) hg::log::useJournal();
    auto log = hg::log::category("daemon");
    std::shared_ptr<const station::DaemonConfig> config;
    try {
        if (!logSpec.empty()) hg::log::configure(logSpec);
        config = std::make_shared<const station::DaemonConfig>(station::loadDaemonConfig(configFile));
    } catch (const InputError& e) {
        std::cerr << "hullgauged: " << e.what() << '\n';
        return static_cast<int>(ExitStatus::BadInput);
    }
    if (checkOnly) {
        std::cout << configFile << ": valid (" << config->programs.size() << " part programs)\n";
        return 0;
    }

    // Signals are taken synchronously by the main loop; block them before any thread starts.
    sigset_t signals;
    sigemptyset(&signals);
    sigaddset(&signals, SIGTERM);
    sigaddset(&signals, SIGINT);
    sigaddset(&signals, SIGHUP);
    sigaddset(&signals, SIGPIPE);
    pthread_sigmask(SIG_BLOCK, &signals, nullptr);
    int sigFd = signalfd(-1, &signals, SFD_CLOEXEC | SFD_NONBLOCK);

    Notifier notifier;
    try {
        ResultStore store(config->results.database);
        station::PlcRegisters registers;
        registers.setKnownPrograms(programNumbers(*config));
        StationHardware hardware = makeDevices(*config);
        auto& devices = hardware.devices;
        SimulationControl* simulation = hardware.simulation;
        auto inspector = makeInspector(*config);
        PlcServer plc(registers, config->plc);
        plc.start();
        CycleRunner runner(registers, *devices, *inspector, store, config);

        auto handle = [&](const nlohmann::json& request) -> nlohmann::json {
            auto command = request.at("command").get<std::string>();
            if (command == "status") {
                auto regs = registers.snapshot();
                auto counters = plc.counters();
                return {{"ok", true},
                        {"pid", getpid()},
                        {"config", config->file.string()},
                        {"sequencer", runner.describe()},
                        {"plc",
                         {{"port", plc.port()},
                          {"status", regs[station::reg::Status]},
                          {"ack_seq", regs[station::reg::AckSeq]},
                          {"done_seq", regs[station::reg::DoneSeq]},
                          {"result", regs[station::reg::Result]},
                          {"fault_code", regs[station::reg::FaultCode]},
                          {"heartbeat", regs[station::reg::Heartbeat]},
                          {"rejected_triggers", regs[station::reg::RejectedTriggers]},
                          {"clients", counters.clients},
                          {"requests", counters.requests},
                          {"exceptions", counters.exceptions},
                          {"refused_connections", counters.refusedConnections},
                          {"dropped_connections", counters.droppedConnections}}},
                        {"results", {{"database", store.file().string()}, {"records", store.count()}}},
                        {"lamps", devices->lampStatus()},
                        {"calibration", runner.calibration()},
                        {"simulated_part", simulation ? simulation->part() : std::string()}};
            }
            if (command == "results") {
                int limit = request.value("limit", 10);
                return {{"ok", true}, {"results", store.recent(std::clamp(limit, 1, 1000))}};
            }
            if (command == "trigger") {
                auto program = request.value("program", 0);
                if (program < 1 || program > 65535) return {{"ok", false}, {"error", "program must be 1..65535"}};
                auto reason = registers.triggerManually(static_cast<std::uint16_t>(program),
                                                        request.value("serial", std::string()));
                if (reason == station::RejectReason::None) return {{"ok", true}};
                static constexpr const char* why[] = {"", "busy", "unknown part program",
                                                      "not ready (fault or starting)"};
                return {{"ok", false}, {"error", std::string("trigger refused: ") + why[static_cast<int>(reason)]}};
            }
            if (command == "abort") {
                runner.abort();
                return {{"ok", true}};
            }
            if (command == "calibrate") {
                // The live fixture calibration (docs/calibration.md), run by the
                // cycle runner between cycles. Bad input is answered at once.
                CalibrationJob job;
                try {
                    job.target = calib::TargetSpec::parse(request.value("pattern", std::string()), "pattern");
                    const auto poses = request.value("poses", std::string());
                    if (poses.empty()) return {{"ok", false}, {"error", "poses: the poses YAML file is required"}};
                    job.poses = geometry::loadPoses(poses, &config->station.fixture);
                } catch (const std::exception& e) {
                    return {{"ok", false}, {"error", e.what()}};
                }
                if (config->station.fixture.type != geometry::FixtureType::RotationDeclination)
                    return {{"ok", false}, {"error", "calibrate solves rotation/declination fixtures"}};
                job.out = request.value("out", config->stationFile.string());
                std::string why;
                if (!runner.requestCalibration(std::move(job), why)) return {{"ok", false}, {"error", why}};
                return {{"ok", true}, {"calibration", runner.calibration()}};
            }
            if (command == "calibration") return {{"ok", true}, {"calibration", runner.calibration()}};
            if (command == "sim-part") {
                if (!simulation || simulation->parts().empty())
                    return {{"ok", false}, {"error", "the camera is not simulated"}};
                if (request.value("list", false))
                    return {{"ok", true}, {"parts", simulation->parts()}, {"current", simulation->part()}};
                auto name = request.value("name", std::string());
                if (!simulation->selectPart(name))
                    return {{"ok", false}, {"error", "unknown simulated part '" + name + "' (see sim-part --list)"}};
                return {{"ok", true}, {"current", name}};
            }
            return {{"ok", false}, {"error", "unknown command '" + command + "'"}};
        };
        MaintenanceServer maintenance(config->maintenance.socket, config->maintenance.group, handle);

        notifier.status("starting devices");
        runner.start([&] { notifier.ready("ready; PLC on port " + std::to_string(plc.port())); });

        const auto heartbeat = config->plc.heartbeatPeriod;
        auto watchdogPeriod = std::chrono::milliseconds(1000);
        if (auto wd = notifier.watchdogInterval())
            watchdogPeriod = std::chrono::duration_cast<std::chrono::milliseconds>(*wd / 2);
        auto nextBeat = Clock::now();
        auto nextPing = Clock::now();
        bool wasHealthy = true;
        bool running = true;
        while (running) {
            auto now = Clock::now();
            if (now >= nextBeat) {
                registers.beat();
                nextBeat = now + heartbeat;
            }
            // Healthy: the PLC server loop turns (it wakes every 0.5 s) and no cycle is stuck.
            bool healthy =
                ageNs(plc.lastLoopNs()) < std::chrono::nanoseconds(std::chrono::seconds(3)).count() && runner.healthy();
            if (healthy != wasHealthy) {
                if (healthy)
                    log->info("healthy again; watchdog pings resume");
                else
                    log->error("unhealthy (PLC server loop stalled or cycle longer than watchdog.max_cycle_s); "
                               "watchdog pings stop");
                wasHealthy = healthy;
            }
            if (healthy && now >= nextPing && notifier.watchdogInterval()) {
                notifier.watchdog();
                nextPing = now + watchdogPeriod;
            }
            auto state = runner.state();
            notifier.status(healthy ? std::string(station::toString(state))
                                    : "unhealthy: " + std::string(station::toString(state)));

            auto wake = std::min(nextBeat, notifier.watchdogInterval() ? nextPing : nextBeat);
            auto timeoutMs = std::chrono::duration_cast<std::chrono::milliseconds>(wake - Clock::now()).count();
            pollfd fds[2] = {{sigFd, POLLIN, 0}, {maintenance.fd(), POLLIN, 0}};
            int n = poll(fds, 2, static_cast<int>(std::clamp<long long>(timeoutMs, 1, 1000)));
            if (n <= 0) continue;
            if (fds[1].revents & POLLIN) maintenance.serveOne();
            if (!(fds[0].revents & POLLIN)) continue;
            signalfd_siginfo info{};
            while (read(sigFd, &info, sizeof info) == sizeof info) {
                if (info.ssi_signo == SIGHUP) {
                    notifier.reloading();
                    try {
                        auto fresh =
                            std::make_shared<const station::DaemonConfig>(station::loadDaemonConfig(config->file));
                        for (const auto& key : needsRestart(*config, *fresh))
                            log->warn("reload: '{}' changed; it takes effect when the daemon restarts", key);
                        registers.setKnownPrograms(programNumbers(*fresh));
                        runner.setConfig(fresh);
                        config = fresh;
                        log->info("configuration reloaded from {} ({} part programs)", config->file.string(),
                                  config->programs.size());
                    } catch (const InputError& e) {
                        log->error("reload refused, keeping the running configuration: {}", e.what());
                    }
                    notifier.ready(std::string(station::toString(runner.state())));
                } else if (info.ssi_signo == SIGTERM || info.ssi_signo == SIGINT) {
                    log->info("stopping on signal {}", info.ssi_signo);
                    running = false;
                }
            }
        }
        notifier.stopping("stopping: finishing or aborting the cycle");
        runner.stop();
        plc.stop();
        log->info("stopped");
    } catch (const FaultError& e) {
        log->critical("{}", e.what());
        notifier.stopping(std::string("failed: ") + e.what());
        close(sigFd);
        return static_cast<int>(ExitStatus::Fault);
    } catch (const InputError& e) {
        log->critical("{}", e.what());
        close(sigFd);
        return static_cast<int>(ExitStatus::BadInput);
    }
    close(sigFd);
    return 0;
}

} // namespace hg::daemon
