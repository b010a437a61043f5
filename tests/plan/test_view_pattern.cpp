// View pattern analysis on hand-built variation lists: OR removal, AND
// combination and the exact set cover, each against a worked answer.
#include "hullgauge/plan/view_pattern.h"

#include <gtest/gtest.h>
#include <random>

namespace hg::plan {
namespace {

TEST(ViewPattern, IntersectionOfSortedSets)
{
    EXPECT_EQ(intersect({1, 3, 5, 7}, {3, 4, 5}), (PoseSet{3, 5}));
    EXPECT_EQ(intersectionSize({1, 3, 5, 7}, {3, 4, 5}), 2u);
    EXPECT_EQ(intersectionSize({}, {1}), 0u);
}

TEST(ViewPattern, AndCombinationMergesLargestIntersectionFirst)
{
    // r0 ∩ r1 = {2, 3} (2 poses), r1 ∩ r2 = {4} (1), r0 ∩ r2 = {}.
    // Largest first: r0+r1 -> {2, 3}; {2, 3} ∩ {4, 5} = {} -> stop: 2 views.
    std::vector<Requirement> reqs{{0, {{1, 2, 3}}}, {1, {{2, 3, 4}}}, {2, {{4, 5}}}};
    auto g = greedyViewPattern(reqs);
    ASSERT_EQ(g.groups.size(), 2u);
    EXPECT_TRUE(g.unserved.empty());
    EXPECT_EQ(g.groups[0].variation, (PoseSet{2, 3}));
    EXPECT_EQ(g.groups[0].landmarks, (std::vector<std::size_t>{0, 1}));
    EXPECT_EQ(g.groups[1].variation, (PoseSet{4, 5}));
}

TEST(ViewPattern, ThresholdStopsSmallIntersections)
{
    std::vector<Requirement> reqs{{0, {{1, 2, 3}}}, {1, {{3, 4}}}};
    PatternOptions o;
    o.minIntersection = 2;
    EXPECT_EQ(greedyViewPattern(reqs, o).groups.size(), 2u);
    o.minIntersection = 1;
    EXPECT_EQ(greedyViewPattern(reqs, o).groups.size(), 1u);
}

TEST(ViewPattern, OrRedundancyKeepsTheSubViewThatMeetsOthers)
{
    // Landmark 0 may be seen from {1} or from {5, 6}; landmark 1 needs {6, 7}.
    // The OR sub-view {5, 6} meets {6, 7}: it is kept, {1} dropped, and the
    // AND step merges both into one view at pose 6.
    std::vector<Requirement> reqs{{0, {{1}, {5, 6}}}, {1, {{6, 7}}}};
    auto g = greedyViewPattern(reqs);
    ASSERT_EQ(g.groups.size(), 1u);
    EXPECT_EQ(g.groups[0].variation, (PoseSet{6}));
    EXPECT_EQ(g.groups[0].landmarks, (std::vector<std::size_t>{0, 1}));
}

TEST(ViewPattern, AndTermsOfOneLandmarkNeedTheirOwnViews)
{
    // One landmark with two AND terms that share no pose: two views.
    std::vector<Requirement> reqs{{0, {{1, 2}}}, {0, {{3}}}};
    auto g = greedyViewPattern(reqs);
    EXPECT_EQ(g.groups.size(), 2u);
}

TEST(ViewPattern, EmptyRequirementIsUnserved)
{
    std::vector<Requirement> reqs{{0, {{1}}}, {1, {{}}}};
    auto g = greedyViewPattern(reqs);
    EXPECT_EQ(g.groups.size(), 1u);
    ASSERT_EQ(g.unserved.size(), 1u);
    EXPECT_EQ(g.unserved[0], 1u);
}

TEST(ViewPattern, ExactCoverFindsTheOptimum)
{
    // Four landmarks on a ring of poses: {1,2}, {2,3}, {3,4}, {4,1}. Two poses
    // (2 and 4, or 1 and 3) cover all; one cannot.
    std::vector<Requirement> reqs{{0, {{1, 2}}}, {1, {{2, 3}}}, {2, {{3, 4}}}, {3, {{1, 4}}}};
    auto e = exactViewCover(reqs);
    ASSERT_TRUE(e.solved);
    EXPECT_TRUE(e.optimal);
    EXPECT_EQ(e.poses.size(), 2u);
    for (const auto& r : reqs) {
        bool met = false;
        for (int p : e.poses) met = met || std::binary_search(r.anyOf[0].begin(), r.anyOf[0].end(), p);
        EXPECT_TRUE(met);
    }
}

TEST(ViewPattern, GreedyCanBeWorseThanTheOptimum)
{
    // Pose 10 serves r0, r2, r4 and pose 20 serves r1, r3, r5: the optimum is
    // 2 views. The decoy poses {1, 2, 3} give r0 and r1 the largest pairwise
    // intersection (3), so the greedy merges them on {1, 2, 3}, a list that no
    // other requirement meets; r2+r4 then merge on {10} and r3+r5 on {20}: 3 views.
    std::vector<Requirement> reqs{{0, {{1, 2, 3, 10}}}, {1, {{1, 2, 3, 20}}}, {2, {{10, 30}}},
                                  {3, {{20, 40}}},      {4, {{10, 50}}},      {5, {{20, 60}}}};
    auto g = greedyViewPattern(reqs);
    auto e = exactViewCover(reqs);
    ASSERT_TRUE(e.optimal);
    EXPECT_EQ(e.poses.size(), 2u);
    EXPECT_EQ(g.groups.size(), 3u);
    // The final redundancy check drops the decoy: 10 and 20 meet r0 and r1 too.
    EXPECT_EQ(removeRedundantPoses(reqs, {2, 10, 20}), (std::vector<int>{10, 20}));
    // Nothing to drop when each pose is needed.
    EXPECT_EQ(removeRedundantPoses(reqs, {10, 20}), (std::vector<int>{10, 20}));
}

TEST(ViewPattern, ExactNeverWorseThanGreedyOnRandomInstances)
{
    std::mt19937 rng(7);
    for (int trial = 0; trial < 20; ++trial) {
        std::vector<Requirement> reqs;
        for (std::size_t l = 0; l < 15; ++l) {
            PoseSet s;
            for (int p = 0; p < 40; ++p)
                if (rng() % 6 == 0) s.push_back(p);
            if (s.empty()) s.push_back(static_cast<int>(l));
            reqs.push_back({l, {s}});
        }
        auto g = greedyViewPattern(reqs);
        auto e = exactViewCover(reqs);
        ASSERT_TRUE(e.solved);
        EXPECT_LE(e.poses.size(), g.groups.size());
    }
}

} // namespace
} // namespace hg::plan
