// The controls of the simulated twins, beside the production interfaces:
// what the simulated line, tests and maintenance switch that no real device
// has (the part under test, fault switches, the lamps' line levels). The
// backend tables build the twins like any backend and publish their controls
// in a SimulationControls the caller passes in (docs/drivers.md); production
// code never casts a driver to its twin.
#pragma once

#include <cstdint>
#include <memory>
#include <opencv2/core/matx.hpp>
#include <string>
#include <vector>

#include "hullgauge/drivers/camera.h"
#include "hullgauge/drivers/fixture.h"
#include "hullgauge/drivers/lamps.h"
#include "hullgauge/geometry/transform.h"
#include "hullgauge/model/mesh.h"

namespace hg::drivers {

/// Fault switches of the simulated camera (docs/camera.md, `camera.driver.fault`).
enum class SimulatedCameraFault {
    None,
    Timeout,      ///< the camera is silent: every grab waits out its timeout
    Incomplete,   ///< frames arrive with missing packets (status incomplete, rows missing)
    Dropped,      ///< the next frame is lost: that grab times out, the frame counter skips it (one-shot)
    RefuseRegion, ///< OffsetX/Y, Width/Height not writable: a region request falls back to whole frames
};
constexpr auto nameTable(SimulatedCameraFault)
{
    using enum SimulatedCameraFault;
    return std::to_array<EnumName<SimulatedCameraFault>>({{None, "none"},
                                                          {Timeout, "timeout"},
                                                          {Incomplete, "incomplete"},
                                                          {Dropped, "dropped"},
                                                          {RefuseRegion, "refuse_region"}});
}

/// The part name that shows the empty fixture: the bare back light, what a
/// flat-field reference is taken from (docs/camera.md, "The empty fixture").
inline constexpr const char* kEmptyFixture = "none";

/// The simulated camera's optics as they are now: as configured, aged by the
/// cycles counted (docs/camera.md, "Optics of the simulated camera", "Aging").
struct SimulatedOptics {
    std::uint64_t cycles = 0;     ///< cycles counted since the start or the last resetAging()
    std::uint64_t agingSteps = 0; ///< times the optics aged: cycles / aging.per_cycles
    double backgroundLevel = 0.0; ///< the back light at the sensor's centre, fraction of full scale
    double vignetting = 0.0;      ///< fall-off at the sensor's corners (fraction)
    double blurSigmaPx = 0.0;     ///< optics blur (Gaussian σ, px)
    double haloPx = 0.0;          ///< the silhouette's erosion by light wrapping round the edge (px)
    /// Every dust speck on the back light: x, y (sensor pixels), radius (px), depth (fraction).
    std::vector<cv::Vec4d> dust;
};

/// The simulated camera's controls.
class SimCameraControl {
  public:
    virtual ~SimCameraControl() = default;
    /// Switches the part under test (thread-safe, also while streaming);
    /// fails for a name not among the parts. kEmptyFixture shows no part.
    virtual Status setPart(const std::string& name) = 0;
    virtual std::string part() const = 0;
    /// The parts it renders, then kEmptyFixture.
    virtual std::vector<std::string> partNames() const = 0;
    /// Renders `mesh` as the part under test, named `name` (a released part of
    /// the workbench, docs/workbench.md: its own CAD model), until setPart
    /// picks a listed part again. Thread-safe; the renderer of the last mesh
    /// shown under `name` is kept, so showing it again costs nothing.
    virtual void showMesh(const std::string& name, std::shared_ptr<const model::TriangleMesh> mesh) = 0;
    /// Seats the part under test (and every part shown next): the camera
    /// renders it through camera_from_part = camera_from_fixture · fixture
    /// motion · `seat`, with `seat` = nominal_from_part (docs/alignment.md).
    /// Identity (the default) shows the part as drawn. Thread-safe.
    virtual void setSeat(const geometry::RigidTransform& seat) = 0;
    /// Switches a fault on, or off with SimulatedCameraFault::None (thread-safe).
    virtual void injectFault(SimulatedCameraFault fault) = 0;
    /// A new part was put in the nest: one more cycle for `camera.driver.aging`
    /// (the daemon's simulated line calls it at the start of every cycle). Thread-safe.
    virtual void countCycle() = 0;
    virtual SimulatedOptics optics() const = 0;
    /// The optics as configured again, the cycle count at 0, the aging's draws from its seed anew.
    virtual void resetAging() = 0;
};

/// Fault switches of the simulated drive (the in-process twin and the Modbus
/// fixture simulator share them; numbers are the simulator's FAULT_MODE values).
enum class SimulatedFault {
    None = 0,
    NoAnswer = 1,        ///< requests are not answered
    ExceptionReply = 2,  ///< requests are answered with a Modbus exception
    Disconnect = 3,      ///< the connection is dropped and refused
    NeverInPosition = 4, ///< axes stall half-way, busy stays set
    DriveFault = 5,      ///< the drive latches a fault (fault bit and code)
};

/// The in-process fixture twin's controls.
class SimFixtureControl {
  public:
    virtual ~SimFixtureControl() = default;
    /// Switches a fault on (or off with SimulatedFault::None); `code` is the
    /// drive fault code (DriveFault) or Modbus exception code (ExceptionReply).
    virtual void injectFault(SimulatedFault fault, int code = 0) = 0;
};

/// The simulated lamps' controls: what the operator would see.
class SimLampsControl {
  public:
    virtual ~SimLampsControl() = default;
    /// True when the lamp is lit right now (blink phase included).
    virtual bool lit(Lamp lamp) const = 0;
    /// The electrical level of the lamp's line (lit XOR active_low); false
    /// while the line is not requested.
    virtual bool lineLevel(Lamp lamp) const = 0;
    /// True between configure() and cleanup() (lines requested).
    virtual bool linesRequested() const = 0;
    /// Number of writes that changed some line, for blink-timing checks.
    virtual std::uint64_t transitions() const = 0;
    /// Makes line writes (and configure) fail as an unplugged GPIO expander would.
    virtual void injectWriteFailure(bool fail) = 0;
};

/// Filled by the factories of the simulated backends; null where the driver is real.
struct SimulationControls {
    SimCameraControl* camera = nullptr;
    SimFixtureControl* fixture = nullptr;
    SimLampsControl* lamps = nullptr;
};

} // namespace hg::drivers
