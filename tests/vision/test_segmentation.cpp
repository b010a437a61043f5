// Segmentation: Otsu on 8- and 16-bit frames, fixed thresholds, polarity,
// masks, colour frames and region-limited silhouettes; the station file's
// segmentation section.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "hullgauge/common/config_node.h"
#include "hullgauge/common/error.h"
#include "hullgauge/vision/segmentation.h"

using namespace hg::vision;

namespace {

/// Backlit frame: background `bg`, a dark disc of `obj` at the centre, Gaussian noise σ.
cv::Mat backlit(int depth, double bg, double obj, double sigma, std::uint64_t seed)
{
    cv::Mat f(120, 160, CV_64F, cv::Scalar(bg));
    cv::circle(f, {80, 60}, 30, cv::Scalar(obj), cv::FILLED);
    cv::Mat noise(f.size(), CV_64F);
    cv::RNG rng(seed);
    rng.fill(noise, cv::RNG::NORMAL, 0.0, sigma);
    f += noise;
    cv::Mat out;
    f.convertTo(out, depth);
    return out;
}

} // namespace

TEST(Segmentation, OtsuSeparatesBacklitModes8Bit)
{
    const cv::Mat f = backlit(CV_8U, 217, 20, 2.0, 1);
    SegmentationSettings s;
    s.otsuStride = 1;
    const double t = computeThreshold(f, s);
    EXPECT_GT(t, 40.0);
    EXPECT_LT(t, 200.0);
    const cv::Mat sil = segment(f, s);
    // The disc is object (255), the corners background.
    EXPECT_EQ(sil.at<std::uint8_t>(60, 80), 255);
    EXPECT_EQ(sil.at<std::uint8_t>(2, 2), 0);
    // Pixel count matches the drawn disc exactly (noise 2 grey levels is far from t).
    cv::Mat disc(f.size(), CV_8U, cv::Scalar(0));
    cv::circle(disc, {80, 60}, 30, cv::Scalar(255), cv::FILLED);
    EXPECT_EQ(cv::countNonZero(sil != disc), 0);
}

// Otsu from the regions' pixels alone (docs/inspection.md, "Pixels in
// proportion to the goal"). Two levels 20 and 200 without noise leave Otsu's
// criterion flat for every t in [20, 199]: the middle of that run, (20 + 200) / 2 = 110.
TEST(Segmentation, OtsuFromRegionsReadsOnlyTheirPixels)
{
    cv::Mat f(100, 200, CV_8U, cv::Scalar(200));
    f(cv::Rect(0, 0, 200, 50)).setTo(20);   // object above row 50
    f(cv::Rect(150, 0, 50, 100)).setTo(90); // a third level the regions never see
    SegmentationSettings s;
    const std::vector<cv::Rect> straddling = {{10, 40, 30, 20}, {60, 30, 20, 40}};
    EXPECT_EQ(computeThreshold(f, straddling, s), 110.0);
    // Clipped to the frame: a region running off it counts its pixels inside only.
    EXPECT_EQ(computeThreshold(f, {{-20, 40, 60, 20}}, s), 110.0);
    // One class only (all object, with noise): Otsu would split the noise; the middle of the range.
    cv::Mat noisy = f.clone();
    cv::Mat noise(f.size(), CV_8U);
    cv::randu(noise, 0, 5);
    noisy += noise;
    EXPECT_EQ(computeThreshold(noisy, {{10, 5, 100, 30}}, s), 127.5);
    EXPECT_EQ(computeThreshold(cv::Mat(40, 40, CV_16U, cv::Scalar(60000)), {{0, 0, 40, 40}}, s), 32767.5);
    // Fixed and mask ignore the regions.
    s.method = SegmentationMethod::Fixed;
    s.threshold = 77.0;
    EXPECT_EQ(computeThreshold(f, straddling, s), 77.0);
}

TEST(Segmentation, OtsuOn16BitUsesFullResolution)
{
    const cv::Mat f = backlit(CV_16U, 55000, 5000, 100.0, 2);
    SegmentationSettings s;
    const double t = computeThreshold(f, s);
    EXPECT_GT(t, 6000.0);
    EXPECT_LT(t, 54000.0);
    const cv::Mat sil = segment(f, s);
    EXPECT_EQ(sil.type(), CV_8U);
    EXPECT_EQ(sil.at<std::uint8_t>(60, 80), 255);
    EXPECT_EQ(sil.at<std::uint8_t>(119, 159), 0);
}

