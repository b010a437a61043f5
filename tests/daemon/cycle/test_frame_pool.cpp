// The daemon's frame pool (docs/daemon.md, "Memory"): copies land in slots
// allocated once, a slot is reused once no frame refers to it, and a pool
// with every slot held still gives a right copy, of its own.
#include "cycle/frame_pool.h"

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

namespace hg::daemon {
namespace {

/// A frame of random pixels, another for each seed.
cv::Mat ramp(cv::Size size, int type, int seed)
{
    cv::Mat image(size, type);
    cv::RNG rng(static_cast<std::uint64_t>(seed));
    rng.fill(image, cv::RNG::UNIFORM, 0, type == CV_8UC1 ? 256 : 4096);
    return image;
}

bool same(const cv::Mat& a, const cv::Mat& b)
{
    return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0.0;
}

TEST(FramePool, ACopyIsTheFrameAndItsSlotIsReusedWhenReleased)
{
    FramePool pool;
    pool.reserve(2, 100 * 80);
    const cv::Mat a = ramp({64, 48}, CV_8UC1, 1);
    cv::Mat first = pool.copy(a);
    EXPECT_TRUE(same(first, a));
    EXPECT_TRUE(first.isContinuous());
    EXPECT_EQ(pool.held(), 1u);
    const std::uint8_t* slot = first.data;
    first.release();
    EXPECT_EQ(pool.held(), 0u);
    // Another size in the same slot: its rows at the slot's front.
    const cv::Mat b = ramp({100, 80}, CV_8UC1, 2);
    const cv::Mat second = pool.copy(b);
    EXPECT_TRUE(same(second, b));
    EXPECT_EQ(second.data, slot);
    EXPECT_EQ(pool.overflows(), 0u);
}

TEST(FramePool, EverySlotHeldGivesACopyOfItsOwnAndThePoolDoesNotGrow)
{
    FramePool pool;
    pool.reserve(2, 64 * 48);
    const cv::Mat a = ramp({64, 48}, CV_16UC1, 1), b = ramp({32, 48}, CV_16UC1, 2), c = ramp({64, 48}, CV_16UC1, 3);
    const cv::Mat ca = pool.copy(a), cb = pool.copy(b);
    const cv::Mat cc = pool.copy(c);
    EXPECT_TRUE(same(ca, a));
    EXPECT_TRUE(same(cb, b));
    EXPECT_TRUE(same(cc, c));
    EXPECT_EQ(pool.slots(), 2u);
    EXPECT_EQ(pool.held(), 2u);
    EXPECT_EQ(pool.overflows(), 1u);
    // The copies do not share pixels: writing one leaves the others.
    cv::Mat(ca).setTo(0);
    EXPECT_TRUE(same(cb, b));
    EXPECT_TRUE(same(cc, c));
}

TEST(FramePool, AFrameLargerThanASlotOrOfAnotherTypeIsStillCopiedRight)
{
    FramePool pool;
    pool.reserve(1, 64 * 48);
    const cv::Mat big = ramp({65, 48}, CV_8UC1, 1);
    EXPECT_TRUE(same(pool.copy(big), big));
    EXPECT_EQ(pool.overflows(), 1u);
    // A view into a larger image (not continuous) and then a 16-bit frame.
    const cv::Mat whole = ramp({200, 100}, CV_8UC1, 2);
    const cv::Mat part = whole(cv::Rect(10, 20, 64, 48));
    ASSERT_FALSE(part.isContinuous());
    EXPECT_TRUE(same(pool.copy(part), part));
    const cv::Mat deep = ramp({64, 48}, CV_16UC1, 3);
    EXPECT_TRUE(same(pool.copy(deep), deep));
    EXPECT_EQ(pool.overflows(), 1u);
}

TEST(FramePool, AFrameKeptAcrossAReserveKeepsItsPixels)
{
    FramePool pool;
    pool.reserve(1, 64 * 48);
    const cv::Mat a = ramp({64, 48}, CV_8UC1, 1);
    const cv::Mat kept = pool.copy(a);
    pool.reserve(1, 128 * 96); // the camera's configured region changed
    const cv::Mat b = ramp({128, 96}, CV_8UC1, 2);
    EXPECT_TRUE(same(pool.copy(b), b));
    EXPECT_TRUE(same(kept, a));
    EXPECT_EQ(pool.overflows(), 0u);
}

} // namespace
} // namespace hg::daemon
