// Constructors of the lamp backends, used by makeLamps() only.
#pragma once

#include <memory>

#include "hullgauge/drivers/simulation.h"

namespace hg::drivers {

/// libgpiod v1.6 outputs (drivers/lamps/gpiod/gpiod_lamps.cpp).
std::unique_ptr<Lamps> makeGpiodLamps(LampsConfig config, LampClock clock);
/// The in-process twin (drivers/lamps/sim/sim_lamps.cpp); publishes its controls in `simulation`.
std::unique_ptr<Lamps> makeSimulatedLamps(LampsConfig config, SimulationControls* simulation, LampClock clock);

} // namespace hg::drivers
