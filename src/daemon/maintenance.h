// The maintenance socket: a unix stream socket (mode 0660, group from
// `maintenance.group`) that `hullgauge ctl` talks to. One request per
// connection: a JSON object on one line; the answer is a JSON object on one
// line with "ok": true/false (and "error" when false). Served from the
// daemon's main loop; a client gets at most one second to send its request.
#pragma once

#include "daemon_config.h"

#include <filesystem>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

namespace hg::daemon {

class CycleRunner;
class PlcRegisters;
class PlcServer;
class ResultStore;
class StationDevices;
class SimulationControl;

class MaintenanceServer {
  public:
    using Handler = std::function<nlohmann::json(const nlohmann::json& request)>;

    /// Creates the socket (removing a stale one); throws hg::FaultError naming the path.
    MaintenanceServer(std::filesystem::path path, const std::string& group, Handler handler);
    ~MaintenanceServer();
    MaintenanceServer(const MaintenanceServer&) = delete;
    MaintenanceServer& operator=(const MaintenanceServer&) = delete;

    /// The listening descriptor, for the main loop's poll().
    int fd() const { return fd_; }
    /// Accepts and answers one pending client (call when fd() is readable).
    void serveOne();

  private:
    std::filesystem::path path_;
    Handler handler_;
    int fd_ = -1;
};

/// What the maintenance commands act on; all of it lives as long as the server.
struct MaintenanceContext {
    PlcRegisters& registers;
    const PlcServer& plc;
    CycleRunner& runner;
    ResultStore& store;
    StationDevices& devices;
    /// The simulated line's part switch; null on real hardware.
    SimulationControl* simulation;
    /// The running configuration (replaced by a reload).
    const std::shared_ptr<const station::DaemonConfig>& config;
};

/// The command table of docs/daemon.md ("Maintenance socket"): status,
/// results, trigger, abort, calibrate, calibration, sim-part; any other
/// command is answered as unknown.
MaintenanceServer::Handler maintenanceCommands(MaintenanceContext context);

} // namespace hg::daemon
