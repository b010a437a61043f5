// Inspection through a telecentric camera (docs/telecentric.md) at 0.01 mm
// per pixel, on frames the code under test did not render: the independent
// renderer (hgtest/exact_render.h) draws the telecentric camera's
// orthographic image with its own mapping. The fig. 3.5 post widened or
// narrowed by known amounts, seen along the grazing directions of
// tests/support/parts.h, as the pinhole accuracy tests see it
// (tests/inspect/test_deviation.cpp, tests/study/test_mastering.cpp).
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <random>

#include "hgtest/exact_render.h"
#include "hgtest/parts.h"
#include "hullgauge/inspect/deviation.h"
#include "hullgauge/inspect/inspector.h"

namespace {

using hg::geometry::CameraModel;
using hg::geometry::Vec3;

// 0.01 mm per pixel: a 0.5x lens on 5 µm pixels; 2400 x 1800 px see 24 x 18 mm.
constexpr double kPxPerMm = 100.0;
const cv::Size kImage{2400, 1800};

/// The telecentric camera looking along `pinhole`'s optical axis: the same
/// rotation, the axis through the same points, its focus plane (z = 0)
/// through the point of the axis nearest `centre` (the part's middle).
CameraModel telecentricAlong(const CameraModel& pinhole, const Vec3& centre)
{
    const Vec3 a = pinhole.opticalAxis();
    const Vec3 C = *pinhole.centre();
    const Vec3 onAxis = C + (centre - C).dot(a) * a;
    hg::geometry::Intrinsics in;
    in.projection = hg::geometry::Projection::Telecentric;
    in.K << kPxPerMm, 0, (kImage.width - 1) / 2.0, 0, kPxPerMm, (kImage.height - 1) / 2.0, 0, 0, 1;
    in.imageSize = kImage;
    const hg::geometry::Mat3& R = pinhole.cameraFromPart().R;
    return CameraModel(in, hg::geometry::RigidTransform{R, -(R * onAxis)});
}

/// One grazing view of every landmark and two random views of the part, telecentric.
std::vector<CameraModel> telecentricViews(const hgtest::TestPart& part, const hgtest::PartAsMade& made,
                                          std::uint64_t seed)
{
    std::mt19937_64 rng(seed);
    std::vector<CameraModel> out;
    for (const CameraModel& c : hgtest::grazingViewSet(part, &made, 2, rng))
        out.push_back(telecentricAlong(c, part.mesh.bounds().center()));
    return out;
}

/// Frames of `mesh` in every camera by the independent renderer, blur 0.6 px
/// and noise σ = 1.5 grey levels; view i's part moved by shift[i] (mm, part frame).
std::vector<hg::inspect::CapturedView> exactFrames(const hg::model::TriangleMesh& mesh,
                                                   const std::vector<CameraModel>& cameras,
                                                   const std::vector<Vec3>& shift, std::uint64_t seed)
{
    std::vector<hg::inspect::CapturedView> views;
    for (std::size_t i = 0; i < cameras.size(); ++i) {
        hg::model::TriangleMesh moved = mesh;
        for (Vec3& v : moved.vertices) v += shift[i];
        views.push_back({"v" + std::to_string(i), cameras[i], hgtest::lineFrame({moved}, cameras[i], seed, i)});
    }
    return views;
}

struct Tally {
    int measured = 0, withinU = 0;
    double worst = 0.0, largestU = 0.0;
};

TEST(Telecentric, ThePostIsMeasuredToFiveMicrometresOnIndependentFramesAtAHundredthOfAMillimetrePerPixel)
{
    const hgtest::TestPart post = hgtest::postPart();
    const auto map = post.map();
    const hg::inspect::Inspector inspector(map, {}, nullptr, std::make_shared<hg::inspect::DeviationGauge>(post.solid));
    Tally tally;
    std::uint64_t seed = 300;
    // Within the sub-voxel step's reach: its edge band is 5 px either side of
    // the CAD outline, 0.05 mm at this scale, less the blurred edge's own width.
    for (double b : {0.0, 0.02, -0.02, 0.03, -0.03}) {
        // Every side of the post moved by b/√2: the vertical edges by b along their bisectors.
        const auto made = hgtest::postWidened(post, b / std::sqrt(2.0));
        SCOPED_TRACE("offset " + std::to_string(b));
        const auto cameras = telecentricViews(post, made, seed);
        const auto result = inspector.inspect(
            exactFrames(made.mesh, cameras, std::vector<Vec3>(cameras.size(), Vec3::Zero()), seed), {});
        ++seed;
        for (const auto& lr : result.landmarks) {
            ASSERT_TRUE(lr.deviation && lr.deviation->measured) << lr.id << ": " << lr.deviation->reason;
            const double truth = made.offsetMm[post.landmark(lr.id)];
            const double error = std::abs(lr.deviation->deviationMm - truth), U = lr.deviation->uncertaintyMm;
            EXPECT_LE(error, 0.005) << lr.id << ": " << lr.deviation->deviationMm << " mm, true " << truth;
            ++tally.measured;
            tally.withinU += error <= U;
            tally.worst = std::max(tally.worst, error);
            tally.largestU = std::max(tally.largestU, U);
        }
    }
    std::cout << tally.measured << " landmarks at 0.01 mm/px (telecentric): worst |deviation - truth| " << tally.worst
              << " mm, largest U " << tally.largestU << " mm, truth within U at " << tally.withinU << "\n";
    EXPECT_EQ(tally.measured, 20);
    EXPECT_GE(tally.withinU, static_cast<int>(std::ceil(0.95 * tally.measured)));
}

TEST(Telecentric, APartSeatedHalfAMillimetreNearerTheLensIsMeasuredTheSame)
{
    // In every view the part lies 0.5 mm nearer the lens than the cameras
    // assume (moved against each view's optical axis), the frames otherwise
    // the same: a telecentric lens's image does not grow, so neither does
    // the reading (on a pinhole station at 400 mm it would be a 0.1 % scale).
    const hgtest::TestPart post = hgtest::postPart();
    const auto map = post.map();
    const hg::inspect::Inspector inspector(map, {}, nullptr, std::make_shared<hg::inspect::DeviationGauge>(post.solid));
    const auto made = hgtest::postWidened(post, 0.03);
    const auto cameras = telecentricViews(post, made, 41);
    std::vector<Vec3> asAssumed(cameras.size(), Vec3::Zero()), nearer;
    for (const CameraModel& c : cameras) nearer.push_back(-0.5 * c.opticalAxis());
    const auto seated = inspector.inspect(exactFrames(made.mesh, cameras, asAssumed, 41), {});
    const auto closer = inspector.inspect(exactFrames(made.mesh, cameras, nearer, 41), {});
    ASSERT_EQ(seated.landmarks.size(), closer.landmarks.size());
    double largest = 0.0;
    for (std::size_t i = 0; i < seated.landmarks.size(); ++i) {
        const auto& a = seated.landmarks[i].deviation;
        const auto& b = closer.landmarks[i].deviation;
        ASSERT_TRUE(a && a->measured && b && b->measured) << seated.landmarks[i].id;
        EXPECT_NEAR(b->deviationMm, a->deviationMm, 0.002) << seated.landmarks[i].id;
        // Both against the truth, 0.03·√2 mm at the post's edges.
        EXPECT_NEAR(b->deviationMm, 0.03 * std::sqrt(2.0), 0.005) << seated.landmarks[i].id;
        largest = std::max(largest, std::abs(b->deviationMm - a->deviationMm));
    }
    std::cout << "seated 0.5 mm nearer the lens: the readings moved by at most " << largest << " mm\n";
}

} // namespace
