#include "daemon.h"
#include "config_audit.h"
#include "config_reload.h"
#include "foreground.h"

#include "command_mailbox.h"
#include "cycle/cycle_runner.h"
#include "hmi/hmi_server.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/log.h"
#include "maintenance.h"
#include "mastering_run.h"
#include "notify.h"
#include "plant/mqtt_publisher.h"
#include "plant/plc_server.h"

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdlib>
#include <iostream>
#include <poll.h>
#include <set>
#include <signal.h>
#include <sys/signalfd.h>
#include <unistd.h>
#include <utility>
#include <vector>

namespace hg::daemon {
namespace {

std::set<std::uint16_t> programNumbers(const station::DaemonConfig& cfg)
{
    std::set<std::uint16_t> numbers;
    for (const auto& [number, program] : cfg.programs) numbers.insert(number);
    return numbers;
}

/// The networks `plc.allowed_clients` lets in, whatever order the file lists them in.
std::set<std::pair<std::uint32_t, int>> allowedNetworks(const station::PlcConfig& plc)
{
    std::set<std::pair<std::uint32_t, int>> networks;
    for (const auto& net : plc.allowedClients) networks.emplace(net.address, net.prefix);
    return networks;
}

// Settings the running daemon cannot change without restarting its servers or
// drivers (docs/daemon.md lists them). A list is compared by what it holds: one
// address replacing another leaves the count as it was.
std::vector<std::string> needsRestart(const station::DaemonConfig& a, const station::DaemonConfig& b)
{
    std::vector<std::string> keys;
    if (a.stationFile != b.stationFile) keys.push_back("station");
    if (a.plc.bindAddress != b.plc.bindAddress || a.plc.port != b.plc.port || a.plc.unitId != b.plc.unitId ||
        allowedNetworks(a.plc) != allowedNetworks(b.plc))
        keys.push_back("plc");
    if (a.results.database != b.results.database) keys.push_back("results.database");
    if (a.maintenance.socket != b.maintenance.socket) keys.push_back("maintenance.socket");
    if (!(a.mqtt == b.mqtt)) keys.push_back("mqtt");
    if (a.workbench.folder != b.workbench.folder || a.workbench.cli != b.workbench.cli ||
        a.workbench.maxUploadBytes != b.workbench.maxUploadBytes || a.workbench.maxJobs != b.workbench.maxJobs)
        keys.push_back("workbench");
    return keys;
}

/// The daemon's configuration with every part program loaded in full, as its
/// trigger would load it: a bad program is refused here, not at the trigger.
ConfigPtr loadConfig(const std::filesystem::path& file, const ProgramCheck& checkProgram)
{
    auto config = std::make_shared<const station::DaemonConfig>(station::loadDaemonConfig(file));
    if (!checkProgram) return config;
    for (const auto& [number, ref] : config->programs) {
        try {
            checkProgram(ref, config->station);
        } catch (const InputError&) {
            throw;
        } catch (const std::exception& e) {
            throw InputError(ref.partFile.string(), "part program " + std::to_string(number), e.what());
        }
    }
    return config;
}

struct Options {
    std::string configFile = "/etc/hullgauge/hullgauged.yaml";
    std::string logSpec;
    bool checkOnly = false;
    bool foreground = false;
    std::string user = "hullgauge";
};

/// The command line; an exit status when the program ends here (help, bad arguments).
std::optional<int> parseArguments(int argc, char** argv, Options& options)
{
    CLI::App app{"hullgauged: the inspection station daemon (PLC over Modbus TCP, capture, inspection, results)"};
    app.add_option("--config", options.configFile, "daemon configuration (YAML)")->capture_default_str();
    app.add_option("--log", options.logSpec, "log levels, e.g. 'info' or 'warn,plc=debug' (also $HULLGAUGE_LOG)");
    app.add_flag("--check", options.checkOnly, "validate the configuration and exit (0 valid, 2 invalid)");
    app.add_flag("--foreground", options.foreground,
                 "run without systemd as the unit would: create or check the folders of maintenance.socket and "
                 "results.database, as root become --user keeping only the unit's capability, log to stderr");
    app.add_option("--user", options.user, "the user --foreground becomes when started as root")->capture_default_str();
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        int rc = app.exit(e);
        return rc == 0 ? 0 : static_cast<int>(ExitStatus::BadInput);
    }
    return std::nullopt;
}

/// Signals are taken synchronously by the main loop; they are blocked before any thread starts.
int blockSignals()
{
    sigset_t signals;
    sigemptyset(&signals);
    for (int s : {SIGTERM, SIGINT, SIGHUP, SIGPIPE}) sigaddset(&signals, s);
    pthread_sigmask(SIG_BLOCK, &signals, nullptr);
    return signalfd(-1, &signals, SFD_CLOEXEC | SFD_NONBLOCK);
}

/// The daemon's parts once started, and its main loop: HEARTBEAT, WATCHDOG=1
/// while healthy, STATUS lines, signals and the maintenance socket.
class MainLoop {
  public:
    MainLoop(ConfigPtr config, ProgramCheck checkProgram, PlcRegisters& registers, PlcServer& plc, CycleRunner& runner,
             Notifier& notifier, int sigFd, Clock& clock, store::AuditLog& audit)
        : config_(std::move(config)), configFile_(config_->file), checkProgram_(std::move(checkProgram)),
          registers_(registers), plc_(plc), runner_(runner), notifier_(notifier), sigFd_(sigFd), clock_(clock),
          audit_(audit)
    {
    }
    const ConfigPtr& config() const { return config_; }
    /// Serves until SIGTERM/SIGINT: the maintenance socket's clients and the
    /// web HMI's requests (the mailbox) with one command table.
    void serve(MaintenanceServer& maintenance, CommandMailbox& mailbox, const MaintenanceServer::Handler& commands);
    /// Told of every reloaded configuration.
    void setHmi(HmiServer* hmi) { hmi_ = hmi; }
    /// As SIGHUP: the configuration read and checked again on the reload's worker. From any thread (the
    /// mastering run asks from its own): it reads nothing a reload replaces.
    void requestReload()
    {
        hg::log::category("daemon")->info("reload of {} requested", configFile_.string());
        notifier_.reloading();
        reload_.request(configFile_);
    }

