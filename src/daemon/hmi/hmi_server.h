// The web HMI (docs/hmi.md): the line view, the results and their images, the
// SPC charts and the maintenance page, served with their JSON API by an
// embedded HTTP server (cpp-httplib) on its own threads, off the inspection
// path. It reads the result store through its own read-only connections and
// asks the daemon's main loop for everything else through the command mailbox
// (the maintenance socket's command table), so no web thread touches the
// sequencer, the PLC registers or the devices.
//
// Security (docs/hmi.md, "Security"): read-only pages for whoever reaches the
// configured address (default 127.0.0.1); state-changing requests only in a
// signed-in session whose role allows them (docs/audit.md), with its CSRF
// token in a header, a JSON body and a same-origin Origin; no CORS; request
// size and a rate limit per address; every bad request is a 4xx.
#pragma once

#include "command_mailbox.h"
#include "daemon_config.h"
#include "hmi/access.h"
#include "hmi/gate_listener.h"
#include "hmi/hmi_auth.h"
#include "hmi/static_files.h"
#include "hullgauge/common/worker.h"

#include <atomic>
#include <functional>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>

namespace httplib {
class Server;
class ThreadPool;
struct Request;
struct Response;
} // namespace httplib

namespace hg::daemon {

class GatedHttpServer; // hmi_server.cpp: cpp-httplib answering the gate's requests
class PartsRoutes;     // hmi/parts_routes.h: the workbench's pages and API

class HmiServer {
  public:
    /// The last camera snapshot's overlay (PNG), null before the first (CameraSnapshot::png).
    using SnapshotSource = std::function<std::shared_ptr<const std::vector<unsigned char>>()>;

    /// Binds the configured address (throws hg::FaultError naming it when it
    /// cannot) and starts serving. `config` is the running configuration;
    /// `snapshots` gives the maintenance page its camera frame (none: 404);
    /// `utcOffset` the station's zone for the shifts (none: the machine's, station::localUtcOffset);
    /// `audit` the daemon's audit trail (none: `results.audit` opened here).
    HmiServer(std::shared_ptr<const station::DaemonConfig> config, CommandMailbox& mailbox,
              Clock& clock = Clock::steady(), SnapshotSource snapshots = {}, station::UtcOffset utcOffset = {},
              std::shared_ptr<store::AuditLog> audit = {});
    ~HmiServer();
    HmiServer(const HmiServer&) = delete;
    HmiServer& operator=(const HmiServer&) = delete;

    /// The port it listens on (the configured one, or the one the kernel chose for port 0).
    int port() const { return port_; }
    /// A reloaded configuration: its programs, results and retention from the next request on.
    void setConfig(std::shared_ptr<const station::DaemonConfig> config);
    void stop();

  private:
    std::shared_ptr<const station::DaemonConfig> config() const;
    void routePages();
    void routeApi();
    void routeMaintenance();
    bool guard(const httplib::Request& req, httplib::Response& res);
    nlohmann::json status();
    nlohmann::json disk(const station::DaemonConfig& cfg);

    mutable std::mutex configMutex_;
    std::shared_ptr<const station::DaemonConfig> config_;
    CommandMailbox& mailbox_;
    Clock& clock_;
    SnapshotSource snapshots_;
    station::UtcOffset utcOffset_;
    RateLimiter limiter_;
    std::shared_ptr<store::AuditLog> audit_;
    std::unique_ptr<Access> access_; ///< sign-in, roles, accounts and the audit trail (docs/audit.md)
    std::unique_ptr<GatedHttpServer> server_;
    StaticFiles files_;                  ///< the pages, libraries and images, validated and compressed once
    std::unique_ptr<PartsRoutes> parts_; ///< with `workbench` configured
    int port_ = 0;
    int listenFd_ = -1;

    std::mutex cacheMutex_;
    nlohmann::json statusCache_;
    Clock::time_point statusAt_{};
    nlohmann::json diskCache_;
    Clock::time_point diskAt_{};

    std::unique_ptr<httplib::ThreadPool> pool_; ///< answers the requests the gate passed
    std::unique_ptr<GateListener> gate_;        ///< the accept loop; last, so it ends before what its handlers use
};

} // namespace hg::daemon
