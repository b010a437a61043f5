// The fixed vocabularies of an inspection's outcome (docs/contracts.md §4,
// docs/inspection.md): a landmark's status, the ISO 14253-1 decision on its
// deviation and a geometric parameter's status. The result JSON, the result
// store's rows, the exports, the HMI and the PLC's landmark bits all spell
// them through these tables, so a value is named the same everywhere.
#pragma once

#include "hullgauge/common/enum_names.h"

namespace hg::inspect {

/// In the order docs/inspection.md ranks them. Uncertain (extension): the
/// deviation lies within its uncertainty of a limit, so the guarded decision
/// rule cannot prove conformance (docs/inspection.md, "Decisions").
enum class LandmarkStatus { Ok, OutOfTolerance, Overflow, NotFound, NotObservable, NotInspected, Uncertain };
constexpr auto nameTable(LandmarkStatus)
{
    using enum LandmarkStatus;
    return std::to_array<EnumName<LandmarkStatus>>({{Ok, "ok"},
                                                    {OutOfTolerance, "out_of_tolerance"},
                                                    {Overflow, "overflow"},
                                                    {NotFound, "not_found"},
                                                    {NotObservable, "not_observable"},
                                                    {NotInspected, "not_inspected"},
                                                    {Uncertain, "uncertain"}});
}

/// An ISO 14253-1 decision on a measured deviation against the limits.
enum class Decision { Conforms, Nonconforms, Uncertain };
constexpr auto nameTable(Decision)
{
    using enum Decision;
    return std::to_array<EnumName<Decision>>(
        {{Conforms, "conforms"}, {Nonconforms, "nonconforms"}, {Uncertain, "uncertain"}});
}

/// A geometric parameter (4.6.4): its value within the tolerance, outside
/// it, or not measured (a landmark of it was not measured).
enum class ParameterStatus { Ok, OutOfTolerance, NotMeasured };
constexpr auto nameTable(ParameterStatus)
{
    using enum ParameterStatus;
    return std::to_array<EnumName<ParameterStatus>>(
        {{Ok, "ok"}, {OutOfTolerance, "out_of_tolerance"}, {NotMeasured, "not_measured"}});
}

} // namespace hg::inspect
