// The part's temperature at a trigger (docs/mastering.md, "Temperature";
// hullgauged.yaml's `temperature`, docs/daemon.md): the PLC's PART_TEMPERATURE
// latched with the trigger (docs/plc.md), or a sensor file holding one number
// read when the trigger is taken — a hwmon or 1-wire export, or what a script
// writes. The cycle records it with its result and refers the deviations to
// 20 °C with it.
//
// A reading that cannot be had is a missing reading, never a fault: the part
// is judged unreferred and its row holds NULL. The journal (category
// `inspect`) says why once, and again only when the reason changes, so a
// stale file does not fill it at every part; a line says when readings are
// back.
#pragma once

#include "daemon_config.h"
#include "hullgauge/common/clock.h"
#include "hullgauge/common/status.h"

#include <optional>
#include <string>
#include <string_view>

namespace hg::daemon {

/// The temperature (°C) in a sensor file's text: one decimal number, blanks
/// and a final newline around it, times `scale`. A failure naming what was
/// wrong (empty, not a number, more than one, not finite, or outside
/// −100…200 °C — the sign of a file in millidegrees read without `scale: 0.001`).
Result<double> parseTemperatureText(std::string_view text, double scale);

/// The sensor file of `config` read now: its age (last written, against
/// `clock`'s wall time; `max_age_s`) and its number. A failure naming the
/// file and what was wrong.
Result<double> readTemperatureFile(const station::TemperatureConfig& config, const Clock& clock);

class PartTemperature {
  public:
    explicit PartTemperature(const Clock& clock) : clock_(&clock) {}

    /// The part's temperature at a trigger: none without `config`; the PLC's
    /// `plcC` (PART_TEMPERATURE latched with the trigger) for source `plc`;
    /// the sensor file read now for source `file`, none when it cannot be read
    /// (the journal says why). Never throws.
    std::optional<double> atTrigger(const std::optional<station::TemperatureConfig>& config,
                                    std::optional<double> plcC);

  private:
    const Clock* clock_;
    std::string lastProblem_; ///< the reason last warned of; empty while readings come
};

} // namespace hg::daemon
