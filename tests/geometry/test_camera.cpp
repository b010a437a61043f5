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
        ASSERT_TRUE(cam.centre());
        EXPECT_NEAR((ray.origin - *cam.centre()).norm(), 0.0, 1e-9);
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
    ASSERT_TRUE(cam.centre());
    EXPECT_NEAR((*cam.centre() - Vec3(5, 6, 300)).norm(), 0.0, 1e-12);
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

// ---------------------------------------------------------------------------
// The telecentric camera (docs/telecentric.md): pixel = K·distort(x, y, 1)
// of the camera-frame point, x and y in mm, no division by depth.
// ---------------------------------------------------------------------------

/// A 0.5x lens on 5 µm pixels (100 px per mm of object), principal point
/// (1000.5, 750.25), no distortion, looking straight down (-z) at the focus
/// plane z = 10 of the part frame, axis through (2, 3).
CameraModel downwardTelecentric(std::vector<double> dist = {})
{
    Intrinsics in;
    in.projection = Projection::Telecentric;
    in.K << 100.0, 0, 1000.5, 0, 100.0, 750.25, 0, 0, 1;
    in.dist = std::move(dist);
    in.imageSize = {2000, 1500};
    Mat3 R;
    R << 1, 0, 0, 0, -1, 0, 0, 0, -1;
    return CameraModel(in, RigidTransform{R, -(R * Vec3(2, 3, 10))});
}

TEST(TelecentricCamera, PixelsAreHandComputedAndDoNotChangeWithDepth)
{
    const CameraModel cam = downwardTelecentric();
    EXPECT_TRUE(cam.isTelecentric());
    EXPECT_FALSE(cam.centre().has_value());
    // Camera frame: x = X − 2, y = −(Y − 3), z = 10 − Z.
    // (4.5, 1, Z): x = 2.5 mm, y = 2 mm → (1000.5 + 250, 750.25 + 200), at any depth.
    for (double Z : {10.0, 0.0, -40.0, 25.0}) {
        const auto p = cam.project({4.5, 1.0, Z});
        ASSERT_TRUE(p) << Z;
        EXPECT_NEAR(p->x(), 1250.5, 1e-9) << Z;
        EXPECT_NEAR(p->y(), 950.25, 1e-9) << Z;
    }
    // The scale is the same at every depth: 1/100 mm per pixel.
    EXPECT_DOUBLE_EQ(cam.millimetresPerPixelAt(5.0).x(), 0.01);
    EXPECT_DOUBLE_EQ(cam.millimetresPerPixelAt(500.0).y(), 0.01);
    // Every line of sight is the optical axis, −z.
    EXPECT_NEAR((cam.lineOfSight({-30, 7, 1}) - Vec3(0, 0, -1)).norm(), 0.0, 1e-15);
    EXPECT_NEAR((cam.lineOfSight({4, 4, 4}) - Vec3(0, 0, -1)).norm(), 0.0, 1e-15);
}

TEST(TelecentricCamera, DistortionActsOnMillimetresAsOpenCVsModel)
{
    // k1 = 1e-3 mm⁻², p1 = 2e-4 mm⁻¹: at (x, y) = (3, −4) mm, r² = 25,
    // radial 1 + 0.025 = 1.025; x_d = 3·1.025 + 2·2e-4·3·(−4) = 3.0702,
    // y_d = −4·1.025 + 2e-4·(25 + 2·16) = −4.0886.
    const CameraModel cam = downwardTelecentric({1e-3, 0.0, 2e-4, 0.0, 0.0});
    // Part point with camera x = 3, y = −4: X = 5, Y = 7.
    const auto p = cam.project({5, 7, 2});
    ASSERT_TRUE(p);
    EXPECT_NEAR(p->x(), 1000.5 + 100 * 3.0702, 1e-9);
    EXPECT_NEAR(p->y(), 750.25 - 100 * 4.0886, 1e-9);
}

TEST(TelecentricCamera, BackProjectionIsAParallelLineThroughTheUnprojectedPoint)
{
    const CameraModel cam = downwardTelecentric({-2e-4, 1e-6, 1e-5, -2e-5, 0.0});
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> px(0, 1999), py(0, 1499), depth(0, 20000);
    for (int i = 0; i < 200; ++i) {
        const Vec2 pixel(px(rng), py(rng));
        const Ray ray = cam.backProject(pixel);
        EXPECT_NEAR((ray.direction - cam.opticalAxis()).norm(), 0.0, 1e-15);
        // With no working distance stated the lines start 10 m before the focus plane (z = 10 − 1e4 in the part).
        EXPECT_NEAR(ray.origin.z(), 10.0 + 1e4, 1e-9);
        const auto back = cam.project(ray.origin + depth(rng) * ray.direction);
        ASSERT_TRUE(back);
        EXPECT_NEAR((*back - pixel).norm(), 0.0, 1e-7) << pixel.transpose();
    }
    // Undistorted: the pixel (1100.5, 650.25) is 1 mm right and 1 mm up (y = −1) of the axis.
    const Ray r = downwardTelecentric().backProject({1100.5, 650.25});
    EXPECT_NEAR(r.origin.x(), 3.0, 1e-12);
    EXPECT_NEAR(r.origin.y(), 4.0, 1e-12);
}

