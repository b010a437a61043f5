// The station's devices over the drivers of drivers/, each chosen by name from
// the station file (camera.driver, fixture.driver, the lamps section).
#pragma once

#include "daemon_config.h"
#include "devices.h"

#include <memory>

namespace hg::daemon {

/// Builds the drivers (parsing only; throws hg::InputError naming the key).
std::unique_ptr<StationDevices> makeDriverDevices(const station::DaemonConfig& config);

} // namespace hg::daemon
