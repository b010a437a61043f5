// The station's devices over the drivers of drivers/, each chosen by name from
// the station file (camera.driver, fixture.driver, the lamps section).
#pragma once

#include "cycle/devices.h"
#include "daemon_config.h"
#include "hullgauge/common/clock.h"

#include <memory>

namespace hg::daemon {

/// Builds the drivers from their backend tables (parsing only; throws
/// hg::InputError naming the key), on `clock` (docs/drivers.md, "Clock");
/// with the simulated camera, its part switch.
StationHardware makeDriverDevices(const station::DaemonConfig& config, Clock& clock = Clock::steady());

} // namespace hg::daemon
