// The SPC charts of docs/spc.md: formulas, constants and rule definitions there.
#include "hullgauge/study/spc.h"

#include "hullgauge/common/error.h"
#include "sample_statistics.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <functional>
#include <span>
#include <tuple>
#include <utility>

namespace hg::study {

RuleSet parseRuleSet(std::string_view text)
{
    if (const auto rules = parseEnum<RuleSet>(text)) return *rules;
    throw InputError("", "rules",
                     "unknown rule set '" + std::string(text) + "': expected " + enumNameList<RuleSet>(", ", " or "));
}

namespace {

/// Where the points lie against the baseline's centre line and σ (docs/spc.md,
/// "Zones"): beyond kσ is strictly farther than kσ; a point on the centre line
/// is on neither side.
struct Zones {
    const std::vector<double>& x;
    double centre;
    double sigma;

    bool onSide(std::size_t i, Direction s) const { return s == Direction::Up ? x[i] > centre : x[i] < centre; }
    bool beyond(std::size_t i, double k, Direction s) const
    {
        return s == Direction::Up ? x[i] - centre > k * sigma : x[i] - centre < -k * sigma;
    }
    bool beyondEither(std::size_t i, double k) const { return std::abs(x[i] - centre) > k * sigma; }
};

using PointTest = std::function<bool(std::size_t)>;

/// Every point i that ends `needed` consecutive points passing `holds`: the
/// violation involves those points and the `lead` points before them (a step
/// test at i looks back at i − 1, an alternation test at i − 1 and i − 2).
void addRuns(const std::string& rule, std::size_t needed, std::size_t lead, const PointTest& holds,
             std::optional<Direction> direction, std::size_t n, std::vector<RuleViolation>& out)
{
    std::size_t run = 0;
    for (std::size_t i = 0; i < n; ++i) {
        run = holds(i) ? run + 1 : 0;
        if (run < needed) continue;
        RuleViolation v{rule, i, {}, direction};
        for (std::size_t j = i + 1 - needed - lead; j <= i; ++j) v.points.push_back(j);
        out.push_back(std::move(v));
    }
}

/// Every point i beyond kσ on a side with at least `k` of the `m` points
/// ending at i beyond kσ on that side; the violation involves those points.
void addKOfM(const std::string& rule, std::size_t k, std::size_t m, double sigmas, const Zones& z,
             std::vector<RuleViolation>& out)
{
    for (std::size_t i = 0; i < z.x.size(); ++i)
        for (const auto side : {Direction::Up, Direction::Down}) {
            if (!z.beyond(i, sigmas, side)) continue;
            RuleViolation v{rule, i, {}, side};
            for (std::size_t j = i + 1 - std::min(m, i + 1); j <= i; ++j)
                if (z.beyond(j, sigmas, side)) v.points.push_back(j);
            if (v.points.size() >= k) out.push_back(std::move(v));
        }
}

/// Nine (Nelson 2) or eight (Western Electric 4) points in a row on one side.
void addSameSide(const std::string& rule, std::size_t needed, const Zones& z, std::vector<RuleViolation>& out)
{
    for (const auto side : {Direction::Up, Direction::Down}) {
        const auto onSide = [&](std::size_t i) { return z.onSide(i, side); };
        addRuns(rule, needed, 0, onSide, side, z.x.size(), out);
    }
}

/// Nelson 3, 4 and 7, 8: the trends, the alternation and the runs in or out of zone C.
void addNelsonShapes(const Zones& z, std::vector<RuleViolation>& out)
{
    const auto& x = z.x;
    const auto n = x.size();
    // Six points steadily increasing (decreasing) are five steps up (down) in a row.
    const auto rises = [&](std::size_t i) { return i >= 1 && x[i] > x[i - 1]; };
    const auto falls = [&](std::size_t i) { return i >= 1 && x[i] < x[i - 1]; };
    addRuns("nelson_3", 5, 1, rises, Direction::Up, n, out);
    addRuns("nelson_3", 5, 1, falls, Direction::Down, n, out);
    // Fourteen points alternating are thirteen steps, each of the other sign than the one
    // before it: twelve changes of direction in a row; a step of 0 changes nothing.
    const auto alternates = [&](std::size_t i) { return i >= 2 && (x[i] - x[i - 1]) * (x[i - 1] - x[i - 2]) < 0.0; };
    addRuns("nelson_4", 12, 2, alternates, std::nullopt, n, out);
    const auto inZoneC = [&](std::size_t i) { return !z.beyondEither(i, 1.0); };
    const auto outOfZoneC = [&](std::size_t i) { return z.beyondEither(i, 1.0); };
    addRuns("nelson_7", 15, 0, inZoneC, std::nullopt, n, out);
    addRuns("nelson_8", 8, 0, outOfZoneC, std::nullopt, n, out);
}

std::vector<std::string> ruleNames(RuleSet rules)
{
    if (rules == RuleSet::Nelson)
        return {"nelson_1", "nelson_2", "nelson_3", "nelson_4", "nelson_5", "nelson_6", "nelson_7", "nelson_8"};
    return {"we_1", "we_2", "we_3", "we_4"};
}

/// The rule set's violations in point order (rule order within a point).
std::vector<RuleViolation> applyRules(RuleSet rules, const Zones& z)
{
    std::vector<RuleViolation> out;
    if (rules == RuleSet::Nelson) {
        addKOfM("nelson_1", 1, 1, 3.0, z, out);
        addSameSide("nelson_2", 9, z, out);
        addNelsonShapes(z, out);
        addKOfM("nelson_5", 2, 3, 2.0, z, out);
        addKOfM("nelson_6", 4, 5, 1.0, z, out);
    } else {
        addKOfM("we_1", 1, 1, 3.0, z, out);
        addKOfM("we_2", 2, 3, 2.0, z, out);
        addKOfM("we_3", 4, 5, 1.0, z, out);
        addSameSide("we_4", 8, z, out);
    }
    const auto names = ruleNames(rules);
    const auto rank = [&](const std::string& rule) { return std::find(names.begin(), names.end(), rule); };
    std::stable_sort(out.begin(), out.end(), [&](const RuleViolation& a, const RuleViolation& b) {
        return a.point != b.point ? a.point < b.point : rank(a.rule) < rank(b.rule);
    });
    return out;
}

/// a / σ for σ > 0 and a finite; absent otherwise (docs/spc.md, "Capability").
std::optional<double> indexOf(double a, double sigma)
{
    if (!(sigma > 0.0) || !std::isfinite(a)) return std::nullopt;
    return a / sigma;
}

/// Cp = (USL − LSL) / 6σ when both limits are finite; Cpk = min(USL − μ, μ − LSL) / 3σ
/// over the finite ones.
std::pair<std::optional<double>, std::optional<double>> indices(const Zone& zone, double mu, double sigma)
{
    std::optional<double> cp;
    if (std::isfinite(zone.lower) && std::isfinite(zone.upper)) cp = indexOf(zone.upper - zone.lower, 6.0 * sigma);
    std::optional<double> nearest;
    if (std::isfinite(zone.upper)) nearest = zone.upper - mu;
    if (std::isfinite(zone.lower)) nearest = std::min(nearest.value_or(kUnbounded), mu - zone.lower);
    return {cp, nearest ? indexOf(*nearest, 3.0 * sigma) : std::nullopt};
}

/// `points`' moving ranges are those of x, none across a gap.
Capability capabilityOf(const std::vector<double>& x, const std::vector<SpcPoint>& points, const Zone& zone)
{
    Capability c;
    c.mean = mean(x);
    std::vector<double> ranges;
    for (const auto& p : points)
        if (p.movingRange) ranges.push_back(*p.movingRange);
    c.sigmaWithin = mean(ranges) / kD2;
    c.stddev = sampleStddev(x, c.mean);
    std::tie(c.cp, c.cpk) = indices(zone, c.mean, c.sigmaWithin);
    std::tie(c.pp, c.ppk) = indices(zone, c.mean, c.stddev);
    return c;
}

Yield yieldOf(const std::vector<double>& x, const Zone& zone)
{
    Yield y;
    y.n = x.size();
    y.within = static_cast<std::size_t>(
        std::count_if(x.begin(), x.end(), [&](double v) { return v >= zone.lower && v <= zone.upper; }));
    y.fraction = static_cast<double>(y.within) / static_cast<double>(y.n);
    return y;
}

/// Sturges' rule, ⌈log2 n⌉ + 1 bins, of equal width over the data and the finite
/// limits; the last bin includes its upper edge.
Histogram histogramOf(const std::vector<double>& x, const Zone& zone)
{
    Histogram h;
    h.method = "sturges";
    const auto bins = static_cast<std::size_t>(std::bit_width(x.size() - 1)) + 1;
    auto [lo, hi] = std::minmax_element(x.begin(), x.end());
    double low = *lo, high = *hi;
    if (std::isfinite(zone.lower)) low = std::min(low, zone.lower);
    if (std::isfinite(zone.upper)) high = std::max(high, zone.upper);
    if (!(high > low)) { // one value and no limit beside it: a 2 µm wide axis around it
        low -= 0.001;
        high += 0.001;
    }
    const double width = (high - low) / static_cast<double>(bins);
    for (std::size_t i = 0; i < bins; ++i) h.edges.push_back(low + static_cast<double>(i) * width);
    h.edges.push_back(high);
    h.counts.assign(bins, 0);
    for (double v : x) {
        auto b = std::min(bins - 1, static_cast<std::size_t>((v - low) / width));
        while (b > 0 && v < h.edges[b]) --b;
        while (b + 1 < bins && v >= h.edges[b + 1]) ++b;
        ++h.counts[b];
    }
    return h;
}

/// The values as points, each with its cycle (its index when the series
/// names none) and its moving range when the cycle before it has a value.
std::vector<SpcPoint> pointsOf(const LandmarkSeries& series)
{
    std::vector<SpcPoint> points;
    const bool cyclesGiven = series.cycles.size() == series.values.size();
    for (std::size_t i = 0; i < series.values.size(); ++i) {
        SpcPoint p;
        p.index = i;
        p.cycle = cyclesGiven ? series.cycles[i] : i;
        if (i < series.serials.size()) p.serial = series.serials[i];
        p.value = series.values[i];
        if (i > 0 && p.cycle == points.back().cycle + 1)
            p.movingRange = std::abs(series.values[i] - series.values[i - 1]);
        points.push_back(std::move(p));
    }
    return points;
}

/// The moving ranges of the baseline's points (none across a gap).
std::vector<double> baselineRanges(const SpcResult& r)
{
    std::vector<double> mr;
    for (std::size_t i = 1; i < r.baselineUsed; ++i)
        if (r.points[i].movingRange) mr.push_back(*r.points[i].movingRange);
    return mr;
}

/// The I-MR limits from the first baselineUsed values (docs/spc.md, "Charts").
void chartLimits(const std::vector<double>& x, SpcResult& r)
{
    const std::span<const double> baseline(x.data(), r.baselineUsed);
    const double mrBar = mean(baselineRanges(r));
    r.sigmaWithin = mrBar / kD2;
    r.iChart.centre = mean(baseline);
    r.iChart.ucl = r.iChart.centre + 3.0 * r.sigmaWithin;
    r.iChart.lcl = r.iChart.centre - 3.0 * r.sigmaWithin;
    r.mrChart = {mrBar, kD4 * mrBar, 0.0};
}

} // namespace

SpcResult spcOf(const LandmarkSeries& series, const SpcOptions& options)
{
    if (options.baseline < 2)
        throw InputError("", "", "baseline must be at least 2 (got " + std::to_string(options.baseline) + ")");
    SpcResult r;
    r.id = series.id;
    r.source = series.source;
    r.zone = series.zone;
    r.n = series.values.size();
    r.rules = options.rules;
    r.baselineRequested = options.baseline;
    r.points = pointsOf(series);
    r.gaps = series.gaps;
    r.notEvaluated = !series.problem.empty() ? series.problem : (r.n < 2 ? "fewer than 2 values" : "");
    if (!r.notEvaluated.empty()) return r;
    r.baselineUsed = std::min(options.baseline, r.n);
    r.baselineShort = r.baselineUsed < options.baseline;
    if (baselineRanges(r).empty()) {
        r.notEvaluated = "no two values of the baseline come from consecutive cycles (a gap between each): no moving "
                         "range to estimate sigma_within from";
        return r;
    }
    r.evaluated = true;

    const auto& x = series.values;
    chartLimits(x, r);
    for (auto& p : r.points) p.mrAboveUcl = p.movingRange && *p.movingRange > r.mrChart.ucl;
    if (r.sigmaWithin > 0.0) {
        r.tested = ruleNames(options.rules);
        r.violations = applyRules(options.rules, Zones{x, r.iChart.centre, r.sigmaWithin});
        for (const auto& v : r.violations) r.points[v.point].rules.push_back(v.rule);
    } else {
        r.notTested = "the baseline's values are all equal (sigma_within 0): no zones to test the points against";
    }
    r.capability = capabilityOf(x, r.points, r.zone);
    r.yield = yieldOf(x, r.zone);
    r.histogram = histogramOf(x, r.zone);
    return r;
}

namespace {

/// A number in mm or an index; null when it is not finite.
nlohmann::json number(double v)
{
    return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
}

nlohmann::json number(const std::optional<double>& v)
{
    return v ? number(*v) : nlohmann::json(nullptr);
}

nlohmann::json pointJson(const SpcPoint& p)
{
    return {{"index", p.index},
            {"cycle", p.cycle},
            {"serial", p.serial},
            {"value_mm", number(p.value)},
            {"moving_range_mm", number(p.movingRange)},
            {"mr_above_ucl", p.mrAboveUcl},
            {"rules", p.rules}};
}

nlohmann::json rulesJson(const SpcResult& r)
{
    auto violations = nlohmann::json::array();
    for (const auto& v : r.violations)
        violations.push_back(
            {{"rule", v.rule},
             {"point", v.point},
             {"points", v.points},
             {"direction", v.direction ? nlohmann::json(std::string(enumName(*v.direction))) : nlohmann::json()}});
    return {{"set", std::string(enumName(r.rules))},
            {"tested", r.tested},
            {"not_tested", r.notTested.empty() ? nlohmann::json() : nlohmann::json(r.notTested)},
            {"violations", violations}};
}

/// The parts computed only for an evaluated series (docs/spc.md, "JSON").
void addEvaluated(const SpcResult& r, nlohmann::json& j)
{
    const auto& c = r.capability;
    j["baseline"] = {{"requested", r.baselineRequested}, {"used", r.baselineUsed}, {"short", r.baselineShort}};
    j["i_chart"] = {{"centre_mm", number(r.iChart.centre)},
                    {"ucl_mm", number(r.iChart.ucl)},
                    {"lcl_mm", number(r.iChart.lcl)},
                    {"sigma_within_mm", number(r.sigmaWithin)}};
    j["mr_chart"] = {
        {"centre_mm", number(r.mrChart.centre)}, {"ucl_mm", number(r.mrChart.ucl)}, {"lcl_mm", number(r.mrChart.lcl)}};
    j["rules"] = rulesJson(r);
    j["capability"] = {{"mean_mm", number(c.mean)},     {"sigma_within_mm", number(c.sigmaWithin)},
                       {"stddev_mm", number(c.stddev)}, {"cp", number(c.cp)},
                       {"cpk", number(c.cpk)},          {"pp", number(c.pp)},
                       {"ppk", number(c.ppk)}};
    j["yield"] = {{"within", r.yield.within}, {"n", r.yield.n}, {"fraction", number(r.yield.fraction)}};
    auto edges = nlohmann::json::array();
    for (double e : r.histogram.edges) edges.push_back(number(e));
    j["histogram"] = {{"method", r.histogram.method},
                      {"bins", r.histogram.counts.size()},
                      {"edges_mm", edges},
                      {"counts", r.histogram.counts}};
}

} // namespace

nlohmann::json toJson(const SpcResult& r)
{
    auto points = nlohmann::json::array();
    for (const auto& p : r.points) points.push_back(pointJson(p));
    auto gaps = nlohmann::json::array();
    for (const auto& g : r.gaps) gaps.push_back({{"cycle", g.cycle}, {"serial", g.serial}, {"reason", g.reason}});
    nlohmann::json j{{"id", r.id},
                     {"values", std::string(enumName(r.source))},
                     {"zone_mm", nlohmann::json::array({number(r.zone.lower), number(r.zone.upper)})},
                     {"n", r.n},
                     {"evaluated", r.evaluated},
                     {"not_evaluated", r.evaluated ? nlohmann::json() : nlohmann::json(r.notEvaluated)},
                     {"constants", {{"d2", kD2}, {"D4", kD4}}},
                     {"points", points},
                     {"gaps", gaps}};
    for (const char* key : {"baseline", "i_chart", "mr_chart", "rules", "capability", "yield", "histogram"})
        j[key] = nullptr;
    if (r.evaluated) addEvaluated(r, j);
    return j;
}

} // namespace hg::study
