// Mastering (docs/mastering.md): the correction's arithmetic and its
// uncertainty worked by hand, the certificate's validation, and the station's
// edge bias taken out by a master on frames the twin did not render.
#include "hgtest/exact_render.h"
#include "hgtest/parts.h"
#include "hgtest/paths.h"
#include "hullgauge/common/error.h"
#include "hullgauge/inspect/correction.h"
#include "hullgauge/inspect/inspector.h"
#include "hullgauge/model/primitives.h"
#include "hullgauge/study/mastering.h"

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <random>

namespace hg::study {
namespace {

using inspect::CorrectionSet;
using inspect::LandmarkCorrection;
using inspect::MasterPoint;

TEST(Correction, OnePointIsAnOffsetWithTheCertificateAndTheMeanInItsUncertainty)
{
    // Certified 0.010 mm, U 0.004 mm; 4 readings with mean −0.003 mm and s 0.002 mm.
    const LandmarkCorrection c{"a", {MasterPoint{"M1", 0.010, 0.004, -0.003, 0.002, 4}}};
    EXPECT_DOUBLE_EQ(c.gain(), 1.0);
    EXPECT_NEAR(c.offsetMm(), 0.013, 1e-15);
    EXPECT_NEAR(c.correct(0.050), 0.063, 1e-15);
    // u² = (0.004/2)² + (0.002/√4)² = 4e-6 + 1e-6; U = 2·√5e-6 = 0.0044721 mm, whatever the reading.
    EXPECT_NEAR(c.uncertaintyAt(0.05), 2.0 * std::sqrt(5e-6), 1e-12);
    EXPECT_NEAR(c.uncertaintyAt(-0.3), 2.0 * std::sqrt(5e-6), 1e-12);
}

TEST(Correction, TwoPointsGiveOffsetAndGainAndTheUncertaintyBetweenThem)
{
    // Master 1 certified 0 reads −0.01; master 2 certified 0.5 reads 0.48:
    // g = 0.5 / 0.49, a = g·0.01; both U 0.002, s 0.001 over 4 cycles (u of the mean 0.0005).
    const LandmarkCorrection c{
        "a", {MasterPoint{"M1", 0.0, 0.002, -0.01, 0.001, 4}, MasterPoint{"M2", 0.5, 0.002, 0.48, 0.001, 4}}};
    const double g = 0.5 / 0.49;
    EXPECT_NEAR(c.gain(), g, 1e-15);
    EXPECT_NEAR(c.offsetMm(), 0.01 * g, 1e-15);
    EXPECT_NEAR(c.correct(0.2), 0.01 * g + 0.2 * g, 1e-15);
    EXPECT_NEAR(c.correct(-0.01), 0.0, 1e-15);
    EXPECT_NEAR(c.correct(0.48), 0.5, 1e-15);
    // Each point's share: (U/2)² + g²·(s/√n)² = 1e-6 + g²·2.5e-7. At a master's reading only
    // that master counts (t = 0 or 1); half-way (t = ½) a quarter of each.
    const double share = 1e-6 + g * g * 2.5e-7;
    EXPECT_NEAR(c.uncertaintyAt(-0.01), 2.0 * std::sqrt(share), 1e-12);
    EXPECT_NEAR(c.uncertaintyAt(0.48), 2.0 * std::sqrt(share), 1e-12);
    EXPECT_NEAR(c.uncertaintyAt(0.235), 2.0 * std::sqrt(0.25 * share + 0.25 * share), 1e-12);
}

TEST(Correction, ThermalOffsetIsTheExpansionAlongTheNormal)
{
    // Steel 11.5e-6/K at 25 °C, 50 mm from the centre along the normal: 11.5e-6 · 5 · 50 = 0.002875 mm.
    EXPECT_NEAR(inspect::thermalOffsetMm(11.5e-6, 25.0, {50, 0, 0}, {1, 0, 0}, {0, 0, 0}), 0.002875, 1e-15);
    // Across the normal nothing moves; below 20 °C the part shrinks.
    EXPECT_NEAR(inspect::thermalOffsetMm(11.5e-6, 25.0, {0, 50, 0}, {1, 0, 0}, {0, 0, 0}), 0.0, 1e-15);
    EXPECT_NEAR(inspect::thermalOffsetMm(23e-6, 10.0, {10, 0, 0}, {2, 0, 0}, {-10, 0, 0}), -0.0046, 1e-15);
}

TEST(Correction, TheSetRoundTripsThroughItsFileAndABadFileIsNamed)
{
    CorrectionSet set;
    set.id = "p1-v3-steel-20260412T081500Z";
    set.program = 1;
    set.programVersion = 3;
    set.material = "steel";
    set.createdUnixMs = 1776000000000;
    set.temperatureC = 20.5;
    set.landmarks.push_back({"a", {MasterPoint{"M1", 0.01, 0.004, -0.003, 0.002, 4}}});
    hgtest::TempDir dir;
    inspect::saveCorrectionSet(set, dir / "set.json");
    const CorrectionSet back = inspect::loadCorrectionSet(dir / "set.json");
    EXPECT_EQ(back.id, set.id);
    EXPECT_EQ(back.programVersion, 3);
    EXPECT_EQ(back.material, "steel");
    ASSERT_EQ(back.landmarks.size(), 1u);
    EXPECT_DOUBLE_EQ(back.landmarks[0].offsetMm(), 0.013);
    EXPECT_EQ(back.method(), inspect::MasteringMethod::OnePoint);

    auto j = inspect::toJson(set);
    j["landmarks"][0]["points"][0]["measured_mm"] = "x";
    try {
        inspect::correctionSetFromJson(j, "set.json");
        FAIL() << "a text where a number belongs was accepted";
    } catch (const InputError& e) {
        EXPECT_EQ(e.field(), "landmarks[0].points[0].measured_mm");
    }
}

TEST(MasterCertificate, IsReadStrictlyWithTheLineOfWhatIsWrong)
{
    hgtest::TempDir dir;
    const auto good = hgtest::writeFile(dir / "m.yaml", "master: M-1\n"
                                                        "certificate: CMM report 4711\n"
                                                        "landmarks:\n"
                                                        "  a: {value_mm: 0.004, uncertainty_mm: 0.002}\n"
                                                        "  b: {value_mm: -0.01, uncertainty_mm: 0.003}\n");
    const MasterCertificate m = loadMasterCertificate(good);
    EXPECT_EQ(m.serial, "M-1");
    ASSERT_EQ(m.landmarks.size(), 2u);
    EXPECT_DOUBLE_EQ(m.landmarks.at("b").valueMm, -0.01);
    EXPECT_EQ(m.landmarks.at("b").line, 5);

    const auto typo = hgtest::writeFile(dir / "t.yaml", "master: M-1\n"
                                                        "landmarks:\n"
                                                        "  a: {value_mm: 0.004, uncertainty: 0.002}\n");
    try {
        loadMasterCertificate(typo);
        FAIL() << "a misspelt key was accepted";
    } catch (const InputError& e) {
        EXPECT_EQ(e.line(), 3);
        EXPECT_NE(std::string(e.what()).find("uncertainty"), std::string::npos) << e.what();
    }
    const auto negative = hgtest::writeFile(dir / "n.yaml", "master: M-1\n"
                                                            "landmarks:\n"
                                                            "  a: {value_mm: 0.004, uncertainty_mm: -1}\n");
    EXPECT_THROW(loadMasterCertificate(negative), InputError);
}

// ---------------------------------------------------------------------------
// The edge bias: frames of the fig. 3.5 post (tests/support/parts.h) rendered
// by the independent renderer (hgtest/exact_render.h) with the silhouette
// 0.25 px smaller all round where the deviation reads it. How: an equivalent
// offset surface per camera. Each camera grazes one of the post's vertical
// edges; its outline there and at the opposite edge are those two edges (the
// extremes across the line of sight). Moving the two faces of such an edge
// inward by s moves the edge by s·(n₁ + n₂); s is chosen per camera and edge
// so that the edge's image moves 0.25 px across itself at the landmarks'
// height (found by projecting, linear in s for these hundredths of a
// millimetre). The base, 10 mm below and never read, is left as it is.
// ---------------------------------------------------------------------------

constexpr double kBiasPx = 0.25;

/// Pixels the image of the vertical edge through `p` moves across itself per
/// millimetre the edge moves along `d`.
double pxPerMmAcross(const geometry::CameraModel& camera, const geometry::Vec3& p, const geometry::Vec3& d)
{
    const geometry::Vec2 a = *camera.project(p), up = *camera.project(p + geometry::Vec3(0, 0, 1));
    const geometry::Vec2 along = (up - a).normalized();
    const geometry::Vec2 moved = *camera.project(p + 1e-3 * d) - a;
    return std::abs(moved.x() * along.y() - moved.y() * along.x()) / 1e-3;
}

/// Side offsets (outward, mm) of the post's faces −x, +x, −y, +y in one camera: `widenMm`
/// (the part as made) less the bias at the two edges this camera sees on its outline.
std::array<double, 4> sideOffsets(const geometry::CameraModel& camera, const hgtest::TestPart& post, std::size_t grazed,
                                  double widenMm)
{
    std::array<double, 4> offset{widenMm, widenMm, widenMm, widenMm};
    const std::size_t opposite = (grazed + 2) % 4; // c-nn, c-pn, c-pp, c-np: opposite corners two apart
    for (std::size_t k : {grazed, opposite}) {
        const inspect::MapLandmark& lm = post.landmarks[k];
        const geometry::Vec3 both(std::copysign(1.0, lm.normal.x()), std::copysign(1.0, lm.normal.y()), 0.0);
        const double s = kBiasPx / pxPerMmAcross(camera, lm.position, both);
        offset[lm.normal.x() < 0 ? 0 : 1] -= s;
        offset[lm.normal.y() < 0 ? 2 : 3] -= s;
    }
    return offset;
}

struct BiasedStation {
    hgtest::TestPart post = hgtest::postPart();
    inspect::InspectionMap map = post.map();
    std::vector<geometry::CameraModel> cameras;
    inspect::Inspector inspector{map, {}, nullptr, std::make_shared<inspect::DeviationGauge>(post.solid)};

