// The twin's pieces against independent expectations: seats drawn within the
// play (and filling it), the frame margin of a box seen face-on computed by
// hand, the render options that give the station's contrast, and a cycle on
// the twin whose seat is measured to the drawn one.
#include "hgtest/station.h"
#include "hullgauge/commission/twin.h"
#include "hullgauge/inspect/part_map.h"
#include "hullgauge/model/primitives.h"
#include "hullgauge/plan/program_plan.h"

#include <cmath>
#include <gtest/gtest.h>

namespace hg::commission {
namespace {

using Eigen::Vector3d;

TEST(DrawSeat, StaysWithinThePlayAndFillsIt)
{
    std::mt19937_64 rng(3);
    const Vector3d c(5, -2, 7);
    double largestShift = 0.0, largestAngle = 0.0;
    for (int i = 0; i < 2000; ++i) {
        const geometry::RigidTransform s = drawSeat(rng, 0.3, 0.5, c);
        // The centre moves by the shift alone (the rotation is about it).
        const double shift = (s.apply(c) - c).norm();
        const double angle = geometry::rotationAngleDeg(geometry::Mat3::Identity(), s.R);
        ASSERT_LE(shift, 0.3 + 1e-12);
        ASSERT_LE(angle, 0.5 + 1e-9);
        largestShift = std::max(largestShift, shift);
        largestAngle = std::max(largestAngle, angle);
    }
    // Uniform in the ball: P(r < 0.95 R) = 0.857 per draw; 2000 draws all below is impossible in practice.
    EXPECT_GT(largestShift, 0.95 * 0.3);
    EXPECT_GT(largestAngle, 0.95 * 0.5);
}

TEST(FrameMargin, ABoxSeenFaceOnLiesWhereThePinholePutsIt)
{
    // Camera along the turntable axis: X_cam = X + (0, 0, 300), f = 800 px,
    // 640 x 480, principal point (320, 240). A box 40 x 30 x 20 mm about the
    // origin: its face z = -10 is nearest the camera (depth 290) and
    // projects largest, its corners at (320 ± 20·800/290, 240 ± 15·800/290).
    // The sensor's edge lies half a pixel beyond the last pixel centre, so the
    // right edge is at 639.5 and the bottom at 479.5: the margins there are
    // 319.5 − 20·800/290 and 239.5 − 15·800/290, the second the smaller.
    const geometry::Station st = hgtest::station({.mount = hgtest::CameraMount::Axis});
    const model::TriangleMesh box = model::makeBox(Vector3d(-20, -15, -10), Vector3d(20, 15, 10));
    const geometry::CameraModel cam = st.cameraAt({});
    EXPECT_NEAR(plan::frameMarginPx(box, cam), 239.5 - 15.0 * 800.0 / 290.0, 1e-9);
    // A box wider than the field is cut: negative margin.
    const model::TriangleMesh wide = model::makeBox(Vector3d(-200, -15, -10), Vector3d(200, 15, 10));
    EXPECT_LT(plan::frameMarginPx(wide, cam), 0.0);
}

TEST(TwinRenderOptions, GiveTheStationsContrastNoiseAndBlur)
{
    geometry::ImageQuality q;
    q.noiseGrey = 1.5;
    q.contrastGrey = 224.4;
    q.blurSigmaPx = 0.6;
    const sim::RenderOptions o = twinRenderOptions(q, 9);
    EXPECT_NEAR((o.backgroundLevel - o.objectLevel) * 255.0, 224.4, 1e-9);
    EXPECT_DOUBLE_EQ(o.noiseSigma, 1.5);
    EXPECT_DOUBLE_EQ(o.blurSigmaPx, 0.6);
    EXPECT_EQ(o.seed, 9u);
    EXPECT_EQ(o.bitDepth, 8);
}

} // namespace
} // namespace hg::commission
