// The Pareto of what fails (docs/spc.md, "Pareto") on records counted by hand.
#include "hullgauge/study/pareto.h"

#include "hullgauge/common/error.h"

#include <gtest/gtest.h>

namespace hg::study {
namespace {

nlohmann::json entry(const std::string& id, const std::string& status)
{
    return {{"id", id}, {"status", status}, {"error_mm", 0.0}, {"tolerance_mm", 0.1}};
}

/// Seven cycles: a pass; three fails (A out of tolerance twice, B not found
/// and out of tolerance, C overflow); a camera timeout (10) twice, an abort by
/// the PLC (40) once and a fixture timeout (20) once.
std::vector<ParetoRecord> cycles()
{
    using nlohmann::json;
    return {{1, "pass", 0, json::array({entry("A", "ok"), entry("B", "ok"), entry("C", "ok")})},
            {2, "fail", 0, json::array({entry("A", "out_of_tolerance"), entry("B", "not_found"), entry("C", "ok")})},
            {3, "fail", 0, json::array({entry("A", "out_of_tolerance"), entry("B", "ok"), entry("C", "overflow")})},
            {4, "fail", 0, json::array({entry("A", "ok"), entry("B", "out_of_tolerance"), entry("C", "ok")})},
            {5, "error", 10, json::array()},
            {6, "aborted", 40, json::array()},
            {7, "error", 10, json::array()},
            {8, "error", 20, json::array()}};
}

TEST(Pareto, CountsFailedReadingsAndFaultsMostFirst)
{
    const auto p = paretoOf(cycles());
    EXPECT_EQ(p.cycles, 8u);
    EXPECT_EQ(p.failedCycles, 3u);
    EXPECT_EQ(p.faultedCycles, 4u);
    // Failed readings: A 2, B 2, C 1 — 5 in all; A and B tie and go by id.
    ASSERT_EQ(p.landmarks.size(), 3u);
    EXPECT_EQ(p.landmarks[0].key, "A");
    EXPECT_EQ(p.landmarks[0].count, 2u);
    EXPECT_NEAR(p.landmarks[0].cumulativeShare, 2.0 / 5.0, 1e-12);
    EXPECT_EQ(p.landmarks[0].byStatus, (std::map<std::string, std::size_t>{{"out_of_tolerance", 2}}));
    EXPECT_EQ(p.landmarks[1].key, "B");
    EXPECT_EQ(p.landmarks[1].byStatus, (std::map<std::string, std::size_t>{{"not_found", 1}, {"out_of_tolerance", 1}}));
    EXPECT_NEAR(p.landmarks[1].cumulativeShare, 4.0 / 5.0, 1e-12);
    EXPECT_EQ(p.landmarks[2].key, "C");
    EXPECT_NEAR(p.landmarks[2].cumulativeShare, 1.0, 1e-12);
    // Faults: 10 twice, then 20 and 40 once each, in the codes' numeric order.
    ASSERT_EQ(p.faults.size(), 3u);
    EXPECT_EQ(p.faults[0].key, "10");
    EXPECT_EQ(p.faults[0].count, 2u);
    EXPECT_NEAR(p.faults[0].cumulativeShare, 0.5, 1e-12);
    EXPECT_EQ(p.faults[1].key, "20");
    EXPECT_EQ(p.faults[2].key, "40");
    EXPECT_NEAR(p.faults[2].cumulativeShare, 1.0, 1e-12);

    const auto j = toJson(p);
    EXPECT_EQ(j["faults"][0]["code"], 10);
    EXPECT_EQ(j["landmarks"][1]["by_status"]["not_found"], 1);
    EXPECT_EQ(j["failed_cycles"], 3);
}

TEST(Pareto, NumericCodesOrderByValueNotText)
{
    using nlohmann::json;
    const auto p = paretoOf({{1, "error", 100, json::array()}, {2, "error", 9, json::array()}});
    ASSERT_EQ(p.faults.size(), 2u);
    EXPECT_EQ(p.faults[0].key, "9");
    EXPECT_EQ(p.faults[1].key, "100");
}

TEST(Pareto, NothingFailedIsEmptyBars)
{
    const auto p = paretoOf({{1, "pass", 0, nlohmann::json::array({entry("A", "ok")})}});
    EXPECT_EQ(p.cycles, 1u);
    EXPECT_TRUE(p.landmarks.empty());
    EXPECT_TRUE(p.faults.empty());
    EXPECT_TRUE(paretoOf({}).landmarks.empty());
}

TEST(Pareto, AMalformedEntryIsNamed)
{
    using nlohmann::json;
    try {
        paretoOf({{12, "fail", 0, json::array({json{{"status", "ok"}}})}});
        FAIL() << "an entry without an id was counted";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("result 12.landmarks"), std::string::npos) << e.what();
    }
    try {
        paretoOf({{13, "fail", 0, json::array({entry("A", "broken")})}});
        FAIL() << "an unknown status was counted";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("result 13.landmarks.A"), std::string::npos) << e.what();
    }
}

} // namespace
} // namespace hg::study
