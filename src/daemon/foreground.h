// The daemon without systemd (docs/daemon.md, "Without systemd"): what the
// unit gives hullgauged.service before it starts — its runtime and state
// folders, its user and groups, its one capability, its umask — done by the
// daemon itself when started with `--foreground`.
#pragma once

#include "daemon_config.h"

#include <filesystem>
#include <string>
#include <vector>

namespace hg::daemon {

/// A folder the daemon writes, with the configuration key it comes from.
struct ServiceFolder {
    std::filesystem::path path;
    std::string key;  ///< "maintenance.socket", "results.database"
    std::string unit; ///< the unit's setting that makes it under systemd
};

/// The folders the unit's RuntimeDirectory= and StateDirectory= make: the
/// maintenance socket's folder and the result database's folder.
std::vector<ServiceFolder> serviceFolders(const station::DaemonConfig& config);

/// Prepares the process as the unit runs it. Sets the umask 0027. Started as
/// root: creates each missing folder (mode 0750, owned by `user` and its
/// group), then becomes `user` with its group and the groups it is a member
/// of, keeping CAP_NET_BIND_SERVICE only where the unit grants it (a PLC port
/// below 1024 at build time) and no other capability, with no new privileges.
/// Started as another user: creates missing folders as that user. Either way
/// every folder must then be writable: InputError naming the folder's key,
/// the folder, its owner and mode otherwise (and for a `user` that does not
/// exist); FaultError when the operating system refuses a step.
/// Returns a line for the journal saying what it did.
std::string enterForeground(const station::DaemonConfig& config, const std::string& user);

} // namespace hg::daemon
