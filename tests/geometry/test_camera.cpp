// CameraModel against OpenCV's own projection (independent implementation)
// and against the dissertation's eq. 4.2.1-1/2 written out by hand.
#include <random>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>

#include "hullgauge/geometry/camera.h"

namespace hg::geometry {
namespace {

Intrinsics makeIntrinsics(std::vector<double> dist)
{
    Intrinsics in;
    in.K << 2400.0, 0, 1224.5, 0, 2395.0, 1023.25, 0, 0, 1;
    in.dist = std::move(dist);
    in.imageSize = {2448, 2048};
    return in;
}

RigidTransform somePose(std::mt19937& rng)
{
    std::uniform_real_distribution<double> ang(-180, 180), off(-20, 20);
    Vec3 axis(off(rng), off(rng), off(rng));
    RigidTransform T = RigidTransform::rotation(axis, ang(rng));
    T.t = Vec3(off(rng), off(rng), 400.0 + off(rng));
    return T;
}

// Compares project() with cv::projectPoints for random points in front of the camera.
void expectMatchesOpenCV(const std::vector<double>& dist, std::uint32_t seed)
{
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-40, 40);
    for (int trial = 0; trial < 20; ++trial) {
        CameraModel cam(makeIntrinsics(dist), somePose(rng));
        std::vector<cv::Point3d> pts;
        for (int i = 0; i < 50; ++i) pts.emplace_back(u(rng), u(rng), u(rng));
        const auto& T = cam.cameraFromPart();
        cv::Mat R(3, 3, CV_64F), rvec, tvec = (cv::Mat_<double>(3, 1) << T.t.x(), T.t.y(), T.t.z());
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c) R.at<double>(r, c) = T.R(r, c);
        cv::Rodrigues(R, rvec);
        cv::Mat K(3, 3, CV_64F);
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c) K.at<double>(r, c) = cam.intrinsics().K(r, c);
        std::vector<cv::Point2d> expected;
        cv::projectPoints(pts, rvec, tvec, K, dist, expected);
        for (std::size_t i = 0; i < pts.size(); ++i) {
            auto p = cam.project(Vec3(pts[i].x, pts[i].y, pts[i].z));
            ASSERT_TRUE(p.has_value());
            // Rodrigues round trip costs ~1e-13 px at 2400 px focal length.
            EXPECT_NEAR(p->x(), expected[i].x, 1e-9) << "point " << i << " dist size " << dist.size();
            EXPECT_NEAR(p->y(), expected[i].y, 1e-9) << "point " << i << " dist size " << dist.size();
        }
    }
}

TEST(CameraModel, ProjectionEqualsOpenCVWithoutDistortion)
{
    expectMatchesOpenCV({}, 1);
}
TEST(CameraModel, ProjectionEqualsOpenCVWithFiveCoefficients)
{
    expectMatchesOpenCV({-0.12, 0.08, 0.0007, -0.0004, -0.02}, 2);
}
TEST(CameraModel, ProjectionEqualsOpenCVWithRationalModel)
{
    expectMatchesOpenCV({-0.12, 0.08, 0.0007, -0.0004, -0.02, 0.01, -0.005, 0.002}, 3);
}
TEST(CameraModel, ProjectionEqualsOpenCVWithThinPrism)
{
    expectMatchesOpenCV({-0.12, 0.08, 0.0007, -0.0004, -0.02, 0.01, -0.005, 0.002, 0.001, -0.0005, 0.0007, 0.0002}, 4);
}

TEST(CameraModel, PointsBehindTheCameraDoNotProject)
{
    CameraModel cam(makeIntrinsics({}), RigidTransform::translation({0, 0, 100}));
    EXPECT_FALSE(cam.project({0, 0, -100}).has_value());
    EXPECT_FALSE(cam.project({0, 0, -150}).has_value());
    EXPECT_TRUE(cam.project({0, 0, -99}).has_value());
}

TEST(CameraModel, BackProjectionRoundTripsWithDistortion)
{
    std::mt19937 rng(7);
    CameraModel cam(makeIntrinsics({-0.12, 0.08, 0.0007, -0.0004, -0.02}), somePose(rng));
    std::uniform_real_distribution<double> px(0, 2447), py(0, 2047), depth(300, 500);
    for (int i = 0; i < 200; ++i) {
        Vec2 pixel(px(rng), py(rng));
        Ray ray = cam.backProject(pixel);
        EXPECT_NEAR((ray.origin - cam.centre()).norm(), 0.0, 1e-9);
        EXPECT_NEAR(ray.direction.norm(), 1.0, 1e-12);
        auto back = cam.project(ray.origin + depth(rng) * ray.direction);
        ASSERT_TRUE(back);
        EXPECT_NEAR((*back - pixel).norm(), 0.0, 1e-7) << "pixel " << pixel.transpose();
    }
}

TEST(CameraModel, UndistortAgreesWithOpenCV)
{
    auto in = makeIntrinsics({-0.12, 0.08, 0.0007, -0.0004, -0.02});
    CameraModel cam(in, RigidTransform{});
    cv::Mat K(3, 3, CV_64F);
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) K.at<double>(r, c) = in.K(r, c);
    std::vector<cv::Point2d> pix{{100, 200}, {1224, 1023}, {2300, 1900}, {50, 2000}}, und;
    cv::undistortPoints(pix, und, K, in.dist, cv::noArray(), cv::noArray(),
                        cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 200, 1e-14));
    for (std::size_t i = 0; i < pix.size(); ++i) {
        Vec2 xy = cam.undistortPixel({pix[i].x, pix[i].y});
        EXPECT_NEAR(xy.x(), und[i].x, 1e-8);
        EXPECT_NEAR(xy.y(), und[i].y, 1e-8);
    }
}

