// V4L2 format negotiation and YUYV to grey, without a device.
#include <gtest/gtest.h>

#include <linux/videodev2.h>
#include <opencv2/core.hpp>

#include "v4l2/v4l2_formats.h"

namespace {

using hg::drivers::PixelFormat;
namespace v4l2 = hg::drivers::v4l2;

TEST(V4l2Formats, Mono8PrefersGreyThenFallsBackToYuyv)
{
    EXPECT_EQ(v4l2::negotiate(PixelFormat::Mono8, {V4L2_PIX_FMT_YUYV, V4L2_PIX_FMT_GREY}), V4L2_PIX_FMT_GREY);
    EXPECT_EQ(v4l2::negotiate(PixelFormat::Mono8, {V4L2_PIX_FMT_MJPEG, V4L2_PIX_FMT_YUYV}), V4L2_PIX_FMT_YUYV);
    EXPECT_FALSE(v4l2::negotiate(PixelFormat::Mono8, {V4L2_PIX_FMT_MJPEG, V4L2_PIX_FMT_RGB24}).has_value());
}

TEST(V4l2Formats, WideFormatsNeedTheirExactDeviceFormat)
{
    EXPECT_EQ(v4l2::negotiate(PixelFormat::Mono16, {V4L2_PIX_FMT_GREY, V4L2_PIX_FMT_Y16}), V4L2_PIX_FMT_Y16);
    EXPECT_EQ(v4l2::negotiate(PixelFormat::Mono12, {V4L2_PIX_FMT_Y12, V4L2_PIX_FMT_Y16}), V4L2_PIX_FMT_Y12);
    // A 16-bit device format never silently serves 8 bits, nor the reverse.
    EXPECT_FALSE(v4l2::negotiate(PixelFormat::Mono16, {V4L2_PIX_FMT_GREY, V4L2_PIX_FMT_YUYV}).has_value());
    EXPECT_FALSE(v4l2::negotiate(PixelFormat::Mono8, {V4L2_PIX_FMT_Y16}).has_value());
    EXPECT_FALSE(v4l2::negotiate(PixelFormat::Mono12, {}).has_value());
}

TEST(V4l2Formats, OnlyYuyvIsConverted)
{
    EXPECT_TRUE(v4l2::needsConversion(V4L2_PIX_FMT_YUYV));
    EXPECT_FALSE(v4l2::needsConversion(V4L2_PIX_FMT_GREY));
    EXPECT_FALSE(v4l2::needsConversion(V4L2_PIX_FMT_Y16));
}

TEST(V4l2Formats, FourccNames)
{
    EXPECT_EQ(v4l2::fourccName(V4L2_PIX_FMT_YUYV), "YUYV");
    EXPECT_EQ(v4l2::fourccName(V4L2_PIX_FMT_GREY), "GREY");
    EXPECT_EQ(v4l2::fourccName(V4L2_PIX_FMT_Y16), "Y16");
}

TEST(V4l2Formats, YuyvToGreyTakesTheLumaAndHonoursTheStride)
{
    // 4x2 image, rows padded to 12 bytes (8 bytes of pixels + 4 of padding).
    // Row 0: Y=10 U=200 Y=20 V=90 | Y=30 U=201 Y=40 V=91
    // Row 1: Y=50 U=202 Y=60 V=92 | Y=70 U=203 Y=80 V=93
    const std::uint8_t data[24] = {10, 200, 20, 90, 30, 201, 40, 91, 0xEE, 0xEE, 0xEE, 0xEE,
                                   50, 202, 60, 92, 70, 203, 80, 93, 0xEE, 0xEE, 0xEE, 0xEE};
    cv::Mat grey(2, 4, CV_8UC1, cv::Scalar(0));
    v4l2::yuyvToGrey(data, 12, 4, 2, grey);
    const cv::Mat expected = (cv::Mat_<std::uint8_t>(2, 4) << 10, 20, 30, 40, 50, 60, 70, 80);
    EXPECT_EQ(cv::norm(grey, expected, cv::NORM_INF), 0.0) << grey;
}

TEST(V4l2Formats, AnAdjustedCropCountsOnlyWhenItContainsTheRegionInsideTheBounds)
{
    using hg::drivers::Roi;
    const Roi bounds{0, 0, 320, 180};
    // Grown to even sizes around the request: accepted as the region delivered.
    EXPECT_EQ(v4l2::acceptedCrop(Roi{11, 5, 51, 31}, Roi{10, 4, 52, 32}, bounds), (Roi{10, 4, 52, 32}));
    EXPECT_EQ(v4l2::acceptedCrop(Roi{10, 4, 52, 32}, Roi{10, 4, 52, 32}, bounds), (Roi{10, 4, 52, 32}));
    // Shrunk or moved off the request: not a crop of it.
    EXPECT_FALSE(v4l2::acceptedCrop(Roi{11, 5, 51, 31}, Roi{12, 5, 50, 31}, bounds).has_value());
    EXPECT_FALSE(v4l2::acceptedCrop(Roi{11, 5, 51, 31}, Roi{11, 5, 50, 31}, bounds).has_value());
    // Out of the configured bounds, or empty.
    EXPECT_FALSE(v4l2::acceptedCrop(Roi{300, 5, 20, 31}, Roi{300, 4, 24, 32}, bounds).has_value());
    EXPECT_FALSE(v4l2::acceptedCrop(Roi{11, 5, 51, 31}, Roi{0, 0, 0, 0}, bounds).has_value());
}

} // namespace
