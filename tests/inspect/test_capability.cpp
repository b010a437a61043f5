// The capability check (docs/inspection.md, "Capability"): the uncertainty
// the gauge expects before any frame against the one it then measures on
// rendered frames of the same views, and the 4:1 rule on hand-set zones.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "hgtest/parts.h"
#include "hullgauge/inspect/capability.h"
#include "hullgauge/inspect/inspector.h"
#include "hullgauge/sim/renderer.h"

namespace {

using hg::inspect::assessCapability;
using hg::inspect::DeviationGauge;

struct Rendered {
    hgtest::TestPart post = hgtest::postPart();
    std::vector<hg::geometry::CameraModel> cameras;
    std::vector<hg::inspect::CapturedView> frames;
    hg::geometry::ImageQuality quality;
};

// The post's views at f = 6000 px, 260-380 mm (0.043-0.063 mm per pixel),
// frames with noise σ = 1.5 grey levels and the renderer's levels.
Rendered render(std::uint64_t seed)
{
    Rendered r;
    hgtest::GrazingOptions o;
    o.camera.focalPx = 6000.0;
    const auto made = hgtest::asDesigned(r.post);
    std::mt19937_64 rng(seed);
    r.cameras = hgtest::grazingViewSet(r.post, &made, 2, rng, o);
    const hg::sim::SilhouetteRenderer renderer({made.mesh});
    hg::sim::RenderOptions ro;
    ro.noiseSigma = 1.5;
    ro.blurSigmaPx = 0.6;
    for (std::size_t i = 0; i < r.cameras.size(); ++i) {
        ro.seed = seed + i;
        r.frames.push_back({"v" + std::to_string(i), r.cameras[i], renderer.render(r.cameras[i], ro)});
    }
    r.quality = {1.5, (ro.backgroundLevel - ro.objectLevel) * 255.0, true};
    return r;
}

TEST(Capability, TheExpectedUncertaintyIsTheOneTheFramesThenGive)
{
    const Rendered r = render(41);
    const auto map = r.post.map();
    const auto gauge = std::make_shared<DeviationGauge>(r.post.solid);
    const auto expected = assessCapability(map.landmarks(), map.frame().voxelSize(), gauge.get(), r.cameras, r.quality);
    const hg::inspect::Inspector inspector(map, {}, nullptr, gauge);
    const auto measured = inspector.inspect(r.frames, {});
    ASSERT_EQ(expected.size(), measured.landmarks.size());
    for (std::size_t i = 0; i < expected.size(); ++i) {
        const auto& d = *measured.landmarks[i].deviation;
        ASSERT_TRUE(d.measured) << expected[i].id;
        EXPECT_FALSE(expected[i].bracket) << expected[i].id;
        EXPECT_EQ(expected[i].views, static_cast<int>(d.views.size())) << expected[i].id;
        // The same views, the same method and tilt terms; the edge noise
        // predicted instead of read from the frame: within a quarter.
        EXPECT_NEAR(expected[i].expectedMm, d.uncertaintyMm, 0.25 * d.uncertaintyMm)
            << expected[i].id << ": expected " << expected[i].expectedMm << ", measured " << d.uncertaintyMm;
    }
}

TEST(Capability, AZoneNarrowerThanFourUIsRefusedAndTheBracketNeedsAVoxel)
{
    const Rendered r = render(42);
    auto landmarks = r.post.map().landmarks();
    const auto gauge = std::make_shared<DeviationGauge>(r.post.solid);
    const double dv = r.post.map().frame().voxelSize();
    // ±0.005 mm: a zone of 0.01 mm, below 4 U (U ≈ 0.006-0.009 mm here).
    for (auto& l : landmarks) l.toleranceMm = 0.005;
    for (const auto& c : assessCapability(landmarks, dv, gauge.get(), r.cameras, r.quality)) {
        EXPECT_FALSE(c.capable) << c.id;
        EXPECT_DOUBLE_EQ(c.zoneMm, 0.01);
        const std::string why = hg::inspect::describe(c);
        EXPECT_NE(why.find(c.id), std::string::npos) << why;
        EXPECT_NE(why.find("cannot prove"), std::string::npos) << why;
    }
    // ±0.05 mm: 0.1 mm ≥ 4 U.
    for (auto& l : landmarks) l.toleranceMm = 0.05;
    for (const auto& c : assessCapability(landmarks, dv, gauge.get(), r.cameras, r.quality))
        EXPECT_TRUE(c.capable) << hg::inspect::describe(c);
    // Limits [−0.01, 0.09]: the zone is their difference.
    landmarks[0].limitsMm = std::make_pair(-0.01, 0.09);
    EXPECT_DOUBLE_EQ(assessCapability(landmarks, dv, gauge.get(), r.cameras, r.quality)[0].zoneMm, 0.1);
    // Without the gauge the bracket decides: U = ΔV/2, so a tolerance must reach ΔV.
    for (auto& l : landmarks) l.limitsMm.reset();
    landmarks[0].toleranceMm = dv;
    landmarks[1].toleranceMm = 0.99 * dv;
    const auto bracket = assessCapability(landmarks, dv, nullptr, r.cameras, r.quality);
    EXPECT_TRUE(bracket[0].bracket);
    EXPECT_DOUBLE_EQ(bracket[0].expectedMm, dv / 2.0);
    EXPECT_TRUE(bracket[0].capable);
    EXPECT_FALSE(bracket[1].capable);
}

} // namespace

