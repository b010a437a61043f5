// The fixture that carries the part through its inspection poses: a
// rotation/declination fixture (turntable that tilts) or a rail stage
// (CONTRACTS §2). One small interface in domain types (degrees, millimetres,
// seconds); no protocol handle crosses it (STYLE.md point 1).
//
// Lifecycle (lifecycle.h, after ros2_control): constructing a driver from its
// configuration only parses and validates it (bad sections throw
// hg::InputError naming the key); configure() opens communication and checks
// that the device answers; activate() writes the motion parameters (speeds);
// deactivate() stops motion; cleanup() closes communication.
//
// The cyclic calls (home, moveTo, waitInPosition, stop, resetFault, status)
// never throw: they return a small FixtureResult. A dropped connection is
// re-opened by the next call, so the driver recovers by itself once the device
// answers again; a drive fault stays latched in the drive until resetFault().
// A driver is used from one thread at a time.
#pragma once

#include "hullgauge/common/config_node.h"
#include "hullgauge/drivers/lifecycle.h"
#include "hullgauge/geometry/fixture.h"
#include "hullgauge/geometry/station.h"

#include <chrono>
#include <initializer_list>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace hg::drivers {

/// Outcome classes of every fixture call (documented in docs/fixture.md).
enum class FixtureStatusCode {
    Ok,
    Timeout,            ///< the fixture did not reach position within the timeout
    Fault,              ///< the drive reports a fault (fault bit, fault code)
    CommunicationError, ///< no answer, refused connection, exception reply, bad frame
    NotAllowed,         ///< call not allowed in this lifecycle state, pose out of range, not homed
};

std::string_view toString(FixtureStatusCode code);

/// "rotation 30 deg, declination 20 deg" or "rail 120 mm", for messages.
std::string describePose(const geometry::FixturePose& pose, geometry::FixtureType type);

/// The result of a fixture call: a code and a message for people.
struct [[nodiscard]] FixtureResult {
    FixtureStatusCode code = FixtureStatusCode::Ok;
    std::string message;

    bool ok() const { return code == FixtureStatusCode::Ok; }
    static FixtureResult success() { return {}; }
};

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

class Fixture {
  public:
    virtual ~Fixture() = default;
    Fixture(const Fixture&) = delete;
    Fixture& operator=(const Fixture&) = delete;

    // Lifecycle transitions (lifecycle.h). A transition not allowed in the
    // current state returns NotAllowed and changes nothing. A failed
    // configure/activate leaves the state as it was; a failed deactivate
    // (motion could not be stopped) enters Failed, from which cleanup() and
    // configure() recover.
    FixtureResult configure();
    FixtureResult activate();
    FixtureResult deactivate();
    FixtureResult cleanup();
    LifecycleState state() const { return state_; }

    /// Starts homing (Active only); waitInPosition() waits for its end.
    FixtureResult home();
    /// Starts a move to `pose` (Active only). A pose outside the fixture's
    /// ranges, or any move before homing when `require_homed` is set, is
    /// NotAllowed; a latched drive fault is Fault. Returns once the drive has
    /// accepted the move.
    FixtureResult moveTo(const geometry::FixturePose& pose);
    /// Waits until the drive reports in position at the commanded target (after
    /// home(): homed) and not busy (Ok), a fault (Fault), not in position
    /// within `timeout` (Timeout), or a communication failure
    /// (CommunicationError). Polls every `poll_interval_s`.
    FixtureResult waitInPosition(std::chrono::milliseconds timeout);
    /// Stops motion (Active only).
    FixtureResult stop();
    /// Acknowledges a latched drive fault (Inactive or Active).
    FixtureResult resetFault();
    /// Reads the drive's status (Inactive or Active).
    FixtureResult status(FixtureStatus& out);

    geometry::FixtureType type() const { return kinematics_.type; }
    /// The configured default timeouts (`move_timeout_s`, `home_timeout_s`).
    std::chrono::milliseconds moveTimeout() const { return moveTimeout_; }
    std::chrono::milliseconds homeTimeout() const { return homeTimeout_; }
    /// The backend name from the configuration (`modbus`, `sim`).
    virtual std::string_view backend() const = 0;

  protected:
    /// `driver` is the `fixture.driver` section; its common keys are read here.
    Fixture(const ConfigNode& driver, const geometry::FixtureKinematics& kinematics);

    virtual FixtureResult onConfigure() = 0;
    virtual FixtureResult onActivate() = 0;
    virtual FixtureResult onDeactivate() = 0;
    virtual FixtureResult onCleanup() = 0;
    virtual FixtureResult doHome() = 0;
    virtual FixtureResult doMoveTo(const geometry::FixturePose& pose) = 0;
    virtual FixtureResult doStop() = 0;
    virtual FixtureResult doResetFault() = 0;
    virtual FixtureResult doStatus(FixtureStatus& out) = 0;
    /// True when `actual` is within the axis tolerances of `target`.
    virtual bool atTarget(const geometry::FixturePose& actual, const geometry::FixturePose& target) const = 0;

    const geometry::FixtureKinematics& kinematics() const { return kinematics_; }
    /// The key path of the driver section, for messages ("fixture.driver").
    const std::string& configPath() const { return configPath_; }
    /// Text for a drive fault code (`fault_texts`, else "drive fault code N").
    std::string faultText(int code) const;

  private:
    FixtureResult transition(Transition t, FixtureResult (Fixture::*hook)());
    FixtureResult requireState(std::initializer_list<LifecycleState> allowedStates, std::string_view call) const;

    geometry::FixtureKinematics kinematics_;
    LifecycleState state_ = LifecycleState::Unconfigured;
    std::string configPath_;
    std::chrono::milliseconds moveTimeout_{30000};
    std::chrono::milliseconds homeTimeout_{60000};
    std::chrono::milliseconds pollInterval_{10};
    bool requireHomed_ = true;
    enum class Pending { None, Move, Home } pending_ = Pending::None;
    geometry::FixturePose target_;
    std::vector<std::pair<int, std::string>> faultTexts_;
};

/// Builds the driver named by `driver.backend` (`modbus` or `sim`) from the
/// station's `fixture.driver` section. Parses and validates only (lifecycle
/// `init`): unknown backends, bad register maps and bad settings throw
/// hg::InputError naming file, line and key.
std::unique_ptr<Fixture> makeFixture(const ConfigNode& driver, const geometry::FixtureKinematics& kinematics);
/// As above, from a loaded station: its `fixture.driver` section (required)
/// and its fixture kinematics.
std::unique_ptr<Fixture> makeFixture(const geometry::Station& station);

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

/// The in-process simulated twin (`backend: sim`): the fixture simulator's
/// motion model and fault switches without Modbus, for tests of the code
/// above the driver. Obtain it with `dynamic_cast<SimulatedFixture*>`.
class SimulatedFixture : public Fixture {
  public:
    /// Switches a fault on (or off with SimulatedFault::None); `code` is the
    /// drive fault code (DriveFault) or Modbus exception code (ExceptionReply).
    virtual void injectFault(SimulatedFault fault, int code = 0) = 0;

  protected:
    using Fixture::Fixture;
};

} // namespace hg::drivers
