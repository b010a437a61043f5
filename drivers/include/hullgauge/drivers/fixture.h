// The fixture that carries the part through its inspection poses: a
// rotation/declination fixture (turntable that tilts) or a rail stage
// (docs/contracts.md §2). One small interface in domain types (degrees, millimetres,
// seconds); no protocol handle crosses it (docs/style.md point 1).
//
// Lifecycle (lifecycle.h, docs/drivers.md): constructing a driver from its
// configuration only parses and validates it (bad sections throw
// hg::InputError naming the key); configure() opens communication and checks
// that the device answers; activate() writes the motion parameters (speeds);
// deactivate() stops motion (a drive that cannot be stopped is an error:
// Failed); cleanup() closes communication.
//
// The cyclic calls (home, moveTo, waitInPosition, stop, resetFault, status)
// never throw: they return an hg::Status whose code docs/fixture.md lists. A dropped connection is
// re-opened by the next call, so the driver recovers by itself once the device
// answers again; a drive fault stays latched in the drive until resetFault().
// A driver is used from one thread at a time.
#pragma once

#include "hullgauge/common/config_node.h"
#include "hullgauge/drivers/lifecycle.h"
#include "hullgauge/geometry/fixture.h"
#include "hullgauge/geometry/station.h"

#include <chrono>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace hg::drivers {

/// A snapshot of the fixture as the drive reports it.
struct FixtureStatus {
    geometry::FixturePose position; ///< actual position (degrees / millimetres)
    bool inPosition = false;        ///< at the commanded target and settled
    bool busy = false;              ///< moving, homing or settling
    bool homed = false;
    bool fault = false;
    int faultCode = 0;     ///< the drive's fault code (0 = none)
    std::string faultText; ///< from `fault_texts` in the configuration, or generic
};

class Fixture : public Device {
  public:
    /// Starts homing (Active only); waitInPosition() waits for its end.
    Status home();
    /// Starts a move to `pose` (Active only). A pose outside the fixture's
    /// ranges, or any move before homing when `require_homed` is set, is
    /// NotAllowed; a latched drive fault is Fault. Returns once the drive has
    /// accepted the move.
    Status moveTo(const geometry::FixturePose& pose);
    /// Waits until the drive reports in position at the commanded target (after
    /// home(): homed) and not busy (Ok), a fault (Fault), not in position
    /// within `timeout` (Timeout), or a communication failure
    /// (CommunicationError). Polls every `poll_interval_s`.
    Status waitInPosition(std::chrono::milliseconds timeout);
    /// Stops motion (Active only).
    Status stop();
    /// Acknowledges a latched drive fault (Inactive or Active).
    Status resetFault();
    /// Reads the drive's status (Inactive or Active).
    Status status(FixtureStatus& out);

    geometry::FixtureType type() const { return kinematics_.type; }
    /// The configured default timeouts (`move_timeout_s`, `home_timeout_s`).
    std::chrono::milliseconds moveTimeout() const { return moveTimeout_; }
    std::chrono::milliseconds homeTimeout() const { return homeTimeout_; }
    /// The backend name from the configuration (`modbus`, `sim`).
    virtual std::string_view backend() const = 0;

  protected:
    /// `driver` is the `fixture.driver` section; its common keys are read here.
    Fixture(const ConfigNode& driver, const geometry::FixtureKinematics& kinematics, Clock& clock);

    virtual Status doHome() = 0;
    virtual Status doMoveTo(const geometry::FixturePose& pose) = 0;
    virtual Status doStop() = 0;
    virtual Status doResetFault() = 0;
    virtual Status doStatus(FixtureStatus& out) = 0;
    /// True when `actual` is within the axis tolerances of `target`.
    virtual bool atTarget(const geometry::FixturePose& actual, const geometry::FixturePose& target) const = 0;

    const geometry::FixtureKinematics& kinematics() const { return kinematics_; }
    /// The key path of the driver section, for messages ("fixture.driver").
    const std::string& configPath() const { return configPath_; }
    /// Text for a drive fault code (`fault_texts`, else "drive fault code N").
    std::string faultText(int code) const;

  private:
    geometry::FixtureKinematics kinematics_;
    std::string configPath_;
    std::chrono::milliseconds moveTimeout_{30000};
    std::chrono::milliseconds homeTimeout_{60000};
    std::chrono::milliseconds pollInterval_{10};
    bool requireHomed_ = true;
    enum class Pending { None, Move, Home } pending_ = Pending::None;
    geometry::FixturePose target_;
    std::vector<std::pair<int, std::string>> faultTexts_;
};

struct SimulationControls;

/// Builds the driver named by `driver.backend` from the backend table
/// (`modbus` or `sim`) from the station's `fixture.driver` section. Parses and
/// validates only (lifecycle `init`): unknown backends, bad register maps and
/// bad settings throw hg::InputError naming file, line and key. The simulated
/// twin publishes its controls in `simulation` (simulation.h) when given.
/// `clock` is the one the driver times and waits on (docs/drivers.md).
std::unique_ptr<Fixture> makeFixture(const ConfigNode& driver, const geometry::FixtureKinematics& kinematics,
                                     SimulationControls* simulation = nullptr, Clock& clock = Clock::steady());
/// As above, from a loaded station: its `fixture.driver` section (required)
/// and its fixture kinematics.
std::unique_ptr<Fixture> makeFixture(const geometry::Station& station, SimulationControls* simulation = nullptr,
                                     Clock& clock = Clock::steady());

} // namespace hg::drivers
