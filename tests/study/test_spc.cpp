// The SPC charts (docs/spc.md) on series worked out by hand: every expected
// value is written with its arithmetic, every run rule is met by a series
// built for it at a known point and missed by the same series one point short.
#include "hullgauge/study/spc.h"

#include "hullgauge/common/error.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>

namespace hg::study {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

/// Ten values in mm with a hand-computed chart (the test below).
const std::vector<double> kTen{0.10, 0.12, 0.11, 0.14, 0.12, 0.13, 0.10, 0.12, 0.11, 0.15};

LandmarkSeries seriesOf(std::vector<double> values, Zone zone = {0.0, 0.3})
{
    LandmarkSeries s;
    s.id = "bore";
    s.zone = zone;
    for (std::size_t i = 0; i < values.size(); ++i) s.serials.push_back("S" + std::to_string(i));
    s.values = std::move(values);
    return s;
}

/// −0.564, +0.564, then `tail`, charted with these two values as the baseline:
/// CL = 0, MR̄ = 1.128, σ_within = 1.128 / 1.128 = 1 — every value is its
/// distance from the centre line in σ, and the tail starts at index 2.
SpcResult unitChart(const std::vector<double>& tail, RuleSet rules = RuleSet::Nelson)
{
    std::vector<double> values{-0.564, 0.564};
    values.insert(values.end(), tail.begin(), tail.end());
    return spcOf(seriesOf(values, {-10.0, 10.0}), {2, rules});
}

std::vector<RuleViolation> violationsOf(const SpcResult& r, const std::string& rule)
{
    std::vector<RuleViolation> out;
    for (const auto& v : r.violations)
        if (v.rule == rule) out.push_back(v);
    return out;
}

std::vector<std::size_t> range(std::size_t first, std::size_t last)
{
    std::vector<std::size_t> v;
    for (std::size_t i = first; i <= last; ++i) v.push_back(i);
    return v;
}

std::vector<double> repeated(std::size_t n, double v)
{
    return std::vector<double>(n, v);
}

std::vector<double> operator+(std::vector<double> a, const std::vector<double>& b)
{
    a.insert(a.end(), b.begin(), b.end());
    return a;
}

/// `n` values alternating −a, +a, −a, …
std::vector<double> alternating(std::size_t n, double a)
{
    std::vector<double> v;
    for (std::size_t i = 0; i < n; ++i) v.push_back(i % 2 == 0 ? -a : a);
    return v;
}

/// Exactly one violation of `rule`, completed at `point`, involving `points`.
void expectOne(const SpcResult& r, const std::string& rule, std::size_t point, const std::vector<std::size_t>& points,
               std::optional<Direction> direction)
{
    const auto found = violationsOf(r, rule);
    ASSERT_EQ(found.size(), 1u) << rule;
    EXPECT_EQ(found[0].point, point) << rule;
    EXPECT_EQ(found[0].points, points) << rule;
    EXPECT_EQ(found[0].direction, direction) << rule;
    const auto& marks = r.points.at(point).rules;
    EXPECT_NE(std::find(marks.begin(), marks.end(), rule), marks.end()) << rule;
}

void expectNone(const SpcResult& r, const std::string& rule)
{
    const auto found = violationsOf(r, rule);
    EXPECT_TRUE(found.empty()) << rule << " completed at " << (found.empty() ? 0 : found.front().point);
}

TEST(SpcChart, TenValuesByHand)
{
    // Σx = 1.20: CL = 0.12. Moving ranges 0.02 0.01 0.03 0.02 0.01 0.03 0.02 0.01 0.04, Σ = 0.19:
    // MR̄ = 0.19 / 9 = 0.0211111; σ_within = 0.0211111 / 1.128 = 0.0187155, 3σ = 0.0561466;
    // UCL = 0.12 + 0.0561466 = 0.1761466, LCL = 0.12 − 0.0561466 = 0.0638534;
    // MR chart UCL = 3.267 · 0.0211111 = 0.62073 / 9 = 0.06897, LCL 0.
    const auto r = spcOf(seriesOf(kTen), {});
    ASSERT_TRUE(r.evaluated) << r.notEvaluated;
    EXPECT_EQ(r.n, 10u);
    EXPECT_EQ(r.baselineRequested, 25u);
    EXPECT_EQ(r.baselineUsed, 10u);
    EXPECT_TRUE(r.baselineShort);
    EXPECT_NEAR(r.iChart.centre, 0.12, 1e-12);
    EXPECT_NEAR(r.mrChart.centre, 0.0211111, 1e-7);
    EXPECT_NEAR(r.sigmaWithin, 0.0187155, 1e-7);
    EXPECT_NEAR(r.iChart.ucl, 0.1761466, 1e-7);
    EXPECT_NEAR(r.iChart.lcl, 0.0638534, 1e-7);
    EXPECT_NEAR(r.mrChart.ucl, 0.06897, 1e-9);
    EXPECT_EQ(r.mrChart.lcl, 0.0);
    ASSERT_EQ(r.points.size(), 10u);
    EXPECT_FALSE(r.points[0].movingRange);
    EXPECT_NEAR(*r.points[9].movingRange, 0.04, 1e-12);
    EXPECT_EQ(r.points[3].serial, "S3");
    EXPECT_EQ(r.points[3].value, 0.14);
}

TEST(SpcChart, TheBaselineIsTheFirstValuesOnly)
{
    // Baseline 0.10 0.12 0.11 0.14 0.12: CL = 0.59 / 5 = 0.118; MR 0.02 0.01 0.03 0.02, MR̄ = 0.02,
    // σ_within = 0.02 / 1.128 = 0.0177305; the capability's σ_within stays that of all ten (0.0187155).
    const auto r = spcOf(seriesOf(kTen), {5, RuleSet::Nelson});
    EXPECT_EQ(r.baselineUsed, 5u);
    EXPECT_FALSE(r.baselineShort);
    EXPECT_NEAR(r.iChart.centre, 0.118, 1e-12);
    EXPECT_NEAR(r.sigmaWithin, 0.0177305, 1e-7);
    EXPECT_NEAR(r.capability.sigmaWithin, 0.0187155, 1e-7);
}

TEST(SpcChart, MovingRangeAboveItsLimit)
{
    // MR chart UCL = 3.267 · 1.128 = 3.685; |0.5 − 0.564| = 0.064 is below, |4.5 − 0.5| = 4 above.
    const auto r = unitChart({0.5, 4.5});
    EXPECT_NEAR(r.mrChart.ucl, 3.685176, 1e-6);
    EXPECT_FALSE(r.points[2].mrAboveUcl);
    EXPECT_TRUE(r.points[3].mrAboveUcl);
}

TEST(SpcChart, BaselineBelowTwoIsRefused)
{
    for (std::size_t baseline : {0u, 1u}) {
        try {
            spcOf(seriesOf(kTen), {baseline, RuleSet::Nelson});
            ADD_FAILURE() << "baseline " << baseline << " accepted";
        } catch (const InputError& e) {
            EXPECT_NE(std::string(e.what()).find("baseline must be at least 2"), std::string::npos) << e.what();
        }
    }
}

TEST(SpcRules, ParseAndName)
{
    EXPECT_EQ(parseRuleSet("nelson"), RuleSet::Nelson);
    EXPECT_EQ(parseRuleSet("western_electric"), RuleSet::WesternElectric);
    EXPECT_EQ(hg::enumName(RuleSet::Nelson), "nelson");
    EXPECT_EQ(hg::enumName(RuleSet::WesternElectric), "western_electric");
    try {
        parseRuleSet("foo");
        ADD_FAILURE() << "foo accepted";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("'foo'"), std::string::npos) << e.what();
    }
}

