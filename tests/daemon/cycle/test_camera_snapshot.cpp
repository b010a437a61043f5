// The camera snapshot's picture and figures (docs/hmi.md, "Maintenance") on
// frames drawn here: a backlight of one grey with a dark rectangle whose area,
// outline and grey levels are known by construction.
#include "cycle/camera_snapshot.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

namespace hg::daemon {
namespace {

// 64 × 48 backlight `back` with the rectangle x 10..29, y 12..21 (20 × 10 px) at `object`.
cv::Mat frame(int type, double back, double object)
{
    cv::Mat f(48, 64, type, cv::Scalar(back));
    f(cv::Rect(10, 12, 20, 10)).setTo(cv::Scalar(object));
    return f;
}

cv::Mat rectangleMask()
{
    return frame(CV_8UC1, 0, 255);
}

TEST(CameraSnapshot, FiguresAreTheRectanglesShareAndTheTwoGreys)
{
    const auto f = snapshotFigures(frame(CV_8UC1, 230, 12), rectangleMask(), 121);
    EXPECT_DOUBLE_EQ(f.objectFraction, 200.0 / (64.0 * 48.0));
    EXPECT_DOUBLE_EQ(f.backlightGrey, 230);
    EXPECT_DOUBLE_EQ(f.objectGrey, 12);
    EXPECT_DOUBLE_EQ(f.threshold, 121);
}

TEST(CameraSnapshot, SixteenBitFramesKeepTheirGreyLevels)
{
    const auto f = snapshotFigures(frame(CV_16UC1, 60000, 3000), rectangleMask(), 31500);
    EXPECT_DOUBLE_EQ(f.backlightGrey, 60000);
    EXPECT_DOUBLE_EQ(f.objectGrey, 3000);
}

TEST(CameraSnapshot, OverlayOutlinesTheSilhouetteInRedAndTintsItsInside)
{
    const auto img = snapshotOverlay(frame(CV_16UC1, 257 * 200, 257 * 40), rectangleMask());
    ASSERT_EQ(img.type(), CV_8UC3);
    ASSERT_EQ(img.size(), cv::Size(64, 48));
    const auto at = [&](int x, int y) { return img.at<cv::Vec3b>(y, x); };
    // Backlight far from the part: the frame's grey (16 bit scaled to 8), untouched.
    EXPECT_EQ(at(50, 40), cv::Vec3b(200, 200, 200));
    // The rectangle's border pixels are the outline: pure red (BGR).
    EXPECT_EQ(at(10, 12), cv::Vec3b(0, 0, 255));
    EXPECT_EQ(at(29, 21), cv::Vec3b(0, 0, 255));
    EXPECT_EQ(at(20, 12), cv::Vec3b(0, 0, 255));
    // Inside: 0.6 · grey + 0.4 · (255, 120, 0) = (126, 72, 24).
    EXPECT_EQ(at(20, 16), cv::Vec3b(126, 72, 24));
    // Just outside the rectangle nothing is drawn.
    EXPECT_EQ(at(9, 16), cv::Vec3b(200, 200, 200));
    EXPECT_EQ(at(30, 16), cv::Vec3b(200, 200, 200));
}

// A refused request says why, as a status: the maintenance socket answers with its message.
TEST(CameraSnapshot, ARefusedRequestSaysWhy)
{
    CameraSnapshot snapshot;
    const Status notReady = snapshot.request({}, station::SequencerState::Fault);
    EXPECT_FALSE(notReady.ok());
    EXPECT_EQ(notReady.code(), StatusCode::NotAllowed);
    EXPECT_EQ(notReady.message(), "the station is not ready (fault)");
    EXPECT_FALSE(snapshot.queued());

    const Status queued = snapshot.request({}, station::SequencerState::Ready);
    EXPECT_TRUE(queued.ok()) << queued.message();
    EXPECT_TRUE(snapshot.queued());
    const Status again = snapshot.request({}, station::SequencerState::Ready);
    EXPECT_FALSE(again.ok());
    EXPECT_EQ(again.code(), StatusCode::NotAllowed);
    EXPECT_EQ(again.message(), "a camera snapshot is already queued or running");
}

} // namespace
} // namespace hg::daemon