  private:
    bool healthy();
    /// Takes the pending signals; false on SIGTERM/SIGINT.
    bool takeSignals();
    /// Applies a finished reload (read and checked on the reload's worker).
    void applyReload();

    ConfigPtr config_;
    const std::filesystem::path configFile_; ///< the file every reload reads
    ProgramCheck checkProgram_;
    PlcRegisters& registers_;
    PlcServer& plc_;
    CycleRunner& runner_;
    Notifier& notifier_;
    int sigFd_;
    Clock& clock_; ///< the PLC server's and the runner's: the watchdog compares their times with it
    store::AuditLog& audit_;
    HmiServer* hmi_ = nullptr;
    bool wasHealthy_ = true;
    ConfigReload reload_{[this](const std::filesystem::path& file) { return loadConfig(file, checkProgram_); }};
};

void MainLoop::serve(MaintenanceServer& maintenance, CommandMailbox& mailbox,
                     const MaintenanceServer::Handler& commands)
{
    const auto heartbeat = config_->plc.heartbeatPeriod;
    auto watchdogPeriod = std::chrono::milliseconds(1000);
    if (auto wd = notifier_.watchdogInterval())
        watchdogPeriod = std::chrono::duration_cast<std::chrono::milliseconds>(*wd / 2);
    auto nextBeat = clock_.now();
    auto nextPing = clock_.now();
    for (;;) {
        auto now = clock_.now();
        if (now >= nextBeat) {
            registers_.beat();
            nextBeat = now + heartbeat;
        }
        const bool ok = healthy();
        if (ok && now >= nextPing && notifier_.watchdogInterval()) {
            notifier_.watchdog();
            nextPing = now + watchdogPeriod;
        }
        const auto state = std::string(enumName(runner_.state()));
        notifier_.status(ok ? state : "unhealthy: " + state);

        auto wake = std::min(nextBeat, notifier_.watchdogInterval() ? nextPing : nextBeat);
        auto timeoutMs = std::chrono::duration_cast<std::chrono::milliseconds>(wake - clock_.now()).count();
        // Waiting maintenance clients are polled too, and closed past their time even when silent.
        auto clients = maintenance.pollFds();
        std::vector<pollfd> fds{{sigFd_, POLLIN, 0}, {mailbox.fd(), POLLIN, 0}, {reload_.fd(), POLLIN, 0}};
        fds.insert(fds.end(), clients.begin(), clients.end());
        int n = poll(fds.data(), fds.size(), static_cast<int>(std::clamp<long long>(timeoutMs, 1, 200)));
        std::copy(fds.begin() + 3, fds.end(), clients.begin());
        maintenance.serve(clients);
        if (n > 0 && (fds[1].revents & POLLIN)) mailbox.serve(commands);
        if (n > 0 && (fds[2].revents & POLLIN)) applyReload();
        if (n > 0 && (fds[0].revents & POLLIN) && !takeSignals()) return;
    }
}

// Healthy: the PLC server loop turns (it wakes every 0.5 s) and no cycle is stuck.
bool MainLoop::healthy()
{
    const bool healthy =
        clock_.nowNs() - plc_.lastLoopNs() < std::chrono::nanoseconds(std::chrono::seconds(3)).count() &&
        runner_.healthy();
    if (healthy != wasHealthy_) {
        if (healthy)
            hg::log::category("daemon")->info("healthy again; watchdog pings resume");
        else
            hg::log::category("daemon")->error(
                "unhealthy (PLC server loop stalled or cycle longer than watchdog.max_cycle_s); watchdog pings stop");
        wasHealthy_ = healthy;
    }
    return healthy;
}

bool MainLoop::takeSignals()
{
    signalfd_siginfo info{};
    bool running = true;
    while (read(sigFd_, &info, sizeof info) == sizeof info) {
        if (info.ssi_signo == SIGHUP) {
            requestReload();
        } else if (info.ssi_signo == SIGTERM || info.ssi_signo == SIGINT) {
            hg::log::category("daemon")->info("stopping on signal {}", info.ssi_signo);
            running = false;
        }
    }
    return running;
}

// SIGHUP: a configuration that does not validate is refused; the running one stays.
void MainLoop::applyReload()
{
    auto log = hg::log::category("daemon");
    auto finished = reload_.take();
    if (!finished) return;
    if (!finished->ok()) {
        log->error("reload refused, keeping the running configuration: {}", finished->status().message());
    } else {
        auto fresh = finished->value();
        for (const auto& key : needsRestart(*config_, *fresh))
            log->warn("reload: '{}' changed; it takes effect when the daemon restarts", key);
        // The runner first: the program list's recheck of the active program (docs/plc.md,
        // recipe changeover) is prepared from the new configuration.
        runner_.setConfig(fresh);
        registers_.setKnownPrograms(programNumbers(*fresh));
        if (hmi_) hmi_->setConfig(fresh);
        config_ = fresh;
        log->info("configuration reloaded from {} ({} part programs)", config_->file.string(),
                  config_->programs.size());
        recordConfigurationFiles(audit_, *config_, "reload", clock_.wallMs());
    }
    // READY once the last reload asked for is applied (a SIGHUP during one asked for another).
    if (!reload_.busy()) notifier_.ready(std::string(enumName(runner_.state())));
}

/// Opens the store, starts the PLC server, the runner and the maintenance socket, and serves until stopped.
void runStation(ConfigPtr config, const DevicesFactory& makeDevices, const InspectorFactory& makeInspector,
                const ProgramCheck& checkProgram, Notifier& notifier, int sigFd)
{
    // One clock for every part (docs/daemon.md, "Threads and the clock").
    Clock& clock = Clock::steady();
    store::ResultStore store(config->results.database);
    // The audit trail (docs/audit.md): the files the daemon starts with, then every change it is told of.
    const auto audit = std::make_shared<store::AuditLog>(station::auditFile(*config));
    recordConfigurationFiles(*audit, *config, "start", clock.wallMs());
    PlcRegisters registers;
    registers.setKnownPrograms(programNumbers(*config));
    StationHardware hardware = makeDevices(*config, clock);
    auto inspector = makeInspector(*config);
    PlcServer plc(registers, config->plc, clock);
    plc.start();
    CycleRunner runner(registers, *hardware.devices, *inspector, store, config, clock);
    runner.setSimulation(hardware.simulation);
    MainLoop loop(config, checkProgram, registers, plc, runner, notifier, sigFd, clock, *audit);
    CommandMailbox mailbox;
    std::unique_ptr<HmiServer> hmi;
    if (config->http.enabled)
        hmi = std::make_unique<HmiServer>(
            config, mailbox, clock, [&runner] { return runner.snapshot().png(); }, station::UtcOffset{}, audit);
    loop.setHmi(hmi.get());
    // The plant link reads the outbox on its own thread and connection (docs/mqtt.md).
    // Shared with the runner's health sink: the publisher outlives the runner's thread, whatever ends first.
    std::shared_ptr<MqttPublisher> mqtt;
    if (config->mqtt.enabled)
        mqtt = std::make_shared<MqttPublisher>(
            config->mqtt, config->results.database,
            [&runner] {
                // The plant sees the PLC's view (docs/mqtt.md): a cycle's steps are one state, busy.
                const auto state = runner.state();
                return station::isBusy(state) ? std::string("busy") : std::string(enumName(state));
            },
            clock);
    MaintenanceContext context{
        registers, plc, runner, store, *hardware.devices, hardware.simulation, loop.config(), hmi ? hmi->port() : 0};
    if (mqtt) {
        context.mqttStatus = [&mqtt] { return mqtt->status(); };
        // Each cycle's health on the topic `health` (docs/mqtt.md).
        runner.setHealthSink([mqtt](const nlohmann::json& health) { mqtt->publishHealth(health); });
    }
    context.requestReload = [&loop] { loop.requestReload(); };
    context.audit = [&audit, &clock](store::AuditEntry entry) {
        entry.atMs = clock.wallMs();
        try {
            audit->record(std::move(entry));
        } catch (const std::exception& e) {
            hg::log::category("daemon")->error("audit trail: {}", e.what());
        }
    };
    // The mastering run (docs/mastering.md, "The mastering run"): a client of the station on its own thread.
    MasteringRun mastering(
        {.purpose = [&registers] { return registers.purpose(); },
         .setPurpose = [&registers](station::CyclePurpose p) { registers.setPurpose(p); },
         .trigger = [&registers](std::uint16_t program,
                                 const std::string& serial) { return registers.triggerManually(program, serial); },
         .config = [&runner] { return runner.config(); },
         .material = [&runner](std::uint16_t program) -> std::optional<std::string> {
             const auto loaded = runner.program();
             if (!loaded.is_object() || loaded.value("number", -1) != program) return std::nullopt;
             return loaded.value("material", std::string());
         },
         .reload = [&loop] { loop.requestReload(); },
         .audit = context.audit},
        clock);
    context.mastering = &mastering;
    const auto commands = maintenanceCommands(context);
    MaintenanceServer maintenance(config->maintenance.socket, config->maintenance.group, commands, clock);
    notifier.status("starting devices");
    runner.start([&] { notifier.ready("ready; PLC on port " + std::to_string(plc.port())); });
    loop.serve(maintenance, mailbox, commands);
    notifier.stopping("stopping: finishing or aborting the cycle");
    // The HMI's requests waiting for the loop are answered as refused; then it stops.
    mailbox.close();
    if (hmi) hmi->stop();
    mastering.cancel("the daemon stopping");
    runner.stop();
    // After the runner: a cycle recorded while stopping may still go out; the state goes offline last.
    if (mqtt) mqtt->stop();
    plc.stop();
    hg::log::category("daemon")->info("stopped");
}

} // namespace

