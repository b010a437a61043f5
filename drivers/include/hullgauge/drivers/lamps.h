// The operator lamps: a green, an amber and a red lamp on GPIO lines
// (docs/contracts.md §6: green = pass, red = fail, amber = busy, fault = red and amber
// blinking). One small interface in domain types; no GPIO handle crosses it
// (docs/style.md point 1).
//
// Lifecycle (lifecycle.h, docs/drivers.md): constructing a driver from the
// station's `lamps` section only parses and validates it (bad sections throw
// hg::InputError naming file, line and key); configure() opens the GPIO chip
// and requests the three lines as outputs, all lamps off; activate() lets the
// lamps light; deactivate() switches every lamp off; cleanup() releases the
// lines. A line that cannot be written is an error: the driver is Failed.
//
// Blinking: every blinking lamp is lit for the first half of `blink_period_s`
// and dark for the second, all in the same phase (red and amber blink
// together), on the driver's clock (Device::clock(): the steady one unless a
// test injects its own). A timer thread owned by the driver steps the phase
// (tick()) while it is Active and some lamp blinks, waiting on that clock; a
// caller may step it too (tick() applies the phase at the clock's now, so a
// test that moves the clock by hand sees the same lines either way).
//
// The cyclic calls (set, show, tick) never throw; they return an hg::Status.
// A driver may be used from several threads.
#pragma once

#include <array>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <stop_token>
#include <string>
#include <string_view>

#include "hullgauge/common/config_node.h"
#include "hullgauge/common/worker.h"
#include "hullgauge/drivers/lifecycle.h"
#include "hullgauge/station/lamp_pattern.h"

namespace hg::drivers {

/// A lamp; its name is its key in the `lamps` section.
enum class Lamp { Green = 0, Amber = 1, Red = 2 };
constexpr auto nameTable(Lamp)
{
    using enum Lamp;
    return std::to_array<EnumName<Lamp>>({{Green, "green"}, {Amber, "amber"}, {Red, "red"}});
}
inline constexpr std::array<Lamp, 3> kAllLamps{Lamp::Green, Lamp::Amber, Lamp::Red};

enum class LampState { Off, On, Blinking };
constexpr auto nameTable(LampState)
{
    using enum LampState;
    return std::to_array<EnumName<LampState>>({{Off, "off"}, {On, "on"}, {Blinking, "blinking"}});
}

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

/// The lamp states that show `pattern` (indexed by Lamp).
std::array<LampState, 3> lampStatesFor(station::LampPattern pattern);

class Lamps : public Device {
  public:
    ~Lamps() override;

    /// Sets one lamp (Active only).
    Status set(Lamp lamp, LampState state);
    /// Sets all three lamps at once to show `pattern` (Active only).
    Status show(station::LampPattern pattern);
    /// The commanded state of a lamp.
    LampState commanded(Lamp lamp) const;
    /// Drives the blinking lamps to their phase at the clock's now (a write
    /// only when a line changes). The timer thread calls it at every half
    /// period; a caller may too. Nothing while not Active.
    Status tick();

    const LampsConfig& config() const { return config_; }
    /// The backend name from the configuration (`gpiod`, `sim`).
    virtual std::string_view backend() const = 0;

  protected:
    /// The blink timer runs on `clock`.
    Lamps(LampsConfig config, Clock& clock);

    /// Opens the chip and requests the lines as outputs, all dark.
    virtual Status openLines() = 0;
    /// Releases the lines and closes the chip; never fails.
    virtual void closeLines() = 0;
    /// Drives the three lines: `lit[i]` true lights lamp i (active-low lines
    /// are inverted by the backend). Called with the driver's lock held.
    virtual Status writeOutputs(const std::array<bool, 3>& lit) = 0;

    /// Stops the blink thread; backends call it first in their destructor so
    /// that no write reaches a half-destroyed object.
    void shutdown();

  private:
    HookResult onConfigure() final;
    HookResult onActivate() final;
    HookResult onDeactivate() final;
    void onCleanup() final;

    void command(const std::array<LampState, 3>& states);
    bool blinking() const;
    /// Writes the lines for the commanded states at the clock's now; unless
    /// `always`, only when a line changes.
    Status writeLocked(bool always);
    Status applyLocked();
    void blinkLoop(std::stop_token stop);

    LampsConfig config_;
    std::condition_variable wake_;
    std::array<LampState, 3> commanded_{LampState::Off, LampState::Off, LampState::Off};
    std::array<bool, 3> written_{};
    /// Start of a lit half period of the blinking lamps (the phase origin).
    Clock::time_point phaseStart_;
    Worker blinker_; ///< blinkLoop(); last, so it ends before what it uses
};

struct SimulationControls;

/// Builds the driver named by `lamps.backend` from the backend table (`gpiod`
/// or `sim`) from the station's `lamps` section. Parses and validates only
/// (lifecycle `init`): unknown backends and bad line descriptions throw
/// hg::InputError naming file, line and key. The simulated twin publishes its
/// controls in `simulation` when given; `clock` is the one the blink timer
/// waits on (docs/drivers.md).
std::unique_ptr<Lamps> makeLamps(const ConfigNode& section, SimulationControls* simulation = nullptr,
                                 Clock& clock = Clock::steady());

} // namespace hg::drivers