TEST(SpcRules, TestedNames)
{
    const auto nelson = unitChart({0.5});
    EXPECT_EQ(nelson.tested, (std::vector<std::string>{"nelson_1", "nelson_2", "nelson_3", "nelson_4", "nelson_5",
                                                       "nelson_6", "nelson_7", "nelson_8"}));
    EXPECT_TRUE(nelson.notTested.empty());
    const auto we = unitChart({0.5}, RuleSet::WesternElectric);
    EXPECT_EQ(we.tested, (std::vector<std::string>{"we_1", "we_2", "we_3", "we_4"}));
}

TEST(SpcRules, Nelson1OnePointBeyondThreeSigma)
{
    const auto r = unitChart({0.5, 3.5, -3.5});
    const auto found = violationsOf(r, "nelson_1");
    ASSERT_EQ(found.size(), 2u);
    EXPECT_EQ(found[0].point, 3u);
    EXPECT_EQ(found[0].points, std::vector<std::size_t>{3});
    EXPECT_EQ(found[0].direction, Direction::Up);
    EXPECT_EQ(found[1].point, 4u);
    EXPECT_EQ(found[1].direction, Direction::Down);
    // At 3σ exactly is not beyond it.
    expectNone(unitChart({0.5, 3.0, -3.0, 2.9}), "nelson_1");
}

TEST(SpcRules, Nelson2NineOnOneSide)
{
    // Index 2 below, 3 … 11 above: the ninth above completes it.
    expectOne(unitChart(std::vector<double>{-0.5} + repeated(9, 0.5)), "nelson_2", 11, range(3, 11), Direction::Up);
    expectNone(unitChart(std::vector<double>{-0.5} + repeated(8, 0.5)), "nelson_2");
    // Index 1 (+0.564) and 2 above, 3 … 11 below.
    expectOne(unitChart(std::vector<double>{0.5} + repeated(9, -0.5)), "nelson_2", 11, range(3, 11), Direction::Down);
}

