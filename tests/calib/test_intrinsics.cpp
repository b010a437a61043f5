#include <gtest/gtest.h>

#include <filesystem>
#include <random>

#include <opencv2/aruco/charuco.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "hullgauge/calib/intrinsics.h"
#include "hullgauge/common/error.h"

using namespace hg::calib;

namespace {

// OpenCV's sample chessboard images (Debian package opencv-doc; left10.jpg is
// not part of the set). 9x6 inner corners.
const std::filesystem::path kSampleDir = "/usr/share/doc/opencv-doc/examples/data";

std::vector<std::filesystem::path> sampleImages()
{
    std::vector<std::filesystem::path> files;
    for (int i : {1, 2, 3, 4, 5, 6, 7, 8, 9, 11, 12, 13, 14}) {
        char name[32];
        std::snprintf(name, sizeof name, "left%02d.jpg", i);
        files.push_back(kSampleDir / name);
    }
    return files;
}

std::vector<TargetView> detectAll(const TargetSpec& spec, const std::vector<std::filesystem::path>& files,
                                  cv::Size& size)
{
    std::vector<TargetView> views;
    for (const auto& f : files) {
        cv::Mat img = cv::imread(f.string(), cv::IMREAD_GRAYSCALE);
        if (img.empty()) ADD_FAILURE() << "cannot read " << f << " (tools/setup-deps installs opencv-doc)";
        size = img.size();
        if (auto v = detectTarget(img, spec, f.filename().string())) views.push_back(*v);
    }
    return views;
}

} // namespace

TEST(TargetSpec, ParsesChessboardAndCharuco)
{
    auto c = TargetSpec::parse("chessboard:9x6:25");
    EXPECT_EQ(c.kind, TargetKind::Chessboard);
    EXPECT_EQ(c.cols, 9);
    EXPECT_EQ(c.rows, 6);
    EXPECT_DOUBLE_EQ(c.squareMm, 25.0);
    EXPECT_EQ(c.cornerCount(), 54);
    EXPECT_EQ(c.cornerPosition(10), cv::Point3f(25.0f, 25.0f, 0.0f)); // column 1, row 1
    auto a = TargetSpec::parse("charuco:7x5:30:22");
    EXPECT_EQ(a.kind, TargetKind::Charuco);
    EXPECT_EQ(a.dictionary, "DICT_5X5_100");
    EXPECT_EQ(a.cornerCount(), 24);
    EXPECT_EQ(a.cornerPosition(7), cv::Point3f(30.0f, 30.0f, 0.0f)); // 6 corners per row
}

TEST(TargetSpec, BadPatternsNameTheOption)
{
    for (const char* bad : {"chessboard:9x6", "grid:9x6:25", "chessboard:9by6:25", "chessboard:9x6:-1",
                            "charuco:7x5:30:40", "charuco:7x5:30:20:DICT_9X9_1"}) {
        try {
            (void)TargetSpec::parse(bad);
            ADD_FAILURE() << bad << " was accepted";
        } catch (const hg::InputError& e) {
            EXPECT_EQ(e.field(), "--pattern") << bad;
        }
    }
}

// Reference: OpenCV's samples/data/left_intrinsics.yml (shipped by Debian as
// /usr/share/doc/opencv-doc/examples/data/left_intrinsics.yml), the output of
// OpenCV's calibration sample on these 13 images with flags = 2
// (CALIB_FIX_ASPECT_RATIO, aspect ratio 1): fx = fy = 535.91573396163199,
// cx = 342.28315473308373, cy = 235.57082909788173, RMS 0.39259,
// per-view error largest for left02.jpg (1.182 px).
TEST(Intrinsics, OpenCvSampleImagesMatchThePublishedResult)
{
    auto spec = TargetSpec::parse("chessboard:9x6:25");
    cv::Size size;
    auto views = detectAll(spec, sampleImages(), size);
    ASSERT_EQ(views.size(), 13u);
    EXPECT_EQ(size, cv::Size(640, 480));
    IntrinsicsOptions opt;
    opt.fixAspectRatio = true;
    auto r = calibrateIntrinsics(views, size, opt);
    const auto& K = r.intrinsics.K;
    EXPECT_NEAR(K(0, 0), 535.91573396163199, 0.01 * 535.9);
    EXPECT_NEAR(K(1, 1), 535.91573396163199, 0.01 * 535.9);
    EXPECT_NEAR(K(0, 2), 342.28315473308373, 0.01 * 342.3);
    EXPECT_NEAR(K(1, 2), 235.57082909788173, 0.01 * 235.6);
    EXPECT_NEAR(r.rmsPx, 0.39259098975581364, 0.05);
    ASSERT_EQ(r.perViewRmsPx.size(), 13u);
    auto worst = std::max_element(r.perViewRmsPx.begin(), r.perViewRmsPx.end()) - r.perViewRmsPx.begin();
    EXPECT_EQ(r.viewNames[static_cast<std::size_t>(worst)], "left02.jpg");
    EXPECT_NEAR(r.perViewRmsPx[1], 1.18204820, 0.15);
    // Standard deviations: estimated, positive, and small against the values
    // (fx follows fy when the aspect ratio is fixed: no deviation of its own).
    ASSERT_EQ(r.stdDev.size(), 9u);
    EXPECT_EQ(r.stdDev[0], 0.0);
    for (int i = 1; i < 4; ++i) {
        EXPECT_GT(r.stdDev[i], 0.0) << intrinsicParameterNames()[i];
        EXPECT_LT(r.stdDev[i], 5.0) << intrinsicParameterNames()[i];
    }
    std::string report = formatIntrinsicsReport(r);
    EXPECT_NE(report.find("left02.jpg"), std::string::npos);
}