    BiasedStation()
    {
        std::mt19937_64 rng(36);
        hgtest::GrazingOptions o;
        o.camera.focalPx = 6000.0; // 0.043-0.063 mm per pixel at 260-380 mm
        cameras = hgtest::grazingViewSet(post, nullptr, 0, rng, o);
    }

    /// One cycle: the post widened by `widenMm` on every side, frames biased as above.
    inspect::InspectionResult cycle(double widenMm, std::uint64_t seed, const CorrectionSet* correction) const
    {
        std::vector<inspect::CapturedView> views;
        for (std::size_t i = 0; i < cameras.size(); ++i) {
            const auto o = sideOffsets(cameras[i], post, i, widenMm);
            const std::vector<model::TriangleMesh> meshes{
                model::makeBox({0, 0, 0}, {24, 24, 4}),
                model::makeBox({9 - o[0], 9 - o[2], 4}, {15 + o[1], 15 + o[3], 24})};
            views.push_back({"v" + std::to_string(i), cameras[i], hgtest::lineFrame(meshes, cameras[i], seed, i)});
        }
        inspect::DeviationReferral referral;
        referral.correction = correction;
        return inspector.inspect(views, {}, referral);
    }
};

TEST(Mastering, OnePointMasteringTakesOutTheEdgeBiasOfIndependentlyRenderedFrames)
{
    const BiasedStation station;
    ASSERT_EQ(station.cameras.size(), 4u);
    // The master: the nominal post, certified 0 at every landmark with U 0.002 mm; 5 cycles.
    MasterCertificate master;
    master.file = "master.yaml";
    master.serial = "M-1";
    for (const auto& lm : station.post.landmarks) master.landmarks[lm.id] = {0.0, 0.002, 0};
    std::vector<StudyRecord> masterCycles;
    for (std::uint64_t k = 0; k < 5; ++k)
        masterCycles.push_back({static_cast<std::int64_t>(k + 1), "M-1",
                                inspect::toJson(station.cycle(0.0, 1 + k, nullptr))["landmarks"]});
    const CorrectionSet set = computeCorrections({master}, {masterCycles}, {1, 1, "", 0, "20260101T000000Z", {}});
    ASSERT_EQ(set.landmarks.size(), 4u);

    // Production parts with every side moved by b (true offset b·√2 at each edge).
    int readings = 0, rawWithin10um = 0, correctedWithinU = 0;
    double rawSum = 0.0, rawWorst = 0.0, correctedWorst = 0.0, largestU = 0.0;
    std::uint64_t seed = 20;
    for (double b : {0.0, 0.03, -0.03, 0.08, -0.08, 0.05, -0.05}) {
        const double truth = b * std::sqrt(2.0);
        const inspect::InspectionResult raw = station.cycle(b, seed, nullptr);
        const inspect::InspectionResult corrected = station.cycle(b, seed++, &set);
        for (std::size_t i = 0; i < raw.landmarks.size(); ++i) {
            const auto& r = raw.landmarks[i];
            const auto& c = corrected.landmarks[i];
            ASSERT_TRUE(r.deviation && r.deviation->measured) << r.id;
            ASSERT_TRUE(c.deviation && c.deviation->measured && c.referral) << c.id;
            const double rawError = r.deviation->deviationMm - truth;
            const double error = c.deviation->deviationMm - truth;
            ++readings;
            rawSum += rawError;
            rawWorst = std::max(rawWorst, std::abs(rawError));
            rawWithin10um += std::abs(rawError) <= 0.01;
            correctedWorst = std::max(correctedWorst, std::abs(error));
            correctedWithinU += std::abs(error) <= c.deviation->uncertaintyMm;
            largestU = std::max(largestU, c.deviation->uncertaintyMm);
            EXPECT_LE(std::abs(error), 0.005) << c.id << " b " << b;
            // The raw reading and the correction stay in the record beside the corrected one.
            EXPECT_DOUBLE_EQ(c.referral->rawDeviationMm, r.deviation->deviationMm) << c.id;
            EXPECT_EQ(c.referral->correctionId, set.id);
            EXPECT_GT(c.deviation->uncertaintyMm, r.deviation->uncertaintyMm) << c.id;
            // The voxel bracket is the raw geometry's: never corrected.
            EXPECT_EQ(c.errorMinMm, r.errorMinMm);
            EXPECT_EQ(c.errorMaxMm, r.errorMaxMm);
        }
        const auto j = inspect::toJson(corrected);
        for (const auto& l : j["landmarks"]) {
            ASSERT_TRUE(l["raw_deviation_mm"].is_number()) << l.dump();
            EXPECT_EQ(l["correction"]["id"], set.id);
        }
    }
    std::cout << readings << " readings: raw bias mean " << rawSum / readings << " mm, worst " << rawWorst
              << " mm, within 0.01 mm of the truth " << rawWithin10um << "; after one-point mastering worst "
              << correctedWorst << " mm, truth inside U " << correctedWithinU << ", largest U " << largestU << " mm\n";
    for (const auto& l : set.landmarks)
        std::cout << "  " << l.id << ": offset " << l.offsetMm() << " mm, s " << l.points[0].spreadMm
                  << " mm, U of the correction " << l.uncertaintyAt(0.0) << " mm\n";
    EXPECT_EQ(readings, 28);
    // Without mastering the bias shows: on average below −0.008 mm (0.25 px at 0.043-0.063 mm/px).
    EXPECT_LT(rawSum / readings, -0.008);
    EXPECT_GE(correctedWithinU, static_cast<int>(std::ceil(0.95 * readings)));
}

} // namespace
} // namespace hg::study
