// When the master must be measured again (docs/mastering.md, "Re-mastering
// due"): a correction set holds only while the station's bias is the one it
// was measured with, so it goes out of date after a time, after a number of
// production parts, when the station is calibrated anew, when the program
// is released in a new version or when the part's temperature has moved too
// far from the master's. Once due, the station signals it and still
// judges production for a grace count of cycles; past it production triggers
// are refused while master and study cycles run on, so the master can be
// measured. A new correction set clears it.
//
// Pure: no I/O, no threads; the time is read on the injected hg::Clock
// (docs/style.md points 3 and 9). The caller serialises the calls.
#pragma once

#include "hullgauge/common/clock.h"
#include "hullgauge/common/enum_names.h"
#include "hullgauge/station/plc_registers.h"

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>

namespace hg::station {

/// What makes mastering due; each cause off when unset or false.
struct MasteringDuePolicy {
    std::optional<std::chrono::milliseconds> maxAge{}; ///< since the set was computed
    std::optional<std::uint64_t> maxParts{};           ///< production cycles judged with the set
    bool onCalibrationChange = true;                   ///< the station calibrated anew since
    bool onProgramChange = true;                       ///< the program is another release than the set's
    std::uint64_t graceCycles = 0;                     ///< production cycles still judged once due
    /// The largest change of the part's temperature (°C) from the set's before it is due.
    std::optional<double> maxTemperatureStepC{};
    bool operator==(const MasteringDuePolicy&) const = default;
};

/// Why mastering is due; None: it is not. The first that holds, in this order.
enum class MasteringDueCause { None, NotMastered, Program, Calibration, Age, Parts, Temperature };
constexpr auto nameTable(MasteringDueCause)
{
    using enum MasteringDueCause;
    return std::to_array<EnumName<MasteringDueCause>>({{None, "none"},
                                                       {NotMastered, "not_mastered"},
                                                       {Program, "program_changed"},
                                                       {Calibration, "calibration_changed"},
                                                       {Age, "age"},
                                                       {Parts, "parts"},
                                                       {Temperature, "temperature"}});
}

/// The correction set in force and what the station was when it was measured.
struct MasteringInForce {
    std::string correctionId;
    std::int64_t createdUnixMs = 0;    ///< when the set was computed (wall time, UTC)
    std::optional<int> programVersion; ///< the release it was mastered on; none for a draft
    std::string calibration;           ///< the station's calibration as it was then (any stable identity)
    /// The mean temperature of the master cycles (°C); none: the first reading after the set came into force
    /// stands for it.
    std::optional<double> temperatureC{};
};

/// The production parts the result store holds judged with a set, read when
/// the set comes into force, so a restart continues the count and the grace
/// (docs/mastering.md, "Due in the daemon").
struct MasteringHistory {
    std::uint64_t parts = 0;        ///< production parts judged with the set
    std::uint64_t partsPastAge = 0; ///< of them, started once the set was past its maximum age
};

class MasteringDue {
  public:
    /// `calibration`: the station's calibration now (the identity MasteringInForce names).
    MasteringDue(MasteringDuePolicy policy, const Clock& clock, std::string calibration);

    /// A correction set in force: due cleared, the part and grace counts start
    /// from what was judged with it before (`history`; none for a new set).
    void mastered(MasteringInForce set, MasteringHistory history = {});
    /// The program now loaded is `version` (none: a draft).
    void programIs(std::optional<int> version);
    /// The station calibrated anew: `calibration` is its new identity.
    void calibrationIs(std::string calibration);
    /// A cycle of `purpose` was judged: a production one counts as a part
    /// and, while due, uses up one cycle of the grace.
    void judged(CyclePurpose purpose);
    /// A judged cycle's part was at `temperatureC` (°C). Told after judged(): the
    /// cycle whose temperature makes it due does not use the grace.
    void temperatureIs(double temperatureC);

    /// Why mastering is due now (None: it is not). Once due it stays due
    /// until a new set, whatever changes back.
    MasteringDueCause cause() const;
    bool due() const { return cause() != MasteringDueCause::None; }
    /// Whether a trigger of `purpose` may start a cycle: always for master and
    /// study cycles; production only while not due or within the grace.
    bool admits(CyclePurpose purpose) const;
    /// Production cycles still judged before production is refused (the grace left; 0 when refused).
    std::uint64_t graceLeft() const;

  private:
    MasteringDueCause causeNow() const;
    void latch();

    MasteringDuePolicy policy_;
    const Clock* clock_;
    std::optional<MasteringInForce> set_;
    std::optional<int> programVersion_;
    std::string calibration_;
    std::optional<double> referenceC_;   ///< the set's temperature, or the first reading with it
    std::optional<double> temperatureC_; ///< the last reading with the set in force
    std::uint64_t parts_ = 0;            ///< production cycles judged with the set in force
    std::uint64_t cyclesWhileDue_ = 0;   ///< of them, judged while due
    MasteringDueCause latched_ = MasteringDueCause::None;
};

} // namespace hg::station
