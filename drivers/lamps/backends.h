// Constructors of the lamp backends, used by makeLamps() only.
#pragma once

#include <memory>

#include "hullgauge/drivers/lamps.h"

namespace hg::drivers {

/// libgpiod v1.6 outputs (drivers/lamps/gpiod/gpiod_lamps.cpp).
std::unique_ptr<Lamps> makeGpiodLamps(LampsConfig config);
/// The in-process twin (drivers/lamps/sim/sim_lamps.cpp).
std::unique_ptr<Lamps> makeSimulatedLamps(LampsConfig config);

} // namespace hg::drivers
