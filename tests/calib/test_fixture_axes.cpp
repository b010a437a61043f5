#include <gtest/gtest.h>

#include <iostream>
#include <random>

#include "hullgauge/calib/fixture_axes.h"
#include "hullgauge/common/error.h"

using namespace hg::calib;
using namespace hg::geometry;

namespace {

/// A simulated rotation/declination fixture: camera above and in front of the
/// turntable, axes in the fixture frame (declination axis possibly skew and
/// not perpendicular), a 12x9 chessboard lying on the turntable. Corners are
/// projected with the product's CameraModel (distortion included) and get
/// Gaussian pixel noise.
struct Rig {
    Intrinsics camera;
    RigidTransform cameraFromFixture;
    AxisLine rotation{Vec3::Zero(), Vec3::UnitZ()};
    AxisLine declination;
    RigidTransform fixtureFromTarget;
    TargetSpec board = TargetSpec::parse("chessboard:12x9:10");
    double noisePx = 0.2;

    Rig(double skewMm, double tiltDeg)
    {
        camera.K << 2400, 0, 1020.5, 0, 2400, 770.25, 0, 0, 1;
        camera.dist = {-0.05, 0.02, 0, 0, 0};
        camera.imageSize = cv::Size(2048, 1536);
        // Camera 450 mm from the fixture origin, looking down 40 degrees.
        double el = degToRad(40.0);
        Vec3 centre(0.0, -450.0 * std::cos(el), 450.0 * std::sin(el));
        Vec3 zc = (-centre).normalized();
        Vec3 xc = Vec3::UnitX();
        Vec3 yc = zc.cross(xc);
        Mat3 fixtureFromCameraR;
        fixtureFromCameraR.col(0) = xc;
        fixtureFromCameraR.col(1) = yc;
        fixtureFromCameraR.col(2) = zc;
        cameraFromFixture = RigidTransform{fixtureFromCameraR, centre}.inverse();
        // Declination axis: along x, tilted `tiltDeg` towards z, `skewMm` off along y.
        declination.direction = Vec3(std::cos(degToRad(tiltDeg)), 0.0, std::sin(degToRad(tiltDeg)));
        declination.point = Vec3(0.0, skewMm, 0.0);
        // Board centred on the turntable, 20 mm above the origin, turned 10 degrees.
        fixtureFromTarget = RigidTransform::rotation(Vec3::UnitZ(), 10.0);
        fixtureFromTarget.t = Vec3(-55.0, -40.0, 20.0);
    }

    std::vector<FixtureView> views(unsigned seed) const
    {
        std::mt19937 rng(seed);
        std::normal_distribution<double> noise(0.0, noisePx);
        std::vector<FixtureView> out;
        for (double phi : {0.0, 15.0, 30.0, 45.0})
            for (double theta : {-60.0, -30.0, 0.0, 30.0, 60.0}) {
                FixturePose pose{theta, phi, 0.0};
                RigidTransform T = cameraFromFixture * rotationAboutLine(declination, phi) *
                                   rotationAboutLine(rotation, theta) * fixtureFromTarget;
                CameraModel cam(camera, T);
                std::vector<cv::Point2f> pixels;
                for (int id = 0; id < board.cornerCount(); ++id) {
                    auto p = board.cornerPosition(id);
                    auto px = cam.project(Vec3(p.x, p.y, p.z));
                    if (!px) throw std::logic_error("corner behind the camera");
                    pixels.emplace_back(static_cast<float>(px->x() + noise(rng)),
                                        static_cast<float>(px->y() + noise(rng)));
                }
                out.push_back({pose, viewFromCorners(board, "r" + std::to_string(int(theta)) + "_d" +
                                                                std::to_string(int(phi)),
                                                     pixels)});
            }
        return out;
    }
};

double angleBetweenDeg(const Vec3& a, const Vec3& b)
{
    return radToDeg(std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)));
}

/// Distance from point p to a line.
double distanceToLine(const Vec3& p, const AxisLine& l)
{
    Vec3 d = l.direction.normalized();
    Vec3 v = p - l.point;
    return (v - d * d.dot(v)).norm();
}

