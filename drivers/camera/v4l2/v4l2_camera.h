// Video4Linux2 cameras (`camera.driver.backend: v4l2`): mmap streaming.
#pragma once

#include <memory>

#include "hullgauge/drivers/camera.h"

namespace hg::drivers {

/// Parses and validates the v4l2 keys of `camera.driver` (see docs/camera.md);
/// opens nothing. Throws hg::InputError naming the key.
std::unique_ptr<Camera> makeV4l2Camera(const ConfigNode& driver, Clock& clock);

} // namespace hg::drivers
