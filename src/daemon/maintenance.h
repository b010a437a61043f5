// The maintenance socket: a unix stream socket (mode 0660, group from
// `maintenance.group`) that `hullgauge ctl` talks to. One request per
// connection: a JSON object on one line; the answer is a JSON object on one
// line with "ok": true/false (and "error" when false). Served from the
// daemon's main loop, every client on its own: each connection gathers its
// request line (at most 64 KiB) as it arrives, one that has not sent it within
// one second is closed, and when kMaxClients wait the longest-waiting one
// goes, so idle clients never keep `ctl` out (docs/daemon.md).
#pragma once

#include "daemon_config.h"
#include "hullgauge/common/clock.h"

#include <chrono>
#include <filesystem>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <poll.h>
#include <string>
#include <vector>

namespace hg::store {
class ResultStore;
struct AuditEntry;
} // namespace hg::store

namespace hg::daemon {

class CycleRunner;
class MasteringRun;
class PlcRegisters;
class PlcServer;
class StationDevices;
class SimulationControl;

class MaintenanceServer {
  public:
    using Handler = std::function<nlohmann::json(const nlohmann::json& request)>;

    /// Creates the socket (removing a stale one); throws hg::FaultError naming
    /// the path. `clock` times the clients' request timeout.
    MaintenanceServer(std::filesystem::path path, const std::string& group, Handler handler,
                      Clock& clock = Clock::steady());
    ~MaintenanceServer();
    MaintenanceServer(const MaintenanceServer&) = delete;
    MaintenanceServer& operator=(const MaintenanceServer&) = delete;

    static constexpr std::size_t kMaxClients = 32;
    static constexpr std::size_t kMaxRequestBytes = 64 * 1024;
    static constexpr std::chrono::milliseconds kRequestTimeout{1000};

    /// The listening socket and every waiting client, for the main loop's poll().
    std::vector<pollfd> pollFds() const;
    /// Accepts new clients, reads what the ready ones sent, answers every
    /// complete request and closes the clients past their time; `polled` is
    /// pollFds() as poll() returned it.
    void serve(const std::vector<pollfd>& polled);

  private:
    struct Client {
        int fd;
        Clock::time_point since;
        std::string request;
        std::string peer; ///< `unix:<user>` from the socket's peer credentials (the audit trail's who)
    };
    void acceptAll();
    /// Reads once; true when the client is done with (answered or gone).
    bool readFrom(Client& client);
    void answer(const Client& client);
    void refuseUnfinished(const Client& client);

    std::filesystem::path path_;
    Handler handler_;
    Clock& clock_;
    int fd_ = -1;
    std::vector<Client> clients_;
};

/// The answer line to a client's `request` bytes (its first line; all of it
/// when it has none, which the server sends at 64 KiB): `handler`'s answer, or
/// {"ok": false, "error": ...} for a line that is not one JSON object with a
/// "command" or a handler that throws. Pure but for the handler; the fuzzing
/// harness calls it (docs/fuzzing.md).
/// The request is handed on with `"caller": {"who": peer, "source": "socket"}` in place of any
/// caller it names (only the HMI names its signed-in person, through the mailbox); without a peer
/// the caller is removed.
std::string answerMaintenanceRequest(const std::string& request, const MaintenanceServer::Handler& handler,
                                     const std::string& peer = {});

/// What the maintenance commands act on; all of it lives as long as the server.
struct MaintenanceContext {
    PlcRegisters& registers;
    const PlcServer& plc;
    CycleRunner& runner;
    store::ResultStore& store;
    StationDevices& devices;
    /// The simulated line's part switch; null on real hardware.
    SimulationControl* simulation;
    /// The running configuration (replaced by a reload).
    const std::shared_ptr<const station::DaemonConfig>& config;
    /// The web HMI's port; 0 when it is off.
    int hmiPort = 0;
    /// The plant link's state (docs/mqtt.md); empty when it is off.
    std::function<nlohmann::json()> mqttStatus = {};
    /// Reads the configuration and its programs again, as SIGHUP does (the
    /// workbench's release, docs/workbench.md); empty: `reload` is refused.
    std::function<void()> requestReload = {};
    /// The mastering run (docs/mastering.md, "The mastering run"); null: `master` is refused.
    MasteringRun* mastering = nullptr;
    /// Records a change (cycle purpose, simulated part, calibration, flat-field reference, reload) in the audit trail
    /// (docs/audit.md) with the request's caller; empty: not recorded.
    std::function<void(store::AuditEntry)> audit = {};
};

/// The command table of docs/daemon.md ("Maintenance socket"): status,
/// results, trigger, abort, calibrate, calibration, sim-part, sim-age, purpose, snapshot, reload,
/// flat-field, master; any other command is answered as unknown.
MaintenanceServer::Handler maintenanceCommands(MaintenanceContext context);

} // namespace hg::daemon