TEST(SpcRules, Nelson3SixSteadilyIncreasingOrDecreasing)
{
    // Index 1 → 2 falls (0.564 → 0.0), then five rises: points 2 … 7.
    expectOne(unitChart({0.0, 0.1, 0.2, 0.3, 0.4, 0.5}), "nelson_3", 7, range(2, 7), Direction::Up);
    expectNone(unitChart({0.0, 0.1, 0.2, 0.3, 0.4}), "nelson_3");
    // 0.564 (index 1) → 0.5 → … → 0.1 (index 6): five falls.
    expectOne(unitChart({0.5, 0.4, 0.3, 0.2, 0.1}), "nelson_3", 6, range(1, 6), Direction::Down);
    expectNone(unitChart({0.5, 0.4, 0.3, 0.2}), "nelson_3");
    // Two equal values are no step: the rise stops there.
    expectNone(unitChart({0.0, 0.1, 0.2, 0.2, 0.3, 0.4, 0.5}), "nelson_3");
}

TEST(SpcRules, Nelson4FourteenAlternating)
{
    // −0.564, +0.564, −0.5, +0.5, …: up and down from the first point; 14 points end at index 13.
    expectOne(unitChart(alternating(12, 0.5)), "nelson_4", 13, range(0, 13), std::nullopt);
    expectNone(unitChart(alternating(11, 0.5)), "nelson_4");
    // A repeated value (no step) in the middle breaks the alternation.
    auto broken = alternating(12, 0.5);
    broken.insert(broken.begin() + 6, broken[5]);
    expectNone(unitChart(broken), "nelson_4");
}

TEST(SpcRules, Nelson5TwoOfThreeBeyondTwoSigma)
{
    expectOne(unitChart({2.5, 0.5, 2.5}), "nelson_5", 4, {2, 4}, Direction::Up);
    expectNone(unitChart({2.5, 0.5, 0.5, 2.5}), "nelson_5");
    expectOne(unitChart({-2.5, -2.5}), "nelson_5", 3, {2, 3}, Direction::Down);
    expectNone(unitChart({2.5, -2.5}), "nelson_5"); // not on the same side
}

TEST(SpcRules, Nelson6FourOfFiveBeyondOneSigma)
{
    expectOne(unitChart({1.5, 1.5, 0.5, 1.5, 1.5}), "nelson_6", 6, {2, 3, 5, 6}, Direction::Up);
    expectNone(unitChart({1.5, 1.5, 0.5, 1.5}), "nelson_6");
    expectNone(unitChart({1.5, 1.5, 0.5, 0.5, 1.5, 1.5}), "nelson_6"); // three of five
    expectOne(unitChart({-1.5, -1.5, -1.5, -1.5}), "nelson_6", 5, {2, 3, 4, 5}, Direction::Down);
}

TEST(SpcRules, Nelson7FifteenWithinOneSigma)
{
    // Index 2 (2.0) leaves zone C; 3 … 17 are within 1σ, one of them on the centre line.
    auto inside = alternating(15, 0.3);
    inside[2] = 0.0;
    expectOne(unitChart(std::vector<double>{2.0} + inside), "nelson_7", 17, range(3, 17), std::nullopt);
    inside.pop_back();
    expectNone(unitChart(std::vector<double>{2.0} + inside), "nelson_7");
}

TEST(SpcRules, Nelson8EightBeyondOneSigmaOnEitherSide)
{
    // Index 1 (+0.564) is within 1σ; 2 … 9 alternate ±1.5.
    expectOne(unitChart(alternating(8, 1.5)), "nelson_8", 9, range(2, 9), std::nullopt);
    expectNone(unitChart(alternating(7, 1.5)), "nelson_8");
    auto broken = alternating(8, 1.5);
    broken[4] = 0.9;
    expectNone(unitChart(broken), "nelson_8");
}

