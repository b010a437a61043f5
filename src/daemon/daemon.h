// hullgauged's main program, with the devices and the inspection pipeline
// supplied by the caller: the installed daemon passes the drivers chosen by
// the station file; the daemon's tests pass fakes.
//
//   hullgauged --config FILE [--log SPEC] [--check]
//
// Start: load and validate the configuration (exit 2 naming file, line, key),
// open the result store, start the PLC server (STATUS = starting), start the
// devices; READY=1 once they are active. Main loop: HEARTBEAT, WATCHDOG=1
// while healthy, STATUS lines, signals (SIGHUP reload, SIGTERM/SIGINT stop),
// the maintenance socket.
#pragma once

#include "cycle/devices.h"
#include "cycle/inspector.h"
#include "daemon_config.h"
#include "hullgauge/common/clock.h"

#include <functional>
#include <memory>

namespace hg::daemon {

/// The devices, timing and waiting on the daemon's clock.
using DevicesFactory = std::function<StationHardware(const station::DaemonConfig&, Clock&)>;
using InspectorFactory = std::function<std::unique_ptr<Inspector>(const station::DaemonConfig&)>;

/// Loads a part program in full, as a trigger would, and throws InputError
/// naming its file and field when it does not load or the station cannot
/// decide its tolerances (docs/daemon.md, docs/inspection.md "Capability").
using ProgramCheck = std::function<void(const station::PartProgramRef&, const geometry::Station&)>;

/// Runs the daemon until SIGTERM/SIGINT; returns the process exit status.
/// `checkProgram` runs on every part program at start, `--check` and reload.
int runDaemon(int argc, char** argv, const DevicesFactory& makeDevices, const InspectorFactory& makeInspector,
              const ProgramCheck& checkProgram = {});

} // namespace hg::daemon
