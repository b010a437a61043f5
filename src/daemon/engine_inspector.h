// The inspection pipeline of the installed daemon over the core's goal-driven
// inspection (include/hullgauge/inspect): the part program and its octree
// inspection map are loaded once per program and kept; each cycle collects the
// grabbed views with their posed cameras and inspects them at finish().
#pragma once

#include "hullgauge/station/daemon_config.h"
#include "inspector.h"

#include <memory>

namespace hg::daemon {

std::unique_ptr<Inspector> makeEngineInspector(const station::DaemonConfig& config);

} // namespace hg::daemon