TEST(SpcRules, WesternElectricRules)
{
    const auto we = RuleSet::WesternElectric;
    expectOne(unitChart({0.5, 3.5}, we), "we_1", 3, {3}, Direction::Up);
    expectNone(unitChart({0.5, 2.9}, we), "we_1");
    expectOne(unitChart({2.5, 0.5, 2.5}, we), "we_2", 4, {2, 4}, Direction::Up);
    expectNone(unitChart({2.5, 0.5, 0.5, 2.5}, we), "we_2");
    expectOne(unitChart({1.5, 1.5, 0.5, 1.5, 1.5}, we), "we_3", 6, {2, 3, 5, 6}, Direction::Up);
    expectNone(unitChart({1.5, 1.5, 0.5, 1.5}, we), "we_3");
    // Index 2 below, 3 … 10 above.
    expectOne(unitChart(std::vector<double>{-0.5} + repeated(8, 0.5), we), "we_4", 10, range(3, 10), Direction::Up);
    expectNone(unitChart(std::vector<double>{-0.5} + repeated(7, 0.5), we), "we_4");
    // The Nelson names are not in this set.
    for (const auto& v : unitChart(std::vector<double>{-0.5} + repeated(9, 0.5), we).violations)
        EXPECT_EQ(v.rule.rfind("we_", 0), 0u) << v.rule;
}

TEST(SpcRules, APointOnTheCentreLineBreaksARun)
{
    // Index 2 below; 3 … 6 above, 7 on the CL, 8 … 12 above: runs of 4 and 5, never 9.
    const auto onCl = std::vector<double>{-0.5} + repeated(4, 0.5) + std::vector<double>{0.0} + repeated(5, 0.5);
    expectNone(unitChart(onCl), "nelson_2");
    expectNone(unitChart(onCl, RuleSet::WesternElectric), "we_4");
    // 0.1 instead of 0.0: 3 … 12 are ten above, the ninth and the tenth each complete nine.
    const auto above = std::vector<double>{-0.5} + repeated(4, 0.5) + std::vector<double>{0.1} + repeated(5, 0.5);
    const auto found = violationsOf(unitChart(above), "nelson_2");
    ASSERT_EQ(found.size(), 2u);
    EXPECT_EQ(found[0].points, range(3, 11));
    EXPECT_EQ(found[1].points, range(4, 12));
    // Western Electric 4 the same way: 3 … 11 above (nine), at 10 and 11.
    const auto weAbove = std::vector<double>{-0.5} + repeated(4, 0.5) + std::vector<double>{0.1} + repeated(4, 0.5);
    const auto we = violationsOf(unitChart(weAbove, RuleSet::WesternElectric), "we_4");
    ASSERT_EQ(we.size(), 2u);
    EXPECT_EQ(we[0].point, 10u);
    EXPECT_EQ(we[1].point, 11u);
}

TEST(SpcRules, ViolationsInPointOrder)
{
    // 3.5 at index 2 completes nelson_1; 2.5 at 3 then nelson_5 (2 and 3 beyond 2σ).
    const auto r = unitChart({3.5, 2.5});
    ASSERT_GE(r.violations.size(), 2u);
    for (std::size_t i = 1; i < r.violations.size(); ++i) EXPECT_LE(r.violations[i - 1].point, r.violations[i].point);
    EXPECT_EQ(r.violations.front().rule, "nelson_1");
}

TEST(SpcRules, EqualBaselineValuesTestNone)
{
    // Baseline 0.2 0.2 0.2: MR̄ = 0, σ_within = 0: no zones, no rule; the limits collapse on the CL.
    const auto r = spcOf(seriesOf({0.2, 0.2, 0.2, 0.5, 0.1}), {3, RuleSet::Nelson});
    ASSERT_TRUE(r.evaluated);
    EXPECT_EQ(r.sigmaWithin, 0.0);
    EXPECT_TRUE(r.tested.empty());
    EXPECT_FALSE(r.notTested.empty());
    EXPECT_TRUE(r.violations.empty());
    EXPECT_EQ(r.iChart.ucl, 0.2);
    EXPECT_EQ(r.iChart.lcl, 0.2);
    EXPECT_TRUE(r.points[3].mrAboveUcl); // 0.3 above an MR limit of 0
    const auto j = toJson(r);
    EXPECT_TRUE(j["rules"]["not_tested"].is_string());
    EXPECT_EQ(j["rules"]["tested"], nlohmann::json::array());
}

TEST(SpcCapability, ByHand)
{
    // x̄ = 0.12, σ_within = 0.0187155 (above); Σ(x − x̄)² = (4+0+1+4+0+1+4+0+1+9)·1e-4 = 0.0024,
    // s = sqrt(0.0024 / 9) = 0.0163299. Zone [0, 0.3]:
    // Cp = 0.3 / (6·0.0187155) = 0.3·1.128·9 / (6·0.19) = 3.0456 / 1.14 = 2.671579;
    // Cpk = min(0.18, 0.12) / (3·0.0187155) = 0.12·1.128·9 / 0.57 = 1.21824 / 0.57 = 2.137263;
    // Pp = 0.3 / (6·0.0163299) = 0.3 / 0.0979796 = 3.061862; Ppk = 0.12 / 0.0489898 = 2.449490.
    const auto c = spcOf(seriesOf(kTen), {}).capability;
    EXPECT_NEAR(c.mean, 0.12, 1e-12);
    EXPECT_NEAR(c.sigmaWithin, 0.0187155, 1e-7);
    EXPECT_NEAR(c.stddev, 0.0163299, 1e-7);
    ASSERT_TRUE(c.cp && c.cpk && c.pp && c.ppk);
    EXPECT_NEAR(*c.cp, 2.671579, 1e-6);
    EXPECT_NEAR(*c.cpk, 2.137263, 1e-6);
    EXPECT_NEAR(*c.pp, 3.061862, 1e-6);
    EXPECT_NEAR(*c.ppk, 2.449490, 1e-6);
}