TEST(TelecentricCamera, TheLensFrontIsTheOnlyDepthLimitOfTheProjection)
{
    CameraModel unlimited = downwardTelecentric();
    // No working distance stated: even a point "behind" the focus plane by 1 m projects.
    EXPECT_TRUE(unlimited.project({2, 3, 1010}).has_value());
    Intrinsics in = unlimited.intrinsics();
    in.workingDistanceMm = 110.0;
    const CameraModel cam(in, unlimited.cameraFromPart());
    // The lens front is 110 mm above the focus plane (part z = 120); at it and beyond, nothing is imaged.
    EXPECT_TRUE(cam.project({2, 3, 119.9}).has_value());
    EXPECT_FALSE(cam.project({2, 3, 120.0}).has_value());
    EXPECT_FALSE(cam.project({2, 3, 130.0}).has_value());
    EXPECT_NEAR(cam.backProject({0, 0}).origin.z(), 120.0, 1e-12);
    EXPECT_NEAR(cam.rangeTo({7, -1, 4}), 116.0, 1e-12);
    EXPECT_NEAR((cam.sightOrigin({7, -1, 4}) - Vec3(7, -1, 120)).norm(), 0.0, 1e-12);
    in.workingDistanceMm = 0.0;
    EXPECT_THROW(in.validate(), std::invalid_argument);
}

TEST(TelecentricCamera, TheIntrinsicsJacobianIsTheProjectionsDerivative)
{
    const CameraModel cam = downwardTelecentric({-2e-4, 1e-6, 1e-5, -2e-5, 3e-9});
    const Vec3 X(6.0, -1.0, 3.0);
    const auto J = cam.intrinsicsJacobian(X);
    ASSERT_TRUE(J);
    // Central differences of project() in each parameter (fx, fy, cx, cy, k1, k2, p1, p2, k3).
    const double step[9] = {1e-3, 1e-3, 1e-3, 1e-3, 1e-7, 1e-9, 1e-7, 1e-7, 1e-11};
    for (int i = 0; i < 9; ++i) {
        auto moved = [&](double s) {
            Intrinsics in = cam.intrinsics();
            in.dist.resize(5, 0.0);
            if (i < 2) in.K(i, i) += s;
            if (i == 2) in.K(0, 2) += s;
            if (i == 3) in.K(1, 2) += s;
            const int k[9] = {-1, -1, -1, -1, 0, 1, 2, 3, 4};
            if (i >= 4) in.dist[static_cast<std::size_t>(k[i])] += s;
            return *CameraModel(in, cam.cameraFromPart()).project(X);
        };
        const Vec2 numeric = (moved(step[i]) - moved(-step[i])) / (2 * step[i]);
        EXPECT_NEAR((J->col(i) - numeric).norm(), 0.0, 1e-4 * std::max(1.0, numeric.norm())) << "parameter " << i;
    }
}

TEST(TelecentricCamera, FromAxesIsTheDataSheetModel)
{
    // Axes h = x, v = −y, a = −z through P0 = (2, 3, 10): the camera of downwardTelecentric().
    const auto cam = CameraModel::telecentricFromAxes(100.0, 100.0, 1000.5, 750.25, {2, 3, 10}, {1, 0, 0}, {0, -1, 0},
                                                      {0, 0, -1}, {2000, 1500});
    EXPECT_TRUE(cam.isTelecentric());
    const auto p = cam.project({4.5, 1.0, -3.0});
    ASSERT_TRUE(p);
    EXPECT_NEAR(p->x(), 1250.5, 1e-9);
    EXPECT_NEAR(p->y(), 950.25, 1e-9);
}

// HALCON's division model: undistorted = distorted / (1 + κ·r_d²), checked
// here from that definition, not from the camera's closed-form inverse.
TEST(TelecentricCamera, TheDivisionModelUndistortsByItsDefinition)
{
    Intrinsics in = downwardTelecentric().intrinsics();
    in.distortionModel = DistortionModel::Division;
    in.kappa = -2e-3; // mm⁻²
    const CameraModel cam(in, downwardTelecentric().cameraFromPart());
    EXPECT_TRUE(in.hasDistortion());
    for (const Vec3& X : {Vec3(5, 7, 2), Vec3(-3, 0.5, 9), Vec3(2, 3, -4), Vec3(9.5, -2, 0)}) {
        const auto p = cam.project(X);
        ASSERT_TRUE(p);
        // The distorted point from the pixel by hand (K = diag(100, 100), principal point (1000.5, 750.25)).
        const Vec2 d((p->x() - 1000.5) / 100.0, (p->y() - 750.25) / 100.0);
        // The undistorted point: camera x = X − 2, y = −(Y − 3).
        const Vec2 u(X.x() - 2.0, 3.0 - X.y());
        EXPECT_NEAR((d / (1.0 + in.kappa * d.squaredNorm()) - u).norm(), 0.0, 1e-12) << X.transpose();
        EXPECT_NEAR((cam.undistortPixel(*p) - u).norm(), 0.0, 1e-12) << X.transpose();
    }
    // κ > 0 has no distorted point beyond r_u² = 1/(4κ): 1/(4·0.01) = 25, r_u = 5 mm.
    in.kappa = 0.01;
    const CameraModel pincushion(in, downwardTelecentric().cameraFromPart());
    EXPECT_TRUE(pincushion.project({2 + 4.9, 3, 0}).has_value());
    EXPECT_FALSE(pincushion.project({2 + 5.1, 3, 0}).has_value());
    // It takes κ, not OpenCV's coefficients.
    in.dist = {0.1, 0, 0, 0, 0};
    EXPECT_THROW(in.validate(), std::invalid_argument);
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