int runDaemon(int argc, char** argv, const DevicesFactory& makeDevices, const InspectorFactory& makeInspector,
              const ProgramCheck& checkProgram)
{
    Options options;
    if (auto exit = parseArguments(argc, argv, options)) return *exit;
    // Under systemd (INVOCATION_ID is set for every unit) stderr is the journal;
    // in the foreground it is the terminal's, whatever the environment says.
    if (std::getenv("INVOCATION_ID") && !options.foreground) hg::log::useJournal();
    auto log = hg::log::category("daemon");
    ConfigPtr config;
    try {
        if (!options.logSpec.empty()) hg::log::configure(options.logSpec);
        // The folders come from the configuration read as started; everything
        // else, the part programs first, is read as the user the daemon runs as.
        if (options.foreground)
            log->info("{}",
                      enterForeground(station::loadDaemonConfig(options.configFile, station::WorkspaceUse::LeaveBe),
                                      options.user));
        config = loadConfig(options.configFile, checkProgram);
    } catch (const InputError& e) {
        std::cerr << "hullgauged: " << e.what() << '\n';
        return static_cast<int>(ExitStatus::BadInput);
    } catch (const FaultError& e) {
        std::cerr << "hullgauged: " << e.what() << '\n';
        return static_cast<int>(ExitStatus::Fault);
    }
    if (options.checkOnly) {
        std::cout << options.configFile << ": valid (" << config->programs.size() << " part programs)\n";
        return 0;
    }

    const int sigFd = blockSignals();
    Notifier notifier;
    int status = 0;
    try {
        runStation(config, makeDevices, makeInspector, checkProgram, notifier, sigFd);
    } catch (const FaultError& e) {
        log->critical("{}", e.what());
        notifier.stopping(std::string("failed: ") + e.what());
        status = static_cast<int>(ExitStatus::Fault);
    } catch (const InputError& e) {
        log->critical("{}", e.what());
        status = static_cast<int>(ExitStatus::BadInput);
    }
    close(sigFd);
    return status;
}

} // namespace hg::daemon