TEST(SpcCapability, OneSidedZone)
{
    // Upper limit 0.3 only: USL − x̄ = 0.18; Cpk = 0.18·1.128·9 / 0.57 = 1.82736 / 0.57 = 3.205895,
    // Ppk = 0.18 / 0.0489898 = 3.674235; no Cp, Pp.
    const auto upper = spcOf(seriesOf(kTen, {-kInf, 0.3}), {});
    ASSERT_TRUE(upper.evaluated);
    EXPECT_FALSE(upper.capability.cp);
    EXPECT_FALSE(upper.capability.pp);
    ASSERT_TRUE(upper.capability.cpk && upper.capability.ppk);
    EXPECT_NEAR(*upper.capability.cpk, 3.205895, 1e-6);
    EXPECT_NEAR(*upper.capability.ppk, 3.674235, 1e-6);
    const auto j = toJson(upper);
    EXPECT_TRUE(j["zone_mm"][0].is_null());
    EXPECT_EQ(j["zone_mm"][1], 0.3);
    EXPECT_TRUE(j["capability"]["cp"].is_null());
    // Lower limit 0 only: x̄ − LSL = 0.12, Cpk = 2.137263 as above.
    const auto lower = spcOf(seriesOf(kTen, {0.0, kInf}), {});
    ASSERT_TRUE(lower.capability.cpk);
    EXPECT_NEAR(*lower.capability.cpk, 2.137263, 1e-6);
    EXPECT_EQ(lower.yield.within, 10u);
}

TEST(SpcCapability, NoSpreadGivesNoIndex)
{
    const auto r = spcOf(seriesOf(repeated(5, 0.2), {0.0, 0.4}), {});
    ASSERT_TRUE(r.evaluated);
    EXPECT_EQ(r.capability.sigmaWithin, 0.0);
    EXPECT_EQ(r.capability.stddev, 0.0);
    EXPECT_FALSE(r.capability.cp || r.capability.cpk || r.capability.pp || r.capability.ppk);
    const auto j = toJson(r);
    for (const char* key : {"cp", "cpk", "pp", "ppk"}) EXPECT_TRUE(j["capability"][key].is_null()) << key;
}

TEST(SpcYield, LimitsIncluded)
{
    // −0.1 and 0.1 are on the limits and count; 0.2 and −0.3 are outside: 3 of 5.
    const auto y = spcOf(seriesOf({-0.1, 0.0, 0.1, 0.2, -0.3}, {-0.1, 0.1}), {}).yield;
    EXPECT_EQ(y.within, 3u);
    EXPECT_EQ(y.n, 5u);
    EXPECT_DOUBLE_EQ(y.fraction, 0.6);
}

TEST(SpcHistogram, SturgesBinsOverDataAndLimits)
{
    const std::vector<double> eight{1, 2, 3, 4, 5, 6, 7, 8}; // n = 8: ⌈log2 8⌉ + 1 = 4 bins
    // Zone [0, 10] around the data: width 2.5; [0, 2.5) 1 2, [2.5, 5) 3 4, [5, 7.5) 5 6 7, [7.5, 10] 8.
    const auto wide = spcOf(seriesOf(eight, {0.0, 10.0}), {}).histogram;
    EXPECT_EQ(wide.method, "sturges");
    EXPECT_EQ(wide.edges, (std::vector<double>{0.0, 2.5, 5.0, 7.5, 10.0}));
    EXPECT_EQ(wide.counts, (std::vector<std::size_t>{2, 2, 3, 1}));
    // Zone [2, 5] inside the data: the data span [1, 8], width 1.75; the largest value in the last bin.
    const auto narrow = spcOf(seriesOf(eight, {2.0, 5.0}), {}).histogram;
    EXPECT_EQ(narrow.edges, (std::vector<double>{1.0, 2.75, 4.5, 6.25, 8.0}));
    EXPECT_EQ(narrow.counts, (std::vector<std::size_t>{2, 2, 2, 2}));
    // Upper limit 10 only: [1, 10], width 2.25; [1, 3.25) 1 2 3, [3.25, 5.5) 4 5, [5.5, 7.75) 6 7, 8.
    const auto oneSided = spcOf(seriesOf(eight, {-kInf, 10.0}), {}).histogram;
    EXPECT_EQ(oneSided.edges, (std::vector<double>{1.0, 3.25, 5.5, 7.75, 10.0}));
    EXPECT_EQ(oneSided.counts, (std::vector<std::size_t>{3, 2, 2, 1}));
}

