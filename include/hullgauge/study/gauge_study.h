// Gauge studies on the station's own results (docs/study.md): the type-1
// study of one master part measured again and again (VDA 5, Bosch booklet 10:
// Cg, Cgk) and the type-3 study, the automatic gauge R&R of several parts
// measured in turn (AIAG MSA 4th edition, ANOVA method without operators:
// EV, PV, %GRR, ndc). Pure computation on values: the records come in as the
// result store holds them (a serial and the landmarks JSON of
// src/station/result_record.cpp), the caller reads and writes the files.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "hullgauge/common/enum_names.h"
#include "hullgauge/inspect/outcome.h"

namespace hg::study {

/// A landmark's tolerance zone in mm: `limits_mm: [lower, upper]` when the
/// landmark has it, else [−tolerance_mm, +tolerance_mm]; T = upper − lower.
struct Zone {
    double lower = 0.0;
    double upper = 0.0;
    double width() const { return upper - lower; }
    bool operator==(const Zone&) const = default;
};

/// The tolerance zone of one landmark entry of a stored result (the landmarks
/// JSON of src/station/result_record.cpp): its `limits_mm` when it has them,
/// else ±`tolerance_mm`. `field` names the entry in errors ("cycle 12.landmarks.a");
/// throws hg::InputError naming it when neither is there or limits_mm is not
/// [lower, upper]. The studies and the exports (docs/export.md) take it from here.
Zone zoneOf(const nlohmann::json& entry, const std::string& field);

/// The `status` of one landmark entry of a stored result, nullopt when the
/// entry has none; a status that is no landmark status (docs/contracts.md §4)
/// throws hg::InputError naming `field`.status.
std::optional<inspect::LandmarkStatus> statusOf(const nlohmann::json& entry, const std::string& field);
/// Its `decision` likewise (docs/inspection.md, "Decisions"), nullopt when it has none.
std::optional<inspect::Decision> decisionOf(const nlohmann::json& entry, const std::string& field);

/// Which number of a landmark's result the study measured.
enum class ValueSource {
    Deviation,     ///< `deviation_mm`, the signed sub-voxel deviation (every record had it)
    BracketMiddle, ///< `error_mm`, the middle of the voxel bracket: resolution one voxel
};
constexpr auto nameTable(ValueSource)
{
    using enum ValueSource;
    return std::to_array<EnumName<ValueSource>>({{Deviation, "deviation_mm"}, {BracketMiddle, "error_mm"}});
}

/// One cycle of the study as the result store holds it.
struct StudyRecord {
    std::int64_t id = 0; ///< the row id, for messages
    std::string serial;
    nlohmann::json landmarks; ///< the record's `landmarks_json` (array of objects)
};

/// A cycle of the selection without a value for a landmark (SPC only,
/// docs/spc.md "Gaps"): where it is and why.
struct SeriesGap {
    std::size_t cycle = 0; ///< its position in the selection (0 = the oldest)
    std::string serial;
    std::string reason; ///< the landmark's status (`not_found`, `not_observable`), or `absent` when not listed
};

/// A landmark's measurements over the selected cycles, in cycle order.
struct LandmarkSeries {
    std::string id;
    Zone zone;
    ValueSource source = ValueSource::Deviation;
    std::vector<double> values;
    std::vector<std::string> serials; ///< the part of each value
    std::vector<std::size_t> cycles;  ///< the position of each value in the selection
    std::vector<SeriesGap> gaps;      ///< the cycles without a value (only when gaps are allowed)
    /// Why the landmark cannot be studied (empty when it can): a cycle without
    /// a value for it (unless gaps are allowed), a tolerance zone that changed
    /// within the selection.
    std::string problem;
};

/// How collectSeries treats a cycle without a value for a landmark.
enum class MissingValues {
    Refuse, ///< a problem naming the cycle: a gauge study needs every cycle
    Gap,    ///< a gap in the series: an SPC chart shows it and goes on
};

/// Per landmark, in the order of the first record: the deviation when every
/// record with a value has one for that landmark, else the bracket middle. A
/// landmark a record does not list, or lists `not_found` / `not_observable`,
/// has a problem naming the cycle, or with MissingValues::Gap a gap there.
/// Throws hg::InputError on malformed landmarks JSON.
std::vector<LandmarkSeries> collectSeries(const std::vector<StudyRecord>& records,
                                          MissingValues missing = MissingValues::Refuse);

/// The acceptance limits of both studies (docs/study.md).
struct Limits {
    std::size_t minType1Values = 25; ///< VDA 5 / Bosch booklet 10: at least 25 (50 recommended)
    double type1Share = 0.2;         ///< Cg compares 6 s with 20 % of T
    double cgMin = 1.33;
    double cgkMin = 1.33;
    double grrAcceptable = 10.0;  ///< AIAG: %GRR ≤ 10 % acceptable
    double grrConditional = 30.0; ///< 10 % < %GRR ≤ 30 % may be acceptable; above not acceptable
};

inline constexpr double kUnbounded = std::numeric_limits<double>::infinity();

/// Type-1 study of one landmark on repeated measurements of a master part.
/// With s = 0 Cg is +∞ and Cgk ±∞ by the sign of 0.1·T − |bias| (0 when that is 0).
struct Type1Result {
    std::size_t n = 0;
    bool evaluated = false;
    std::string notEvaluated; ///< why not, when !evaluated
    double tolerance = 0.0;   ///< T
    double mean = 0.0;
    double stddev = 0.0; ///< s, with n − 1
    double reference = 0.0;
    double bias = 0.0; ///< x̄ − x_ref
    double cg = 0.0;
    double cgk = 0.0;
    bool capable = false; ///< Cg ≥ 1.33 and Cgk ≥ 1.33
};

Type1Result type1(const std::vector<double>& values, double tolerance, double reference, const Limits& limits = {});

enum class Acceptance { Acceptable, Conditional, NotAcceptable };
constexpr auto nameTable(Acceptance)
{
    using enum Acceptance;
    return std::to_array<EnumName<Acceptance>>(
        {{Acceptable, "acceptable"}, {Conditional, "conditional"}, {NotAcceptable, "not_acceptable"}});
}
Acceptance grrAcceptance(double percent, const Limits& limits = {});

/// Type-3 study of one landmark: p parts × r trials, one-way ANOVA (no operators).
struct Type3Result {
    std::size_t parts = 0;  ///< p
    std::size_t trials = 0; ///< r
    double tolerance = 0.0; ///< T
    double grandMean = 0.0;
    double ssParts = 0.0, ssError = 0.0;
    double msParts = 0.0, msError = 0.0;
    double ev = 0.0;  ///< repeatability, sqrt(MS_error)
    double pv = 0.0;  ///< part variation, sqrt(max(0, (MS_parts − MS_error) / r))
    double grr = 0.0; ///< = EV (no operators, so no appraiser variation)
    double tv = 0.0;  ///< sqrt(GRR² + PV²)
    /// 100·GRR/TV and 100·6·GRR/T; absent when TV (or T) is 0.
    std::optional<double> percentGrr, percentTolerance;
    /// floor(1.41·PV/GRR); absent when GRR is 0 (unbounded).
    std::optional<long> ndc;
    /// Of %GRR (study variation), of %GRR of the tolerance, and the worse of both.
    std::optional<Acceptance> acceptanceVariation, acceptanceTolerance;
    Acceptance acceptance = Acceptance::NotAcceptable;
};

/// A part's trials: its serial and its values in cycle order.
using PartTrials = std::vector<std::pair<std::string, std::vector<double>>>;

/// Throws hg::InputError naming each part's count when the layout is
/// unbalanced, or when there are fewer than 2 parts or 2 trials.
Type3Result type3(const PartTrials& byPart, double tolerance, const Limits& limits = {});

/// A series' values grouped by serial, parts in the order they first appear.
PartTrials groupByPart(const LandmarkSeries& series);

/// Checks the cycles per part of a type-3 selection (every record's serial):
/// throws hg::InputError listing each part's count when they differ, or when
/// there are fewer than 2 parts or 2 trials, or a cycle has no serial.
void checkType3Layout(const std::vector<StudyRecord>& records);

/// The JSON of one landmark's result (docs/study.md); ±∞ is written "inf" / "-inf".
nlohmann::json toJson(const Type1Result& r);
nlohmann::json toJson(const Type3Result& r);

} // namespace hg::study
