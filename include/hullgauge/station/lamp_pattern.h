// What the station shows the operator on its three lamps (docs/contracts.md
// §6, docs/lamps.md): the cycle rules choose the pattern for the sequencer's
// state, the lamps driver lights it. One type for both, so the driver needs
// no translation of its own.
#pragma once

#include "hullgauge/common/enum_names.h"

namespace hg::station {

/// Green pass, red fail, amber busy, red and amber blinking on fault;
/// extensions: amber blinking alone after a part not seated (FAULT_CODE 32:
/// re-seat it, docs/plc.md); amber steady beside the verdict while the
/// station asks for attention (re-mastering due, docs/mastering.md); amber
/// steady with red blinking while production triggers are refused.
enum class LampPattern {
    Off,           ///< every lamp off
    Busy,          ///< amber
    Pass,          ///< green
    Fail,          ///< red
    Fault,         ///< red and amber blinking
    Reseat,        ///< amber blinking alone: the part is not seated, re-seat it
    PassAttention, ///< green and amber: pass, and the station asks for attention
    FailAttention, ///< red and amber: fail, and the station asks for attention
    Refused,       ///< amber, red blinking: production triggers are refused
};

constexpr auto nameTable(LampPattern)
{
    using enum LampPattern;
    return std::to_array<EnumName<LampPattern>>({{Off, "off"},
                                                 {Busy, "busy"},
                                                 {Pass, "pass"},
                                                 {Fail, "fail"},
                                                 {Fault, "fault"},
                                                 {Reseat, "reseat"},
                                                 {PassAttention, "pass_attention"},
                                                 {FailAttention, "fail_attention"},
                                                 {Refused, "refused"}});
}

} // namespace hg::station