TEST(SpcHistogram, CountsSumToNAndEdgesCoverTheLimits)
{
    // n = 10: ⌈log2 10⌉ + 1 = 5 bins; zone [0, 0.3] beyond the data on both sides.
    const auto r = spcOf(seriesOf(kTen), {});
    const auto& h = r.histogram;
    ASSERT_EQ(h.counts.size(), 5u);
    ASSERT_EQ(h.edges.size(), 6u);
    std::size_t sum = 0;
    for (auto c : h.counts) sum += c;
    EXPECT_EQ(sum, 10u);
    EXPECT_LE(h.edges.front(), 0.0);
    EXPECT_GE(h.edges.back(), 0.3);
    // All equal values, no finite limit beside them: still an axis of positive width.
    const auto flat = spcOf(seriesOf(repeated(3, 0.2), {-kInf, kInf}), {}).histogram;
    EXPECT_LT(flat.edges.front(), 0.2);
    EXPECT_GT(flat.edges.back(), 0.2);
    // n = 3: 3 bins over [0.199, 0.201], the value in the middle one.
    EXPECT_EQ(flat.counts, (std::vector<std::size_t>{0, 3, 0}));
}

TEST(SpcNotEvaluated, ProblemOrTooFewValues)
{
    auto problem = seriesOf({});
    problem.serials = {"S1"};
    problem.problem = "cycle 8 reports it not_found";
    const auto p = spcOf(problem, {});
    EXPECT_FALSE(p.evaluated);
    EXPECT_EQ(p.notEvaluated, "cycle 8 reports it not_found");
    EXPECT_TRUE(p.points.empty());

    const auto one = spcOf(seriesOf({0.1}), {});
    EXPECT_FALSE(one.evaluated);
    EXPECT_EQ(one.notEvaluated, "fewer than 2 values");
    ASSERT_EQ(one.points.size(), 1u);
    EXPECT_FALSE(one.points[0].movingRange);
    EXPECT_EQ(spcOf(seriesOf({}), {}).notEvaluated, "fewer than 2 values");

    const auto j = toJson(one);
    EXPECT_EQ(j["evaluated"], false);
    EXPECT_EQ(j["not_evaluated"], "fewer than 2 values");
    EXPECT_EQ(j["n"], 1);
    EXPECT_EQ(j["id"], "bore");
    for (const char* key : {"baseline", "i_chart", "mr_chart", "rules", "capability", "yield", "histogram"})
        EXPECT_TRUE(j[key].is_null()) << key;
    EXPECT_EQ(j["points"][0]["value_mm"], 0.1);
    EXPECT_TRUE(j["points"][0]["moving_range_mm"].is_null());
}

std::set<std::string> keysOf(const nlohmann::json& j)
{
    std::set<std::string> keys;
    for (const auto& [k, v] : j.items()) keys.insert(k);
    return keys;
}

/// Every number in `j` is finite (nlohmann would write ±∞ and NaN as null, silently).
void expectFinite(const nlohmann::json& j, const std::string& where)
{
    if (j.is_number_float()) {
        EXPECT_TRUE(std::isfinite(j.get<double>())) << where;
    }
    if (j.is_object())
        for (const auto& [k, v] : j.items()) expectFinite(v, where + "." + k);
    if (j.is_array())
        for (std::size_t i = 0; i < j.size(); ++i) expectFinite(j[i], where + "[" + std::to_string(i) + "]");
}

