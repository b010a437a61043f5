// Constructors of the lamp backends, used by makeLamps() only.
#pragma once

#include <memory>

#include "hullgauge/drivers/simulation.h"

namespace hg::drivers {

/// libgpiod v1.6 outputs (drivers/lamps/gpiod/gpiod_lamps.cpp).
std::unique_ptr<Lamps> makeGpiodLamps(LampsConfig config, Clock& clock);
/// The in-process twin (drivers/lamps/sim/sim_lamps.cpp); publishes its controls in `simulation`.
std::unique_ptr<Lamps> makeSimulatedLamps(LampsConfig config, SimulationControls* simulation, Clock& clock);

} // namespace hg::drivers
