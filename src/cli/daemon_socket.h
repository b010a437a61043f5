// The daemon's maintenance socket from the command line (docs/daemon.md,
// "Maintenance socket"): which socket, and one request with its answer. Used
// by `hullgauge ctl` and by `hullgauge master --run`, which has the daemon run
// the master (docs/mastering.md, "The mastering run").
#pragma once

#include <functional>
#include <nlohmann/json.hpp>
#include <string>

namespace hg::cli {

/// The installed daemon's socket.
inline constexpr const char* kDefaultSocket = "/run/hullgauge/hullgauged.sock";

/// `given` (--socket) when set, else $HULLGAUGE_SOCKET, else kDefaultSocket.
std::string daemonSocketPath(const std::string& given);

/// Sends `request` as one line and returns the daemon's answer, `"ok": false`
/// with its `error` included. Throws hg::FaultError when the daemon cannot be
/// reached or sends no JSON object, hg::InputError for a path too long for a socket.
nlohmann::json daemonAnswer(const std::string& path, const nlohmann::json& request);

/// daemonAnswer(), and an answer that refuses the request is hg::FaultError ("daemon: " and its error).
nlohmann::json daemonRequest(const std::string& path, const nlohmann::json& request);

/// Follows a maintenance job the daemon runs (calibrate, flat-field, master) until it ends: asks
/// `poll` every 200 ms and returns the job (`key` of the answer) once done, shown to `progress` at
/// each answer; a failed job is FaultError with the daemon's reason, one still running after `waitS`
/// FaultError naming its state.
nlohmann::json followJob(const std::string& path, const nlohmann::json& poll, const std::string& key,
                         const std::string& what, double waitS,
                         const std::function<void(const nlohmann::json&)>& progress);

} // namespace hg::cli
