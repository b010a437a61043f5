// What the cycle runner needs from the station's hardware: the fixture, the
// camera and the operator lamps, behind one narrow port in domain types. The
// daemon's implementation (driver_devices.cpp) sits on the drivers of
// drivers/ chosen by the station file; tests use small fakes.
//
// Every call returns an hg::Status (common/status.h) and never throws;
// only construction (configuration parsing) throws hg::InputError.
#pragma once

#include "hullgauge/common/status.h"
#include "hullgauge/geometry/fixture.h"
#include "hullgauge/station/cycle_rules.h"

#include <chrono>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

namespace hg::daemon {

/// Operator lamp patterns (CONTRACTS §6), chosen by station::lampPattern.
using station::LampPattern;

class StationDevices {
  public:
    virtual ~StationDevices() = default;

    /// Configure and activate every driver (and home the fixture). READY=1 is
    /// sent to systemd only after this succeeded.
    virtual Status start() = 0;
    /// Deactivate and clean up every driver (stop motion first).
    virtual void shutdown() = 0;
    /// Move to `pose` and wait until in position or `timeout`. `retry`: a
    /// second attempt — reset a latched drive fault and re-home if needed first.
    virtual Status moveTo(const geometry::FixturePose& pose, std::chrono::milliseconds timeout, bool retry) = 0;
    virtual void stopMotion() = 0;
    /// Grab one frame into `image` (owned copy or a view the caller may keep).
    virtual Status grab(std::chrono::milliseconds timeout, cv::Mat& image) = 0;
    /// Bring the devices back after a fault (reset faults, re-home, restart streaming).
    virtual Status recover() = 0;
    virtual void showLamps(LampPattern pattern) = 0;
    /// What the lamps show, for the maintenance status: per lamp the commanded
    /// state ("off", "on", "blinking") and, where the driver can read its lines
    /// back (the simulated twin), whether the lamp is lit right now.
    virtual nlohmann::json lampStatus() const { return nullptr; }

    /// The simulated camera's part variants (empty on real hardware).
    virtual std::vector<std::string> simulatedParts() const { return {}; }
    virtual std::string simulatedPart() const { return {}; }
    /// Switches the simulated part under test; false when unknown or not simulated.
    virtual bool selectSimulatedPart(const std::string& name)
    {
        (void)name;
        return false;
    }
};

} // namespace hg::daemon