namespace {

// The station's health against the capability bound (docs/health.md,
// "Capability"). Worked by hand: one view whose edge noise is 0.003 mm and
// whose tilt term is 0.002 mm (its outline moving 10⁹ px per mm: no method
// share) in a zone of 0.1 mm; at twice the planned edge σ, U = 2·√(0.006² +
// 0.002²) = 0.0126491 mm and 4 U / zone = 0.505964. A bracket landmark keeps
// U = 0.01 mm (0.4 of a 0.1 mm zone); one the check found not capable does not count.
TEST(Capability, TheShareOfTheBoundFollowsTheEdgeNoiseWorkedByHand)
{
    hg::inspect::LandmarkCapability gauged;
    gauged.zoneMm = 0.1;
    gauged.capable = true;
    gauged.prediction = hg::inspect::combine({{"v0", 0.0, 0.003, 1e9, 0.002, 0.0}}, 0.0);
    gauged.expectedMm = gauged.prediction.uncertaintyMm;
    ASSERT_NEAR(gauged.expectedMm, 2.0 * std::sqrt(0.003 * 0.003 + 0.002 * 0.002), 1e-9);
    hg::inspect::LandmarkCapability bracket;
    bracket.zoneMm = 0.1;
    bracket.capable = true;
    bracket.bracket = true;
    bracket.expectedMm = 0.01;
    hg::inspect::LandmarkCapability unproven = gauged;
    unproven.capable = false;
    unproven.zoneMm = 0.001;
    using hg::inspect::capabilityUsed;
    EXPECT_NEAR(capabilityUsed({gauged, bracket, unproven}, 0.05, 0.10), 0.505964, 1e-6);
    EXPECT_NEAR(capabilityUsed({gauged}, 0.05, 0.05), 4.0 * gauged.expectedMm / 0.1, 1e-9);
    EXPECT_NEAR(capabilityUsed({gauged, bracket}, 0.05, 0.05), 0.4, 1e-12); // the bracket's is the larger
    EXPECT_NEAR(capabilityUsed({bracket, unproven}, 0.05, 0.5), 0.4, 1e-12);
    EXPECT_TRUE(std::isnan(capabilityUsed({unproven}, 0.05, 0.1)));
    EXPECT_TRUE(std::isnan(capabilityUsed({gauged}, 0.0, 0.1)));
    EXPECT_TRUE(std::isnan(capabilityUsed({gauged}, 0.05, std::nan(""))));
}

// Against the gauge itself: the post's assessment at the planned image quality,
// scaled to three times the edge σ, is the assessment the gauge makes at three
// times the noise (the edge σ is proportional to it), landmark by landmark's worst.
TEST(Capability, TheShareOfTheBoundIsTheGaugesAtTheNoiseThatGivesThatSigma)
{
    const Rendered r = render(41);
    const auto map = r.post.map();
    const auto gauge = std::make_shared<DeviationGauge>(r.post.solid);
    auto landmarks = map.landmarks();
    for (auto& l : landmarks) l.toleranceMm = 0.05;
    const double dv = map.frame().voxelSize();
    const auto planned = assessCapability(landmarks, dv, gauge.get(), r.cameras, r.quality);
    hg::geometry::ImageQuality noisy = r.quality;
    noisy.noiseGrey *= 3.0;
    double worst = 0.0;
    for (const auto& c : assessCapability(landmarks, dv, gauge.get(), r.cameras, noisy))
        worst = std::max(worst, hg::inspect::kTestUncertaintyRatio * c.expectedMm / c.zoneMm);
    EXPECT_NEAR(hg::inspect::capabilityUsed(planned, 0.1, 0.3), worst, 1e-9 * worst);
    EXPECT_GT(worst, 0.0);
}

} // namespace
