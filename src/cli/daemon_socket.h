// The daemon's maintenance socket from the command line (docs/daemon.md,
// "Maintenance socket"): which socket, and one request with its answer. Used
// by `hullgauge ctl` and by `hullgauge master --run`, which runs the master
// cycles through the daemon (docs/mastering.md, "The command").
#pragma once

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

} // namespace hg::cli