void expectRecovered(const Rig& rig, const FixtureAxesResult& r)
{
    // Axes in the camera frame: direction within 0.05 degrees, position
    // within 0.1 mm over the working volume (checked at the fixture origin
    // and 60 mm either side along each axis).
    AxisLine trueRot = {rig.cameraFromFixture.apply(rig.rotation.point),
                        rig.cameraFromFixture.applyToDirection(rig.rotation.direction)};
    AxisLine trueDec = {rig.cameraFromFixture.apply(rig.declination.point),
                        rig.cameraFromFixture.applyToDirection(rig.declination.direction)};
    EXPECT_LT(angleBetweenDeg(r.rotationAxisInCamera.direction, trueRot.direction), 0.05);
    EXPECT_LT(angleBetweenDeg(r.declinationAxisInCamera.direction, trueDec.direction), 0.05);
    for (double s : {-60.0, 0.0, 60.0}) {
        EXPECT_LT(distanceToLine(trueRot.point + s * trueRot.direction, r.rotationAxisInCamera), 0.1) << s;
        EXPECT_LT(distanceToLine(trueDec.point + s * trueDec.direction, r.declinationAxisInCamera), 0.1) << s;
    }
    // The fixture frame follows the same convention as the rig's: same pose.
    EXPECT_LT(rotationAngleDeg(r.cameraFromFixture.R, rig.cameraFromFixture.R), 0.05);
    EXPECT_LT((r.cameraFromFixture.t - rig.cameraFromFixture.t).norm(), 0.1);
    EXPECT_LT(angleBetweenDeg(r.declinationAxis, rig.declination.direction), 0.05);
    EXPECT_LT((r.declinationAxisPoint - rig.declination.point).norm(), 0.1);
    EXPECT_NEAR(r.axesDistanceMm, rig.declination.point.norm(), 0.1);
    EXPECT_NEAR(r.axesAngleDeg, angleBetweenDeg(rig.rotation.direction, rig.declination.direction), 0.05);
    EXPECT_NEAR(r.rmsPx, rig.noisePx * std::sqrt(2.0), 0.05);
    // Object-space residual: the pixel residual at the target's depth (~450 mm) over f = 2400 px.
    EXPECT_NEAR(r.rmsMm, r.rmsPx * 450.0 / 2400.0, 0.2 * r.rmsPx * 450.0 / 2400.0);
}

}  // namespace

TEST(FixtureAxes, SkewNonPerpendicularAxesAreRecovered)
{
    Rig rig(0.6, 0.3);
    auto result = calibrateFixtureAxes(rig.views(11), rig.camera);
    std::cout << formatFixtureReport(result);
    expectRecovered(rig, result);
    // The full model predicts unseen poses: target corners within 0.1 mm.
    FixturePose unseen{45.0, 20.0, 0.0};
    RigidTransform truth = rig.cameraFromFixture * rotationAboutLine(rig.declination, 20.0) *
                           rotationAboutLine(rig.rotation, 45.0) * rig.fixtureFromTarget;
    RigidTransform predicted = result.cameraFromTarget(unseen);
    for (int id : {0, 11, 96, 107}) {
        auto p = rig.board.cornerPosition(id);
        Vec3 x(p.x, p.y, p.z);
        EXPECT_LT((truth.apply(x) - predicted.apply(x)).norm(), 0.1) << id;
    }
}

TEST(FixtureAxes, IntersectingPerpendicularAxesGiveTheContractModel)
{
    Rig rig(0.0, 0.0);
    auto result = calibrateFixtureAxes(rig.views(5), rig.camera);
    expectRecovered(rig, result);
    EXPECT_LT(result.axesDistanceMm, 0.1);
    // With intersecting axes the CONTRACTS §2 kinematics reproduce the rig.
    auto k = result.kinematics();
    FixturePose pose{-20.0, 35.0, 0.0};
    RigidTransform truth = rig.cameraFromFixture * rotationAboutLine(rig.declination, 35.0) *
                           rotationAboutLine(rig.rotation, -20.0);
    RigidTransform model = k.cameraFromPart(pose);
    EXPECT_LT(rotationAngleDeg(model.R, truth.R), 0.05);
    EXPECT_LT((model.t - truth.t).norm(), 0.1);
}

TEST(FixtureAxes, ViewsThatDoNotIsolateAnAxisAreBadInput)
{
    Rig rig(0.0, 0.0);
    auto all = rig.views(3);
    std::vector<FixtureView> onlyRotation;
    for (const auto& v : all)
        if (v.pose.declinationDeg == 0.0) onlyRotation.push_back(v);
    try {
        (void)calibrateFixtureAxes(onlyRotation, rig.camera);
        ADD_FAILURE() << "accepted views without a declination change";
    } catch (const hg::InputError& e) {
        EXPECT_NE(std::string(e.what()).find("different declinations"), std::string::npos) << e.what();
    }
}