TEST(SpcJson, KeysAndValues)
{
    auto series = seriesOf(kTen);
    series.source = ValueSource::BracketMiddle;
    const auto j = toJson(spcOf(series, {}));
    EXPECT_EQ(keysOf(j), (std::set<std::string>{"id", "values", "zone_mm", "n", "evaluated", "not_evaluated",
                                                "baseline", "constants", "i_chart", "mr_chart", "points", "gaps",
                                                "rules", "capability", "yield", "histogram"}));
    EXPECT_EQ(j["values"], "error_mm");
    EXPECT_EQ(j["zone_mm"], (nlohmann::json{0.0, 0.3}));
    EXPECT_TRUE(j["not_evaluated"].is_null());
    EXPECT_EQ(j["baseline"], (nlohmann::json{{"requested", 25}, {"used", 10}, {"short", true}}));
    EXPECT_EQ(j["constants"], (nlohmann::json{{"d2", 1.128}, {"D4", 3.267}}));
    EXPECT_EQ(keysOf(j["i_chart"]), (std::set<std::string>{"centre_mm", "ucl_mm", "lcl_mm", "sigma_within_mm"}));
    EXPECT_NEAR(j["i_chart"]["ucl_mm"].get<double>(), 0.1761466, 1e-7);
    EXPECT_EQ(keysOf(j["mr_chart"]), (std::set<std::string>{"centre_mm", "ucl_mm", "lcl_mm"}));
    EXPECT_EQ(keysOf(j["points"][0]), (std::set<std::string>{"index", "cycle", "serial", "value_mm", "moving_range_mm",
                                                             "mr_above_ucl", "rules"}));
    EXPECT_EQ(j["points"][4]["serial"], "S4");
    EXPECT_EQ(keysOf(j["rules"]), (std::set<std::string>{"set", "tested", "not_tested", "violations"}));
    EXPECT_EQ(j["rules"]["set"], "nelson");
    EXPECT_TRUE(j["rules"]["not_tested"].is_null());
    EXPECT_EQ(keysOf(j["capability"]),
              (std::set<std::string>{"mean_mm", "sigma_within_mm", "stddev_mm", "cp", "cpk", "pp", "ppk"}));
    EXPECT_EQ(j["yield"], (nlohmann::json{{"within", 10}, {"n", 10}, {"fraction", 1.0}}));
    EXPECT_EQ(keysOf(j["histogram"]), (std::set<std::string>{"method", "bins", "edges_mm", "counts"}));
    EXPECT_EQ(j["histogram"]["bins"], 5);
    EXPECT_EQ(toJson(spcOf(seriesOf(kTen), {}))["values"], "deviation_mm");
}

TEST(SpcJson, Violations)
{
    const auto j = toJson(unitChart({0.5, 3.5, -0.5}, RuleSet::WesternElectric));
    const auto& v = j["rules"]["violations"];
    ASSERT_EQ(v.size(), 1u);
    EXPECT_EQ(v[0], (nlohmann::json{
                        {"rule", "we_1"}, {"point", 3}, {"points", nlohmann::json::array({3})}, {"direction", "up"}}));
    EXPECT_EQ(j["points"][3]["rules"], nlohmann::json::array({"we_1"}));
    const auto two = toJson(unitChart(alternating(8, 1.5)));
    bool sawNelson8 = false;
    for (const auto& e : two["rules"]["violations"]) {
        if (e["rule"] != "nelson_8") continue;
        sawNelson8 = true;
        EXPECT_TRUE(e["direction"].is_null());
    }
    EXPECT_TRUE(sawNelson8);
}

TEST(SpcJson, NoInfiniteOrNanAnywhere)
{
    expectFinite(toJson(spcOf(seriesOf(kTen, {-kInf, 0.3}), {})), "upper only");
    expectFinite(toJson(spcOf(seriesOf(kTen, {0.0, kInf}), {})), "lower only");
    expectFinite(toJson(spcOf(seriesOf(repeated(5, 0.2), {-kInf, kInf}), {})), "no spread, no limits");
    expectFinite(toJson(spcOf(seriesOf({0.2, 0.2, 0.2, 0.5}), {3, RuleSet::Nelson})), "equal baseline");
    expectFinite(toJson(spcOf(seriesOf({0.1}, {-kInf, 0.3}), {})), "one value");
    const auto dumped = toJson(spcOf(seriesOf(repeated(5, 0.2), {-kInf, 0.3}), {})).dump();
    EXPECT_EQ(dumped.find("inf"), std::string::npos) << dumped;
    EXPECT_EQ(dumped.find("nan"), std::string::npos) << dumped;
}

} // namespace
} // namespace hg::study