TEST(Segmentation, FixedThresholdAndPolarity)
{
    cv::Mat f(1, 4, CV_8U);
    f.at<std::uint8_t>(0, 0) = 10;
    f.at<std::uint8_t>(0, 1) = 100;
    f.at<std::uint8_t>(0, 2) = 101;
    f.at<std::uint8_t>(0, 3) = 250;
    SegmentationSettings s;
    s.method = SegmentationMethod::Fixed;
    s.threshold = 100.5;
    cv::Mat dark = segment(f, s);
    EXPECT_EQ(dark.at<std::uint8_t>(0, 1), 255); // 100 <= 100.5: object when dark
    EXPECT_EQ(dark.at<std::uint8_t>(0, 2), 0);
    s.objectIsDark = false;
    cv::Mat bright = segment(f, s);
    EXPECT_EQ(bright.at<std::uint8_t>(0, 0), 0);
    EXPECT_EQ(bright.at<std::uint8_t>(0, 2), 255);
    EXPECT_EQ(bright.at<std::uint8_t>(0, 3), 255);
}

TEST(Segmentation, MasksAndColourFrames)
{
    cv::Mat mask(10, 10, CV_8U, cv::Scalar(0));
    mask(cv::Rect(2, 2, 3, 3)).setTo(1);
    SegmentationSettings s;
    s.method = SegmentationMethod::Mask;
    EXPECT_EQ(cv::countNonZero(segment(mask, s)), 9);
    cv::Mat colour;
    cv::cvtColor(backlit(CV_8U, 220, 15, 0.0, 3), colour, cv::COLOR_GRAY2BGR);
    EXPECT_EQ(toGrey(colour).channels(), 1);
    EXPECT_EQ(segment(colour, SegmentationSettings{}).at<std::uint8_t>(60, 80), 255);
    EXPECT_THROW(toGrey(cv::Mat(4, 4, CV_32F)), std::invalid_argument);
    EXPECT_THROW(parseSegmentationMethod("adaptive"), std::invalid_argument);
    EXPECT_EQ(parseSegmentationMethod("fixed"), SegmentationMethod::Fixed);
}

TEST(Segmentation, RegionIsClippedToFrameAndMatchesWholeFrame)
{
    const cv::Mat f = backlit(CV_8U, 217, 20, 2.0, 4);
    SegmentationSettings s;
    const double t = computeThreshold(f, s);
    const cv::Mat whole = segmentRegion(f, cv::Rect(0, 0, f.cols, f.rows), t, s);
    const cv::Rect roi(140, 50, 40, 30); // runs past the right edge
    const cv::Mat part = segmentRegion(f, roi, t, s);
    EXPECT_EQ(part.cols, 20);
    EXPECT_EQ(part.rows, 30);
    EXPECT_EQ(cv::countNonZero(part != whole(cv::Rect(140, 50, 20, 30))), 0);
}

namespace {

// The error of parsing `text` as a station file's segmentation section, or "" when it parses.
std::string sectionError(const std::string& text)
{
    try {
        parseSegmentation(hg::ConfigNode::parse(text, "station.yaml")["segmentation"]);
    } catch (const hg::InputError& e) {
        return e.what();
    }
    return "";
}

} // namespace

TEST(Segmentation, StationSectionHasTheManifestsKeysAndDefaults)
{
    const auto fixed = parseSegmentation(hg::ConfigNode::parse(
        "segmentation: {method: fixed, threshold: 812, object_is_dark: false}", "station.yaml")["segmentation"]);
    EXPECT_EQ(fixed.method, SegmentationMethod::Fixed);
    EXPECT_EQ(fixed.threshold, 812.0);
    EXPECT_FALSE(fixed.objectIsDark);
    const auto empty = parseSegmentation(hg::ConfigNode::parse("segmentation: {}", "station.yaml")["segmentation"]);
    EXPECT_EQ(empty.method, SegmentationMethod::Otsu);
    EXPECT_TRUE(empty.objectIsDark);
    EXPECT_EQ(empty.otsuStride, SegmentationSettings{}.otsuStride);
}

TEST(Segmentation, StationSectionMistakesNameFileLineAndKey)
{
    const std::pair<std::string, std::string> mistakes[] = {
        {"segmentation:\n  method: triangle\n", "station.yaml:2: segmentation.method: expected otsu, fixed or mask"},
        {"segmentation:\n  method: fixed\n", "station.yaml:2: segmentation: threshold: missing"},
        {"segmentation:\n  method: fixed\n  threshold: 70000\n", "station.yaml:3: segmentation.threshold"},
        {"segmentation:\n  treshold: 9\n", "station.yaml:2: segmentation.treshold: unknown key"},
        {"segmentation:\n  object_is_dark: dark\n", "station.yaml:2: segmentation.object_is_dark"},
        {"segmentation: otsu\n", "station.yaml:1: segmentation"},
    };
    for (const auto& [text, expected] : mistakes) {
        const std::string e = sectionError(text);
        EXPECT_NE(e.find(expected), std::string::npos) << "expected '" << expected << "' in: " << e;
    }
}
