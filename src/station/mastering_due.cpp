#include "hullgauge/station/mastering_due.h"

#include <algorithm>
#include <cmath>
#include <utility>

namespace hg::station {

MasteringDue::MasteringDue(MasteringDuePolicy policy, const Clock& clock, std::string calibration)
    : policy_(policy), clock_(&clock), calibration_(std::move(calibration))
{
}

void MasteringDue::mastered(MasteringInForce set, MasteringHistory history)
{
    set_ = std::move(set);
    // Only readings taken with the set in force count against it.
    referenceC_ = set_->temperatureC;
    temperatureC_.reset();
    parts_ = history.parts;
    // The grace already used: the parts judged after the count made it due (the part
    // that made it due is not one of them, as in judged()) or after the age did.
    cyclesWhileDue_ = 0;
    if (policy_.maxParts && parts_ > *policy_.maxParts) cyclesWhileDue_ = parts_ - *policy_.maxParts;
    if (policy_.maxAge) cyclesWhileDue_ = std::max(cyclesWhileDue_, history.partsPastAge);
    latched_ = MasteringDueCause::None;
    latch();
}

void MasteringDue::programIs(std::optional<int> version)
{
    programVersion_ = version;
    latch();
}

void MasteringDue::calibrationIs(std::string calibration)
{
    calibration_ = std::move(calibration);
    latch();
}

void MasteringDue::judged(CyclePurpose purpose)
{
    if (purpose != CyclePurpose::Production) return;
    // A part judged while due uses the grace; the part that makes the count due does not.
    if (due()) ++cyclesWhileDue_;
    ++parts_;
    latch();
}

void MasteringDue::temperatureIs(double temperatureC)
{
    if (!set_) return;
    // A set without its masters' temperature is referred to the first part measured with it.
    if (!referenceC_) referenceC_ = temperatureC;
    temperatureC_ = temperatureC;
    latch();
}

MasteringDueCause MasteringDue::cause() const
{
    return latched_ != MasteringDueCause::None ? latched_ : causeNow();
}

bool MasteringDue::admits(CyclePurpose purpose) const
{
    return purpose != CyclePurpose::Production || graceLeft() > 0 || !due();
}

std::uint64_t MasteringDue::graceLeft() const
{
    if (!due()) return policy_.graceCycles;
    return cyclesWhileDue_ >= policy_.graceCycles ? 0 : policy_.graceCycles - cyclesWhileDue_;
}

MasteringDueCause MasteringDue::causeNow() const
{
    using enum MasteringDueCause;
    if (!set_) return NotMastered;
    if (policy_.onProgramChange && programVersion_ != set_->programVersion) return Program;
    if (policy_.onCalibrationChange && calibration_ != set_->calibration) return Calibration;
    if (policy_.maxAge && clock_->wallMs() - set_->createdUnixMs >= policy_.maxAge->count()) return Age;
    if (policy_.maxParts && parts_ >= *policy_.maxParts) return Parts;
    if (policy_.maxTemperatureStepC && referenceC_ && temperatureC_ &&
        std::abs(*temperatureC_ - *referenceC_) > *policy_.maxTemperatureStepC)
        return Temperature;
    return None;
}

// A cause seen once holds until the next set: a calibration or a release
// undone does not make the old set valid again without the master saying so.
void MasteringDue::latch()
{
    if (latched_ == MasteringDueCause::None) latched_ = causeNow();
}

} // namespace hg::station