namespace hg::study {
namespace {

nlohmann::json reading(const std::string& status, double deviation)
{
    nlohmann::json j{{"id", "bore"}, {"status", status}, {"error_mm", deviation}, {"tolerance_mm", 0.3}};
    if (status == "ok") j["deviation_mm"] = deviation;
    return j;
}

/// Seven cycles S0..S6 of landmark bore: 0.10, 0.12, not_found, 0.11, 0.14,
/// (bore not listed), 0.12 mm.
std::vector<StudyRecord> withGaps()
{
    const auto one = [](double v) { return nlohmann::json::array({reading("ok", v)}); };
    return {{1, "S0", one(0.10)}, {2, "S1", one(0.12)}, {3, "S2", nlohmann::json::array({reading("not_found", 0.0)})},
            {4, "S3", one(0.11)}, {5, "S4", one(0.14)}, {6, "S5", nlohmann::json::array()},
            {7, "S6", one(0.12)}};
}

TEST(SpcGaps, AStudyRefusesACycleWithoutAValueAChartShowsItAsAGap)
{
    const auto refused = collectSeries(withGaps());
    ASSERT_EQ(refused.size(), 1u);
    EXPECT_NE(refused[0].problem.find("reports it not_found"), std::string::npos) << refused[0].problem;

    const auto series = collectSeries(withGaps(), MissingValues::Gap);
    ASSERT_EQ(series.size(), 1u);
    const auto& s = series[0];
    EXPECT_TRUE(s.problem.empty()) << s.problem;
    EXPECT_EQ(s.values, (std::vector<double>{0.10, 0.12, 0.11, 0.14, 0.12}));
    EXPECT_EQ(s.cycles, (std::vector<std::size_t>{0, 1, 3, 4, 6}));
    EXPECT_EQ(s.serials, (std::vector<std::string>{"S0", "S1", "S3", "S4", "S6"}));
    ASSERT_EQ(s.gaps.size(), 2u);
    EXPECT_EQ(s.gaps[0].cycle, 2u);
    EXPECT_EQ(s.gaps[0].serial, "S2");
    EXPECT_EQ(s.gaps[0].reason, "not_found");
    EXPECT_EQ(s.gaps[1].cycle, 5u);
    EXPECT_EQ(s.gaps[1].reason, "absent");
}

TEST(SpcGaps, NoMovingRangeSpansAGap)
{
    // Moving ranges only between neighbouring cycles: S1−S0 = 0.02, S4−S3 = 0.03
    // (S3 follows the gap at cycle 2, S6 the gap at 5). MR̄ = 0.025,
    // σ_within = 0.025 / 1.128 = 0.0221631, CL = (0.10 + 0.12 + 0.11 + 0.14 + 0.12) / 5 = 0.118,
    // UCL = 0.118 + 3 · 0.0221631 = 0.1844894, LCL = 0.0515106, MR UCL = 3.267 · 0.025 = 0.081675.
    const auto r = spcOf(collectSeries(withGaps(), MissingValues::Gap)[0], {5, RuleSet::Nelson});
    ASSERT_TRUE(r.evaluated) << r.notEvaluated;
    ASSERT_EQ(r.points.size(), 5u);
    EXPECT_FALSE(r.points[0].movingRange);
    EXPECT_NEAR(r.points[1].movingRange.value_or(-1), 0.02, 1e-12);
    EXPECT_FALSE(r.points[2].movingRange);
    EXPECT_NEAR(r.points[3].movingRange.value_or(-1), 0.03, 1e-12);
    EXPECT_FALSE(r.points[4].movingRange);
    EXPECT_EQ(r.points[2].cycle, 3u);
    EXPECT_EQ(r.points[4].cycle, 6u);
    EXPECT_NEAR(r.mrChart.centre, 0.025, 1e-12);
    EXPECT_NEAR(r.sigmaWithin, 0.0221631, 1e-7);
    EXPECT_NEAR(r.iChart.centre, 0.118, 1e-12);
    EXPECT_NEAR(r.iChart.ucl, 0.1844894, 1e-7);
    EXPECT_NEAR(r.iChart.lcl, 0.0515106, 1e-7);
    EXPECT_NEAR(r.mrChart.ucl, 0.081675, 1e-9);
    // Capability's σ_within over all values: the same two ranges.
    EXPECT_NEAR(r.capability.sigmaWithin, 0.0221631, 1e-7);

    const auto j = toJson(r);
    ASSERT_EQ(j["gaps"].size(), 2u);
    EXPECT_EQ(j["gaps"][0], (nlohmann::json{{"cycle", 2}, {"serial", "S2"}, {"reason", "not_found"}}));
    EXPECT_EQ(j["points"][2]["cycle"], 3);
    EXPECT_TRUE(j["points"][2]["moving_range_mm"].is_null());
}

TEST(SpcGaps, ABaselineWithoutNeighbouringValuesIsNotEvaluated)
{
    LandmarkSeries s = seriesOf({0.10, 0.12, 0.11});
    s.cycles = {0, 2, 4};
    s.gaps = {{1, "G1", "not_found"}, {3, "G3", "not_observable"}};
    const auto r = spcOf(s, {3, RuleSet::Nelson});
    EXPECT_FALSE(r.evaluated);
    EXPECT_NE(r.notEvaluated.find("no moving range"), std::string::npos) << r.notEvaluated;
    EXPECT_EQ(toJson(r)["gaps"].size(), 2u);
    EXPECT_TRUE(toJson(r)["i_chart"].is_null());
}

} // namespace
} // namespace hg::study
