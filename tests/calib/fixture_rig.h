// A simulated rotation/declination fixture for the calibration tests.
#pragma once

#include <cmath>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "hullgauge/calib/fixture_axes.h"

namespace calibtest {

using namespace hg::calib;
using namespace hg::geometry;

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
                out.push_back(
                    {pose, viewFromCorners(board, "r" + std::to_string(int(theta)) + "_d" + std::to_string(int(phi)),
                                           pixels)});
            }
        return out;
    }
};

} // namespace calibtest
