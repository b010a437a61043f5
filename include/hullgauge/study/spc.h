// Statistical process control of one landmark over production cycles
// (docs/spc.md): the individuals and moving-range (I-MR) charts with limits
// from a baseline window, the Nelson or Western Electric run rules, Cp/Cpk
// and Pp/Ppk, the yield and a histogram with the tolerance zone. Pure
// computation on a landmark's series (gauge_study.h); the web HMI reads the
// result store and serves the JSON (docs/hmi.md).
#pragma once

#include "hullgauge/study/gauge_study.h"

#include <cstddef>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace hg::study {

/// The bias-correction constants of the I-MR chart for moving ranges of two
/// (subgroup size 2): σ = MR̄ / d2, the MR chart's UCL = D4 · MR̄ (docs/spc.md).
inline constexpr double kD2 = 1.128;
inline constexpr double kD4 = 3.267;

enum class RuleSet { Nelson, WesternElectric };
constexpr auto nameTable(RuleSet)
{
    using enum RuleSet;
    return std::to_array<EnumName<RuleSet>>({{Nelson, "nelson"}, {WesternElectric, "western_electric"}});
}
/// "nelson" | "western_electric"; throws hg::InputError naming the text otherwise.
RuleSet parseRuleSet(std::string_view text);

struct SpcOptions {
    std::size_t baseline = 25; ///< values of the baseline window, at least 2
    RuleSet rules = RuleSet::Nelson;
};

/// Centre line and control limits of a chart, in mm.
struct ControlLimits {
    double centre = 0.0;
    double ucl = 0.0;
    double lcl = 0.0;
};

/// Which side of the centre line a rule saw the points on.
enum class Direction { Up, Down };
constexpr auto nameTable(Direction)
{
    using enum Direction;
    return std::to_array<EnumName<Direction>>({{Up, "up"}, {Down, "down"}});
}

/// One completion of a run rule: the point that completes it and the points
/// it involves (indices into the series, ascending).
struct RuleViolation {
    std::string rule; ///< "nelson_1" … "nelson_8", "we_1" … "we_4"
    std::size_t point = 0;
    std::vector<std::size_t> points;
    std::optional<Direction> direction; ///< none for the two-sided rules (Nelson 4, 7, 8)
};

struct SpcPoint {
    std::size_t index = 0; ///< among the values
    std::size_t cycle = 0; ///< among the selection's cycles, gaps included
    std::string serial;
    double value = 0.0;
    /// |x_i − x_{i−1}|; none for the first point and for a point right after
    /// a gap (a range over a missing cycle is no moving range, docs/spc.md "Gaps")
    std::optional<double> movingRange;
    bool mrAboveUcl = false;        ///< movingRange > the MR chart's UCL
    std::vector<std::string> rules; ///< the rules this point completes
};

/// Capability over all values; an index is absent when its σ is 0 or the
/// zone has no finite limit it needs (Cp, Pp need both).
struct Capability {
    double mean = 0.0;
    double sigmaWithin = 0.0; ///< MR̄ / d2 over all values
    double stddev = 0.0;      ///< sample standard deviation (n − 1)
    std::optional<double> cp, cpk, pp, ppk;
};

struct Yield {
    std::size_t within = 0; ///< values in [lower, upper], limits included
    std::size_t n = 0;
    double fraction = 0.0;
};

struct Histogram {
    std::string method;        ///< "sturges"
    std::vector<double> edges; ///< bins + 1 ascending edges in mm, spanning the data and the finite limits
    std::vector<std::size_t> counts;
};

struct SpcResult {
    std::string id;
    ValueSource source = ValueSource::Deviation;
    Zone zone; ///< one bound may be ±∞ (a one-sided tolerance)
    std::size_t n = 0;
    bool evaluated = false;
    std::string notEvaluated; ///< why not, when !evaluated
    std::size_t baselineRequested = 0;
    std::size_t baselineUsed = 0; ///< min(requested, n)
    bool baselineShort = false;   ///< fewer values than requested
    ControlLimits iChart;         ///< CL = baseline mean, limits CL ± 3σ_within
    double sigmaWithin = 0.0;     ///< the baseline's MR̄ / d2
    ControlLimits mrChart;        ///< CL = baseline MR̄, UCL = D4 · MR̄, LCL = 0
    std::vector<SpcPoint> points;
    std::vector<SeriesGap> gaps; ///< the cycles without a value, drawn as gaps
    RuleSet rules = RuleSet::Nelson;
    std::vector<std::string> tested; ///< the rules applied
    std::string notTested;           ///< why the rules were not applied (empty when they were)
    std::vector<RuleViolation> violations;
    Capability capability;
    Yield yield;
    Histogram histogram;
};

/// Throws hg::InputError when options.baseline < 2. A series with a problem,
/// fewer than 2 values or no moving range in its baseline is not evaluated:
/// then only its id, source, zone, n, notEvaluated, points and gaps are set.
SpcResult spcOf(const LandmarkSeries& series, const SpcOptions& options);

/// The JSON of docs/spc.md: missing and non-finite numbers are null.
nlohmann::json toJson(const SpcResult& r);

} // namespace hg::study