TEST(Intrinsics, FreeAspectRatioStaysWithinOnePercent)
{
    auto spec = TargetSpec::parse("chessboard:9x6:25");
    cv::Size size;
    auto views = detectAll(spec, sampleImages(), size);
    auto r = calibrateIntrinsics(views, size);
    EXPECT_NEAR(r.intrinsics.K(0, 0), 535.9157, 0.01 * 535.9);
    EXPECT_NEAR(r.intrinsics.K(1, 1), 535.9157, 0.01 * 535.9);
    for (int i = 0; i < 4; ++i) EXPECT_GT(r.stdDev[i], 0.0) << intrinsicParameterNames()[i];
}

TEST(Intrinsics, TooFewViewsIsBadInput)
{
    auto spec = TargetSpec::parse("chessboard:9x6:25");
    cv::Size size;
    auto views = detectAll(spec, {kSampleDir / "left01.jpg", kSampleDir / "left02.jpg"}, size);
    ASSERT_EQ(views.size(), 2u);
    EXPECT_THROW((void)calibrateIntrinsics(views, size), hg::InputError);
}

// ChArUco: a board drawn by OpenCV and seen through a known pinhole camera
// (rendered by warping with the plane's homography K [r1 r2 t]); the
// calibration must give back that camera.
TEST(Intrinsics, CharucoRenderedViewsGiveBackTheCamera)
{
    auto spec = TargetSpec::parse("charuco:8x6:20:15:DICT_5X5_100");
    auto board = cv::aruco::CharucoBoard::create(8, 6, 20.0f, 15.0f,
                                                 cv::aruco::getPredefinedDictionary(cv::aruco::DICT_5X5_100));
    const double pxPerMm = 10.0; // board artwork resolution
    cv::Mat art;
    board->draw(cv::Size(static_cast<int>(8 * 20 * pxPerMm), static_cast<int>(6 * 20 * pxPerMm)), art, 0, 1);

    const cv::Size size(1280, 960);
    cv::Matx33d K(1500, 0, 652.5, 0, 1490, 471.25, 0, 0, 1);
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> tilt(-0.45, 0.45), shift(-25, 25);
    std::vector<TargetView> views;
    for (int i = 0; i < 10; ++i) {
        cv::Vec3d rvec(tilt(rng), tilt(rng), 0.3 * tilt(rng));
        cv::Matx33d R;
        cv::Rodrigues(rvec, R);
        // Board centre in front of the camera at ~450 mm.
        cv::Vec3d centre(shift(rng), shift(rng), 450 + 4 * shift(rng));
        // Art pixel (a, b) -> board mm (a/pxPerMm - 80, b/pxPerMm - 60) centred -> camera.
        cv::Matx33d S(1 / pxPerMm, 0, -80, 0, 1 / pxPerMm, -60, 0, 0, 1);
        cv::Matx33d Rt(R(0, 0), R(0, 1), centre[0], R(1, 0), R(1, 1), centre[1], R(2, 0), R(2, 1), centre[2]);
        cv::Matx33d H = K * Rt * S;
        cv::Mat img;
        cv::warpPerspective(art, img, cv::Mat(H), size, cv::INTER_AREA, cv::BORDER_CONSTANT, cv::Scalar(255));
        cv::GaussianBlur(img, img, cv::Size(3, 3), 0.6);
        auto v = detectTarget(img, spec, "view" + std::to_string(i));
        if (v) views.push_back(*v);
    }
    ASSERT_GE(views.size(), 8u);
    auto r = calibrateIntrinsics(views, size);
    EXPECT_NEAR(r.intrinsics.K(0, 0), 1500, 0.01 * 1500);
    EXPECT_NEAR(r.intrinsics.K(1, 1), 1490, 0.01 * 1490);
    EXPECT_NEAR(r.intrinsics.K(0, 2), 652.5, 6.0);
    EXPECT_NEAR(r.intrinsics.K(1, 2), 471.25, 6.0);
    EXPECT_LT(r.rmsPx, 0.5);
}
