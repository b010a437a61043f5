// What the cycle runner needs from the station's hardware: the fixture, the
// camera and the operator lamps, behind one narrow port in domain types. The
// daemon's implementation (driver_devices.cpp) sits on the drivers of
// drivers/ chosen by the station file; tests use small fakes. The simulated
// line's own switch (the part under test) is a separate port beside it.
//
// Every call returns an hg::Status (common/status.h) and never throws;
// only construction (configuration parsing) throws hg::InputError.
#pragma once

#include "hullgauge/common/status.h"
#include "hullgauge/geometry/fixture.h"
#include "hullgauge/geometry/transform.h"
#include "hullgauge/station/cycle_rules.h"

#include <chrono>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/core/mat.hpp>
#include <optional>
#include <string>
#include <vector>

namespace hg::drivers {
class SimFixtureControl; // hullgauge/drivers/simulation.h
}

namespace hg::daemon {

/// Operator lamp patterns (docs/contracts.md §6), chosen by station::lampPattern.
using station::LampPattern;

/// One grabbed frame and where it lies on the sensor (docs/camera.md,
/// "Regions per grab"): image pixel (u, v) is sensor pixel (origin.x + u,
/// origin.y + v); the station's camera model stays the full-sensor one.
struct GrabbedFrame {
    cv::Mat image;          ///< owned, or a view the caller may keep
    cv::Point origin{0, 0}; ///< sensor position of image's pixel (0, 0)
    std::size_t payloadBytes = 0;
    /// ms the camera took to apply the region this frame is the first of (0: unchanged).
    double regionChangeMs = 0.0;
};

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
    /// The region of the sensor the following grabs deliver (sensor pixels;
    /// empty: whole frames). A camera that cannot (or a request it refuses)
    /// delivers whole frames — GrabbedFrame::origin and the image's size always
    /// say what a frame covers; the failure is only reported.
    virtual Status setRegion(const cv::Rect& region) = 0;
    /// Grab one frame into `frame` (owned copy or a view the caller may keep).
    virtual Status grab(std::chrono::milliseconds timeout, GrabbedFrame& frame) = 0;
    /// Bring the devices back after a fault (reset faults, re-home, restart streaming).
    virtual Status recover() = 0;
    virtual void showLamps(LampPattern pattern) = 0;
    /// What the lamps show, for the maintenance status: per lamp the commanded
    /// state ("off", "on", "blinking") and, where the driver can read its lines
    /// back (the simulated twin), whether the lamp is lit right now.
    virtual nlohmann::json lampStatus() const { return nullptr; }
};

/// A simulated part's true seat (docs/daemon.md, "Seating").
struct SimulatedSeat {
    geometry::RigidTransform seat;                  ///< nominal_from_part, as align::AlignmentResult::seat
    geometry::Vec3 centre = geometry::Vec3::Zero(); ///< the nominal mesh's bounding-box centre, the pivot
};

/// The simulated line's control (`hullgauge ctl sim-part`, docs/daemon.md):
/// which part the simulated camera shows, and how it is seated.
class SimulationControl {
  public:
    virtual ~SimulationControl() = default;
    /// The part variants ("nominal" and the defect variants).
    virtual std::vector<std::string> parts() const = 0;
    virtual std::string part() const = 0;
    /// Switches the part under test; false for an unknown name.
    virtual bool selectPart(const std::string& name) = 0;
    /// A new part is put in the nest: with `simulation.seating` it is seated
    /// at random within the play, else exactly as drawn. The cycle runner calls
    /// it at the start of every cycle.
    virtual void newPart() {}
    /// The program the next part is inspected with, before newPart(): a
    /// released part of the workbench (`simulatedNominal` set) is rendered as
    /// its own CAD model while the "nominal" part is selected
    /// (docs/workbench.md, "Released parts on the station"); null: none.
    virtual void useProgram(const std::filesystem::path& simulatedNominal) { (void)simulatedNominal; }
    /// The seat of the part in the nest; nullopt without `simulation.seating`.
    virtual std::optional<SimulatedSeat> trueSeat() const { return std::nullopt; }
    /// The simulated fixture's fault switches (docs/fixture.md); null when the
    /// fixture is a real drive or the separate Modbus simulator.
    virtual drivers::SimFixtureControl* fixtureFaults() { return nullptr; }
    /// The simulated camera's optics as they have aged (docs/camera.md,
    /// "Aging"; `hullgauge ctl sim-age`): cycles, aging_steps, background_level,
    /// vignetting, blur_sigma_px, halo_px, dust_specks; null when there are none.
    virtual nlohmann::json optics() const { return nullptr; }
    /// The optics as configured again, the cycle count at 0 (`ctl sim-age --reset`).
    virtual void resetAging() {}
};

/// What the daemon's device factory returns: the production port and, on the
/// simulated line only, its control (owned by `devices`; null on real hardware).
struct StationHardware {
    std::unique_ptr<StationDevices> devices;
    SimulationControl* simulation = nullptr;
};

} // namespace hg::daemon