TEST(CameraModel, CentreAndAxis)
{
    // Camera 300 mm above the part looking straight down (-z): x right stays
    // +x, y down becomes -y, forward is -z.
    Mat3 R;
    R << 1, 0, 0, 0, -1, 0, 0, 0, -1;
    RigidTransform T{R, -(R * Vec3(5, 6, 300))};
    CameraModel cam(makeIntrinsics({}), T);
    EXPECT_NEAR((cam.centre() - Vec3(5, 6, 300)).norm(), 0.0, 1e-12);
    EXPECT_NEAR((cam.opticalAxis() - Vec3(0, 0, -1)).norm(), 0.0, 1e-12);
    // A point straight below the camera lands on the principal point.
    auto p = cam.project({5, 6, 0});
    ASSERT_TRUE(p);
    EXPECT_NEAR(p->x(), 1224.5, 1e-9);
    EXPECT_NEAR(p->y(), 1023.25, 1e-9);
    // 1 mm in +x at 300 mm depth moves fx/300 px to the right.
    EXPECT_NEAR(cam.project({6, 6, 0})->x() - 1224.5, 2400.0 / 300.0, 1e-9);
    EXPECT_NEAR(cam.millimetresPerPixelAt(300).x(), 300.0 / 2400.0, 1e-15);
}

// Eq. 4.2.1-1/2 evaluated literally, independent of CameraModel.
Vec2 dissertationProjection(double fh, double fv, double mc, double nc, const Vec3& C, const Vec3& h, const Vec3& v,
                            const Vec3& a, const Vec3& P)
{
    Vec3 d = P - C;
    return {fh * d.dot(h) / d.dot(a) + mc, fv * d.dot(v) / d.dot(a) + nc};
}

TEST(CameraModel, Equation421IsTheGeneralModel)
{
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> u(-30, 30);
    Mat3 R = RigidTransform::rotation(Vec3(0.3, -0.5, 0.8), 37.0).R;
    Vec3 h = R.row(0), v = R.row(1), a = R.row(2);
    Vec3 C = -400.0 * a + Vec3(3, -2, 1);
    auto cam = CameraModel::fromDissertation(903.5, 911.25, 264, 273, C, h, v, a, {512, 512});
    for (int i = 0; i < 100; ++i) {
        Vec3 P(u(rng), u(rng), u(rng));
        Vec2 expected = dissertationProjection(903.5, 911.25, 264, 273, C, h, v, a, P);
        auto got = cam.project(P);
        ASSERT_TRUE(got);
        EXPECT_NEAR((*got - expected).norm(), 0.0, 1e-9);
    }
}

TEST(CameraModel, Equation421WithLowerLeftOriginCountsRowsFromTheTop)
{
    // The dissertation's display origin was the lower-left corner: v points
    // up and (h, v, a) is left-handed. The model reports row = (H-1) - n.
    Vec3 h(1, 0, 0), v(0, -1, 0), a(0, 0, 1); // v up: left-handed
    Vec3 C(0, 0, -400);
    auto cam = CameraModel::fromDissertation(900, 900, 264, 273, C, h, v, a, {512, 512});
    for (Vec3 P : {Vec3(1, 2, 3), Vec3(-10, 5, 20), Vec3(7, -7, 0)}) {
        Vec2 mn = dissertationProjection(900, 900, 264, 273, C, h, v, a, P);
        auto px = cam.project(P);
        ASSERT_TRUE(px);
        EXPECT_NEAR(px->x(), mn.x(), 1e-9);
        EXPECT_NEAR(px->y(), 511.0 - mn.y(), 1e-9);
    }
}

TEST(CameraModel, FromProjectionMatrixRecoversKRt)
{
    std::mt19937 rng(5);
    auto in = makeIntrinsics({});
    RigidTransform T = somePose(rng);
    Eigen::Matrix<double, 3, 4> P = 3.7 * (in.K * T.matrix()); // any scale
    auto cam = CameraModel::fromProjectionMatrix(P, in.imageSize);
    EXPECT_LT((cam.intrinsics().K - in.K).cwiseAbs().maxCoeff(), 1e-6);
    EXPECT_LT((cam.cameraFromPart().R - T.R).cwiseAbs().maxCoeff(), 1e-9);
    EXPECT_LT((cam.cameraFromPart().t - T.t).cwiseAbs().maxCoeff(), 1e-6);
}

TEST(Intrinsics, RejectsUnusableParameters)
{
    auto in = makeIntrinsics({0.1, 0.2, 0.0, 0.0, 0.0, 0.0});
    EXPECT_THROW(in.validate(), std::invalid_argument);
    in.dist.assign(14, 0.0);
    EXPECT_THROW(in.validate(), std::invalid_argument);
    in = makeIntrinsics({});
    in.K(0, 0) = -5;
    EXPECT_THROW(in.validate(), std::invalid_argument);
    in = makeIntrinsics({});
    EXPECT_NO_THROW(in.validate());
}

} // namespace
} // namespace hg::geometry
