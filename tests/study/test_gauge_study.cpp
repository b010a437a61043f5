// The gauge studies (docs/study.md) on small data sets worked out by hand:
// every expected value is written with its arithmetic.
#include "hullgauge/study/gauge_study.h"

#include "hullgauge/common/error.h"

#include <gtest/gtest.h>

#include <cmath>

namespace hg::study {
namespace {

/// 12 × (c − 0.01), 12 × (c + 0.01), 1 × c: mean c, Σ(x − x̄)² = 24 · 0.0001,
/// s = sqrt(0.0024 / 24) = 0.01 exactly (n = 25).
std::vector<double> spreadAround(double c)
{
    std::vector<double> v(12, c - 0.01);
    v.insert(v.end(), 12, c + 0.01);
    v.push_back(c);
    return v;
}

TEST(Type1, CapableMasterAtItsNominal)
{
    // T = 0.8 (±0.4), x̄ = 0, s = 0.01: Cg = 0.2·0.8 / (6·0.01) = 0.16 / 0.06 = 2.6667,
    // Cgk = (0.1·0.8 − 0) / (3·0.01) = 0.08 / 0.03 = 2.6667.
    const auto r = type1(spreadAround(0.0), 0.8, 0.0);
    ASSERT_TRUE(r.evaluated) << r.notEvaluated;
    EXPECT_EQ(r.n, 25u);
    EXPECT_NEAR(r.mean, 0.0, 1e-12);
    EXPECT_NEAR(r.stddev, 0.01, 1e-12);
    EXPECT_NEAR(r.cg, 2.666667, 1e-6);
    EXPECT_NEAR(r.cgk, 2.666667, 1e-6);
    EXPECT_TRUE(r.capable);
}

TEST(Type1, BiasAgainstTheReferenceLowersCgkOnly)
{
    // x̄ = 0.02, x_ref = 0.005: bias 0.015; s = 0.01, T = 0.8:
    // Cg = 0.16 / 0.06 = 2.6667, Cgk = (0.08 − 0.015) / 0.03 = 0.065 / 0.03 = 2.1667.
    const auto r = type1(spreadAround(0.02), 0.8, 0.005);
    ASSERT_TRUE(r.evaluated);
    EXPECT_NEAR(r.bias, 0.015, 1e-12);
    EXPECT_NEAR(r.cg, 2.666667, 1e-6);
    EXPECT_NEAR(r.cgk, 2.166667, 1e-6);
    EXPECT_TRUE(r.capable);
}

TEST(Type1, NarrowToleranceIsNotCapable)
{
    // T = 0.1, x̄ = 0.02, s = 0.01: Cg = 0.02 / 0.06 = 0.3333,
    // Cgk = (0.01 − 0.02) / 0.03 = −0.3333.
    const auto r = type1(spreadAround(0.02), 0.1, 0.0);
    ASSERT_TRUE(r.evaluated);
    EXPECT_NEAR(r.cg, 0.333333, 1e-6);
    EXPECT_NEAR(r.cgk, -0.333333, 1e-6);
    EXPECT_FALSE(r.capable);
}

TEST(Type1, FiveValuesWithTheMinimumLowered)
{
    // 0.01 … 0.05: x̄ = 0.03, Σ(x − x̄)² = 0.0004 + 0.0001 + 0 + 0.0001 + 0.0004 = 0.001,
    // s = sqrt(0.001 / 4) = 0.0158114; T = 0.4:
    // Cg = 0.08 / (6·0.0158114) = 0.08 / 0.0948683 = 0.843274,
    // Cgk = (0.04 − 0.03) / (3·0.0158114) = 0.01 / 0.0474342 = 0.210819.
    Limits limits;
    limits.minType1Values = 5;
    const auto r = type1({0.01, 0.02, 0.03, 0.04, 0.05}, 0.4, 0.0, limits);
    ASSERT_TRUE(r.evaluated);
    EXPECT_NEAR(r.stddev, 0.0158114, 1e-7);
    EXPECT_NEAR(r.cg, 0.843274, 1e-6);
    EXPECT_NEAR(r.cgk, 0.210819, 1e-6);
    EXPECT_FALSE(r.capable);
}

TEST(Type1, FewerThan25ValuesAreNotEvaluated)
{
    auto values = spreadAround(0.0);
    values.pop_back();
    const auto r = type1(values, 0.8, 0.0);
    EXPECT_FALSE(r.evaluated);
    EXPECT_EQ(r.n, 24u);
    EXPECT_NE(r.notEvaluated.find("24 values"), std::string::npos) << r.notEvaluated;
    EXPECT_NE(r.notEvaluated.find("25"), std::string::npos) << r.notEvaluated;
    EXPECT_FALSE(toJson(r).contains("cg"));
}

TEST(Type1, NoSpreadIsUnboundedNotADivisionByZero)
{
    // s = 0: Cg = +∞; Cgk = +∞ while |bias| < 0.1·T, −∞ beyond.
    const auto inside = type1(std::vector<double>(25, 0.01), 0.8, 0.0);
    ASSERT_TRUE(inside.evaluated);
    EXPECT_EQ(inside.stddev, 0.0);
    EXPECT_TRUE(std::isinf(inside.cg) && inside.cg > 0);
    EXPECT_TRUE(std::isinf(inside.cgk) && inside.cgk > 0);
    EXPECT_TRUE(inside.capable);
    EXPECT_EQ(toJson(inside)["cg"], "inf");

    const auto beyond = type1(std::vector<double>(25, 0.1), 0.8, 0.0); // 0.08 − 0.1 < 0
    EXPECT_TRUE(std::isinf(beyond.cgk) && beyond.cgk < 0);
    EXPECT_FALSE(beyond.capable);
    EXPECT_EQ(toJson(beyond)["cgk"], "-inf");
}

TEST(Type3, ThreePartsTwoTrials)
{
    // A 0.10 0.12 (mean 0.11), B 0.20 0.18 (0.19), C 0.30 0.31 (0.305); grand mean 1.21 / 6 = 0.201667.
    // SS_parts = 2·(0.0916667² + 0.0116667² + 0.1033333²) = 1153/30000 = 0.0384333, MS_parts = /2 = 0.0192167;
    // SS_error = 4·0.01² + 2·0.005² = 0.00045, MS_error = /(3·1) = 0.00015;
    // EV = sqrt(0.00015) = 0.0122474; PV = sqrt((0.0192167 − 0.00015) / 2) = sqrt(0.00953333) = 0.0976388;
    // TV = sqrt(0.00015 + 0.00953333) = 0.0984039; %GRR = 100·0.0122474 / 0.0984039 = 12.4461 (conditional);
    // of T = 0.8: 600·0.0122474 / 0.8 = 9.18559 (acceptable); ndc = floor(1.41·0.0976388 / 0.0122474)
    // = floor(11.2408) = 11.
    const PartTrials parts{{"A", {0.10, 0.12}}, {"B", {0.20, 0.18}}, {"C", {0.30, 0.31}}};
    const auto r = type3(parts, 0.8);
    EXPECT_EQ(r.parts, 3u);
    EXPECT_EQ(r.trials, 2u);
    EXPECT_NEAR(r.grandMean, 0.2016667, 1e-7);
    EXPECT_NEAR(r.msParts, 0.01921667, 1e-8);
    EXPECT_NEAR(r.msError, 0.00015, 1e-10);
    EXPECT_NEAR(r.ev, 0.01224745, 1e-8);
    EXPECT_NEAR(r.pv, 0.0976388, 1e-7);
    EXPECT_NEAR(r.tv, 0.0984039, 1e-7);
    ASSERT_TRUE(r.percentGrr && r.percentTolerance && r.ndc);
    EXPECT_NEAR(*r.percentGrr, 12.4461, 1e-4);
    EXPECT_NEAR(*r.percentTolerance, 9.18559, 1e-5);
    EXPECT_EQ(*r.ndc, 11);
    EXPECT_EQ(r.acceptanceVariation, Acceptance::Conditional);
    EXPECT_EQ(r.acceptanceTolerance, Acceptance::Acceptable);
    EXPECT_EQ(r.acceptance, Acceptance::Conditional);
}

TEST(Type3, PartsNoFartherApartThanTheTrialsGiveNoPartVariation)
{
    // A 0.1 0.2, B 0.2 0.1: equal means, SS_parts = 0; SS_error = 4·0.05² = 0.01, MS_error = 0.01 / 2 = 0.005;
    // PV = sqrt(max(0, (0 − 0.005) / 2)) = 0, TV = GRR = sqrt(0.005) = 0.0707107: %GRR 100, ndc 0;
    // of T = 0.8: 600·0.0707107 / 0.8 = 53.033 (not acceptable).
    const auto r = type3({{"A", {0.1, 0.2}}, {"B", {0.2, 0.1}}}, 0.8);
    EXPECT_NEAR(r.msParts, 0.0, 1e-15);
    EXPECT_NEAR(r.msError, 0.005, 1e-12);
    EXPECT_EQ(r.pv, 0.0);
    EXPECT_NEAR(*r.percentGrr, 100.0, 1e-9);
    EXPECT_NEAR(*r.percentTolerance, 53.033, 1e-3);
    EXPECT_EQ(*r.ndc, 0);
    EXPECT_EQ(r.acceptance, Acceptance::NotAcceptable);
}

TEST(Type3, AcceptanceLimits)
{
    EXPECT_EQ(grrAcceptance(10.0), Acceptance::Acceptable);
    EXPECT_EQ(grrAcceptance(10.01), Acceptance::Conditional);
    EXPECT_EQ(grrAcceptance(30.0), Acceptance::Conditional);
    EXPECT_EQ(grrAcceptance(30.01), Acceptance::NotAcceptable);
}

std::string messageOf(const PartTrials& parts)
{
    try {
        type3(parts, 0.8);
    } catch (const InputError& e) {
        return e.what();
    }
    return "accepted";
}

TEST(Type3, RefusesUnbalancedOrTooSmallLayouts)
{
    const auto unbalanced = messageOf({{"A", {0.1, 0.2, 0.3}}, {"B", {0.1, 0.2}}});
    EXPECT_NE(unbalanced.find("part 'B' has 2 trials"), std::string::npos) << unbalanced;
    EXPECT_NE(unbalanced.find("'A' 3, 'B' 2"), std::string::npos) << unbalanced;
    const auto onePart = messageOf({{"A", {0.1, 0.2}}});
    EXPECT_NE(onePart.find("at least 2 parts"), std::string::npos) << onePart;
    const auto oneTrial = messageOf({{"A", {0.1}}, {"B", {0.2}}});
    EXPECT_NE(oneTrial.find("1 trial per part"), std::string::npos) << oneTrial;
}

nlohmann::json landmark(const std::string& id, double error, std::optional<double> deviation = {})
{
    nlohmann::json j{{"id", id}, {"status", "ok"}, {"error_mm", error}, {"tolerance_mm", 0.4}};
    if (deviation) j["deviation_mm"] = *deviation;
    return j;
}

TEST(Series, DeviationWhenEveryRecordHasIt)
{
    const std::vector<StudyRecord> records{
        {1, "S1", nlohmann::json::array({landmark("a", 0.03, 0.011), landmark("b", 0.06, 0.05)})},
        {2, "S2", nlohmann::json::array({landmark("a", 0.03, 0.012), landmark("b", -0.06)})}};
    const auto series = collectSeries(records);
    ASSERT_EQ(series.size(), 2u);
    EXPECT_EQ(series[0].id, "a");
    EXPECT_EQ(series[0].source, ValueSource::Deviation);
    EXPECT_EQ(series[0].values, (std::vector<double>{0.011, 0.012}));
    EXPECT_EQ(series[0].zone, (Zone{-0.4, 0.4}));
    EXPECT_EQ(series[0].serials, (std::vector<std::string>{"S1", "S2"}));
    // One record without a deviation: the whole landmark falls back to the bracket middle.
    EXPECT_EQ(series[1].source, ValueSource::BracketMiddle);
    EXPECT_EQ(series[1].values, (std::vector<double>{0.06, -0.06}));
}

TEST(Series, AsymmetricLimitsAndMissingLandmarks)
{
    auto withLimits = landmark("a", 0.0, 0.01);
    withLimits["limits_mm"] = {-0.1, 0.3};
    auto notFound = landmark("b", 0.0);
    notFound["status"] = "not_found";
    const std::vector<StudyRecord> records{{7, "S", nlohmann::json::array({withLimits, landmark("b", 0.0)})},
                                           {8, "S", nlohmann::json::array({withLimits, notFound})},
                                           {9, "S", nlohmann::json::array({withLimits, landmark("c", 0.0)})}};
    const auto series = collectSeries(records);
    ASSERT_EQ(series.size(), 3u);
    EXPECT_EQ(series[0].zone, (Zone{-0.1, 0.3}));
    EXPECT_NEAR(series[0].zone.width(), 0.4, 1e-15);
    EXPECT_TRUE(series[0].problem.empty());
    EXPECT_EQ(series[1].problem, "cycle 8 reports it not_found");
    EXPECT_EQ(series[2].problem, "cycle 7 has no result for it");
}

TEST(Series, GroupsByPartAndChecksTheLayout)
{
    LandmarkSeries s{"a", {-0.4, 0.4}, ValueSource::Deviation, {1, 2, 3, 4}, {"P", "Q", "P", "Q"}, {}, {}, {}};
    const auto parts = groupByPart(s);
    ASSERT_EQ(parts.size(), 2u);
    EXPECT_EQ(parts[0], (std::pair<std::string, std::vector<double>>{"P", {1, 3}}));
    EXPECT_EQ(parts[1], (std::pair<std::string, std::vector<double>>{"Q", {2, 4}}));

    const auto empty = nlohmann::json::array();
    EXPECT_NO_THROW(checkType3Layout({{1, "P", empty}, {2, "Q", empty}, {3, "P", empty}, {4, "Q", empty}}));
    EXPECT_THROW(checkType3Layout({{1, "P", empty}, {2, "Q", empty}, {3, "P", empty}}), InputError);
    EXPECT_THROW(checkType3Layout({{1, "", empty}, {2, "", empty}}), InputError);
}

} // namespace
} // namespace hg::study
