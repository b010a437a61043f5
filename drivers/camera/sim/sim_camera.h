// The simulated camera (`camera.driver.backend: sim`), built from the camera
// backend table.
#pragma once

#include <memory>

#include "hullgauge/drivers/camera.h"

namespace hg::drivers {

/// Parses `camera.driver` (backend: sim) and the station calibration of
/// `root`; renders `environment.parts` at `environment.poseSource` and
/// publishes itself in `environment.simulation`. Throws hg::InputError naming
/// the key (e.g. camera.driver.part not among the parts).
std::unique_ptr<Camera> makeSimCamera(const ConfigNode& root, CameraEnvironment& environment, Clock& clock);

} // namespace hg::drivers
