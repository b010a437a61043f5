// GigE Vision cameras through Aravis (`camera.driver.backend: aravis`).
#pragma once

#include <memory>

#include "hullgauge/drivers/camera.h"

namespace hg::drivers {

/// Parses and validates the aravis keys of `camera.driver` (see docs/camera.md);
/// opens nothing. Throws hg::InputError naming the key.
std::unique_ptr<Camera> makeAravisCamera(const ConfigNode& driver, Clock& clock);

} // namespace hg::drivers
