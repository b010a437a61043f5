// The operator lamps: a green, an amber and a red lamp on GPIO lines
// (CONTRACTS §6: green = pass, red = fail, amber = busy, fault = red and amber
// blinking). One small interface in domain types; no GPIO handle crosses it
// (STYLE.md point 1).
//
// Lifecycle (lifecycle.h): constructing a driver from the station's `lamps`
// section only parses and validates it (bad sections throw hg::InputError
// naming file, line and key); configure() opens the GPIO chip and requests the
// three lines as outputs, all lamps off; activate() lets the lamps light;
// deactivate() switches every lamp off; cleanup() releases the lines.
//
// Blinking is driven by a timer thread owned by the driver: every blinking
// lamp is lit for the first half of `blink_period_s` and dark for the second,
// all in the same phase (red and amber blink together). The thread runs only
// while the driver is Active and some lamp blinks.
//
// The cyclic calls (set, show) never throw; they return a small LampResult.
// A driver may be used from several threads.
#pragma once

#include <array>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <thread>

#include "hullgauge/common/config_node.h"
#include "hullgauge/drivers/lifecycle.h"

namespace hg::drivers {

enum class Lamp { Green = 0, Amber = 1, Red = 2 };
inline constexpr std::array<Lamp, 3> kAllLamps{Lamp::Green, Lamp::Amber, Lamp::Red};

enum class LampState { Off, On, Blinking };

/// What the station shows the operator (CONTRACTS §6).
enum class StationIndication {
    Dark,  ///< every lamp off
    Pass,  ///< green
    Fail,  ///< red
    Busy,  ///< amber
    Fault, ///< red and amber blinking
};

std::string_view toString(Lamp lamp);
std::string_view toString(LampState state);
std::string_view toString(StationIndication indication);

enum class LampStatusCode {
    Ok,
    IoError,    ///< the chip or a line could not be opened, requested or written
    NotAllowed, ///< call not allowed in this lifecycle state
};

std::string_view toString(LampStatusCode code);

struct [[nodiscard]] LampResult {
    LampStatusCode code = LampStatusCode::Ok;
    std::string message;

    bool ok() const { return code == LampStatusCode::Ok; }
    static LampResult success() { return {}; }
};

/// Where one lamp is wired: a GPIO line by name or by offset on the chip.
struct LampLine {
    std::optional<std::string> name;
    std::optional<unsigned> offset;
    bool activeLow = false;
    /// Key path of the lamp in the configuration ("lamps.green"), for messages.
    std::string key;
    /// "line 'LAMP_GREEN'" or "offset 17", for messages.
    std::string describe() const;
};

/// The parsed `lamps` section (docs/lamps.md lists every key).
struct LampsConfig {
    std::string backend; ///< "gpiod" or "sim"
    /// GPIO chip: name ("gpiochip0"), path ("/dev/gpiochip0"), label or number;
    /// empty when every line is given by name (then all chips are searched).
    std::string chip;
    std::string consumer = "hullgauge";
    std::chrono::milliseconds blinkPeriod{1000};
    std::array<LampLine, 3> lines; ///< indexed by Lamp
    /// Key path of the section ("lamps") and the file, for messages.
    std::string key = "lamps";
    std::string file;

    /// Parses and validates a `lamps` section; throws hg::InputError naming the key.
    static LampsConfig parse(const ConfigNode& section);
};

/// The lamp states that show `indication` (indexed by Lamp).
std::array<LampState, 3> lampStatesFor(StationIndication indication);

class Lamps {
  public:
    virtual ~Lamps();
    Lamps(const Lamps&) = delete;
    Lamps& operator=(const Lamps&) = delete;

    // Lifecycle transitions (lifecycle.h). A transition not allowed in the
    // current state returns NotAllowed and changes nothing. A failed configure
    // leaves the driver Unconfigured; a write failure while Active enters
    // Failed, from which cleanup() and configure() recover.
    LampResult configure();
    LampResult activate();
    LampResult deactivate();
    LampResult cleanup();
    LifecycleState state() const;

    /// Sets one lamp (Active only).
    LampResult set(Lamp lamp, LampState state);
    /// Sets all three lamps at once to show `indication` (Active only).
    LampResult show(StationIndication indication);
    /// The commanded state of a lamp.
    LampState commanded(Lamp lamp) const;

    const LampsConfig& config() const { return config_; }
    /// The backend name from the configuration (`gpiod`, `sim`).
    virtual std::string_view backend() const = 0;

  protected:
    explicit Lamps(LampsConfig config);

    /// Opens the chip and requests the lines as outputs, all dark.
    virtual LampResult onConfigure() = 0;
    /// Releases the lines and closes the chip; never fails.
    virtual void onCleanup() = 0;
    /// Drives the three lines: `lit[i]` true lights lamp i (active-low lines
    /// are inverted by the backend). Called with the driver's lock held.
    virtual LampResult writeOutputs(const std::array<bool, 3>& lit) = 0;

    /// Stops the blink thread; backends call it first in their destructor so
    /// that no write reaches a half-destroyed object.
    void shutdown();

  private:
    LampResult applyLocked();
    LampResult requireActiveLocked(std::string_view call) const;
    void blinkLoop();
    void startBlinkerLocked();

    LampsConfig config_;
    mutable std::mutex mutex_;
    std::condition_variable wake_;
    LifecycleState state_ = LifecycleState::Unconfigured;
    std::array<LampState, 3> commanded_{LampState::Off, LampState::Off, LampState::Off};
    bool blinkLit_ = true; ///< phase of the blinking lamps: lit in the first half period
    bool stopBlinker_ = false;
    std::thread blinker_;
};

/// Builds the driver named by `lamps.backend` (`gpiod` or `sim`) from the
/// station's `lamps` section. Parses and validates only (lifecycle `init`):
/// unknown backends and bad line descriptions throw hg::InputError naming
/// file, line and key.
std::unique_ptr<Lamps> makeLamps(const ConfigNode& section);

/// The simulated twin (`backend: sim`): records the level of each line so that
/// tests can read what the operator would see, including the blink phase.
/// Obtain it with `dynamic_cast<SimulatedLamps*>`.
class SimulatedLamps : public Lamps {
  public:
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

  protected:
    using Lamps::Lamps;
};

} // namespace hg::drivers
