// The maintenance socket: a unix stream socket (mode 0660, group from
// `maintenance.group`) that `hullgauge ctl` talks to. One request per
// connection: a JSON object on one line; the answer is a JSON object on one
// line with "ok": true/false (and "error" when false). Served from the
// daemon's main loop; a client gets at most one second to send its request.
#pragma once

#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>

namespace hg::daemon {

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

} // namespace hg::daemon
