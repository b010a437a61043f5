// How the fixture moves in time (docs/fixture.md, "Motion model"): the
// velocity profile of one axis, the simulated drive's parameters
// (`fixture.driver.simulator`) and the station's motion model
// (`fixture.motion`, docs/config-reference.md) from which the planner
// predicts the cycle time (docs/planning.md, "Cycle time").
//
// Each axis follows a trapezoidal velocity profile: constant acceleration a to
// the speed limit v, cruise, constant deceleration; a move of distance d takes
// d/v + v/a when it reaches the cruise speed (d ≥ v²/a), else 2·sqrt(d/a)
// (triangular profile). The axes of one move start together, each settles for
// its settle time after its profile ends, and the move ends when the last has
// settled. The simulated drive (drivers/fixture/simulated_drive.h) moves with
// exactly these functions, so the planner's prediction and the simulated line
// agree. Units: seconds, degrees (rotation, declination) and millimetres (rail).
#pragma once

#include "hullgauge/common/config_node.h"
#include "hullgauge/geometry/fixture.h"

#include <string>
#include <vector>

namespace hg::geometry {

/// The axis names of a fixture type, in register-map order: rotation,
/// declination; or rail.
std::vector<std::string> axisNames(FixtureType type);

/// A pose as axis values in axisNames() order, and back.
std::vector<double> axisValues(const FixturePose& pose, FixtureType type);
FixturePose poseFromAxes(const std::vector<double>& values, FixtureType type);

/// Duration of a move over `distance` (≥ 0) with speed limit `speed` and
/// acceleration `acceleration`: d/v + v/a when the cruise speed is reached
/// (d ≥ v²/a), else 2·sqrt(d/a).
double trapezoidDuration(double distance, double speed, double acceleration);
/// Distance covered `t` seconds into that move.
double trapezoidDistance(double distance, double speed, double acceleration, double t);

/// Motion parameters of one simulated axis (`driver.simulator.axes.<axis>`).
struct SimulatedAxisParams {
    std::string name;            ///< rotation | declination | rail
    double maxSpeed = 90.0;      ///< units/s, used when no speed is commanded
    double acceleration = 360.0; ///< units/s²
    double settleS = 0.05;       ///< s after the profile ends until in position
    double homePosition = 0.0;   ///< where homing ends
    double startPosition = 0.0;  ///< position at power-up (before homing)
};

/// The simulator's defaults for one axis (docs/fixture.md): 90 deg/s,
/// 360 deg/s² (rotation); 45, 180 (declination); 100 mm/s, 500 mm/s² (rail);
/// settle 0.05 s.
SimulatedAxisParams defaultSimulatedAxis(const std::string& name);

/// Reads `driver.simulator` of a `fixture.driver` section (optional; the
/// defaults of docs/fixture.md for every axis of `type`).
std::vector<SimulatedAxisParams> parseSimulatorSection(const ConfigNode& driver, FixtureType type);

/// One axis as the cycle-time model sees it.
struct AxisMotion {
    std::string name;          ///< rotation | declination | rail
    double speed = 90.0;       ///< speed limit, units/s
    double acceleration = 360; ///< units/s²
    double settleS = 0.05;     ///< the drive's settle after the profile, before in position
};

/// The station's motion model (`fixture.motion`, or what the fixture driver's
/// sections say when it is absent: docs/fixture.md, "Motion model").
struct FixtureMotion {
    FixtureType type = FixtureType::RotationDeclination;
    /// In axisNames(type) order.
    std::vector<AxisMotion> axes;
    /// Wait after the fixture is in position, before the grab (the daemon's
    /// `sequencer.settle_s`), s.
    double settleS = 0.05;
    /// One grab, trigger to frame (exposure and transfer), s (`camera.grab_s`).
    double grabS = 0.0;
    /// Where the axes' figures come from: `fixture.motion`,
    /// `fixture.driver.simulator` (with the drive's `speed_value`), or `defaults`.
    std::string source = "defaults";

    /// Per axis (axes order) the time of its profile plus its settle from `from` to `to`.
    std::vector<double> axisSeconds(const FixturePose& from, const FixturePose& to) const;
    /// The move from `from` to `to`: the slowest axis' profile plus settle.
    double moveSeconds(const FixturePose& from, const FixturePose& to) const;
};

/// The simulated drive's defaults for every axis of `type` (docs/fixture.md).
FixtureMotion defaultFixtureMotion(FixtureType type);

/// The station's motion model from its `fixture` section (`motion`, else the
/// `driver` section's simulator and speed registers) and `camera` section
/// (`grab_s`, else `driver.exposure_us`). Bad values throw hg::InputError
/// naming file, line and key.
FixtureMotion parseFixtureMotion(const ConfigNode& fixture, const ConfigNode& camera, FixtureType type);

struct Station;
/// The motion model of a loaded station (parseFixtureMotion on its file; the
/// file was checked when it was loaded), or for a station built in code
/// without a document the defaults of its fixture type.
FixtureMotion stationMotion(const Station& station);

} // namespace hg::geometry
