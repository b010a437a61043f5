#include <gtest/gtest.h>

#include <iostream>
#include <random>
#include <sstream>

#include "hullgauge/calib/rail.h"
#include "hullgauge/common/error.h"

using namespace hg::calib;
using hg::geometry::Vec2;

namespace {

/// A simulated rail bench: the pinhole camera of eq. 4.2.1-1/2 with its axis
/// along the rail, a point displaced (h, w) from the axis, the mount's zero
/// off the axis by (h0, w0) and the rail reading d off the true depth by d0.
struct Bench {
    double fx = 3200.0, fy = 3180.0, cx = 1231.7, cy = 1019.3;
    double d0 = 42.0, h0 = 0.0, w0 = 0.0;
    double noisePx = 0.25;
    std::vector<double> ranges{300, 350, 400, 450, 500};

    RailObservations simulate(unsigned seed) const
    {
        std::mt19937 rng(seed);
        std::normal_distribution<double> noise(0.0, noisePx);
        RailObservations obs;
        auto pixel = [&](double h, double w, double d) {
            double z = d + d0;
            return Vec2(cx + fx * (h + h0) / z + noise(rng), cy + fy * (w + w0) / z + noise(rng));
        };
        for (double h : {-60.0, -40.0, -20.0, 0.0, 20.0, 40.0, 60.0}) {
            RailSeries s{h, {}};
            for (double d : ranges) s.samples.push_back({d, pixel(h, 0.0, d)});
            obs.horizontal.push_back(s);
        }
        for (double w : {-50.0, -25.0, 0.0, 25.0, 50.0}) {
            RailSeries s{w, {}};
            for (double d : ranges) s.samples.push_back({d, pixel(0.0, w, d)});
            obs.vertical.push_back(s);
        }
        return obs;
    }
};

std::string toYaml(const RailObservations& obs)
{
    std::ostringstream y;
    y.precision(10);
    auto series = [&](const char* key, const std::vector<RailSeries>& list) {
        y << key << ":\n";
        for (const auto& s : list) {
            y << "  - displacement_mm: " << s.displacementMm << "\n    samples:\n";
            for (const auto& smp : s.samples)
                y << "      - {range_mm: " << smp.rangeMm << ", pixel: [" << smp.pixel.x() << ", " << smp.pixel.y()
                  << "]}\n";
        }
    };
    y << "units: mm\n";
    series("horizontal", obs.horizontal);
    series("vertical", obs.vertical);
    return y.str();
}

} // namespace

TEST(RailSimilarTriangles, HandComputedEquation4311)
{
    // f/Δp = 1000, point 10 mm off the axis: n = 1000*10/100 = 100 px at
    // 100 mm and n' = 50 px at 200 mm; (Δd/v) n n'/(n-n') = 10 * 5000/50 = 1000.
    std::vector<RailSeries> series{{10.0, {{100.0, Vec2(600.0, 0.0)}, {200.0, Vec2(550.0, 0.0)}}},
                                   {0.0, {{100.0, Vec2(500.0, 0.0)}, {200.0, Vec2(500.0, 0.0)}}},
                                   {-5.0, {{100.0, Vec2(450.0, 0.0)}, {200.0, Vec2(475.0, 0.0)}}}};
    auto t = similarTriangleTable(series, 500.0, 0);
    ASSERT_EQ(t.rangePairs.size(), 1u);
    EXPECT_EQ(t.rangePairs[0], std::make_pair(200.0, 100.0));
    ASSERT_TRUE(t.values[0][0].has_value());
    EXPECT_NEAR(*t.values[0][0], 1000.0, 1e-9);
    EXPECT_FALSE(t.values[0][1].has_value()); // on the axis: no value, as in Table 4.3
    // v = -5: n = -50, n' = -25: (100/-5) * 1250 / -25 = 1000.
    EXPECT_NEAR(*t.values[0][2], 1000.0, 1e-9);
    EXPECT_EQ(t.overall.count, 2);
    EXPECT_NEAR(t.overall.stdDev, 0.0, 1e-9);
}

TEST(RailSimilarTriangles, RowsFollowTheDissertationsOrder)
{
    std::vector<RailSeries> series{{1.0, {}}};
    for (double r : {25.0, 31.0, 37.0, 43.0, 49.0}) series[0].samples.push_back({r, Vec2(0, 0)});
    auto t = similarTriangleTable(series, 0.0, 0);
    ASSERT_EQ(t.rangePairs.size(), 10u);
    EXPECT_EQ(t.rangePairs[0], std::make_pair(31.0, 25.0));
    EXPECT_EQ(t.rangePairs[3], std::make_pair(49.0, 43.0));
    EXPECT_EQ(t.rangePairs[4], std::make_pair(37.0, 25.0));
    EXPECT_EQ(t.rangePairs[9], std::make_pair(49.0, 25.0));
    EXPECT_EQ(t.overall.count, 0); // the point never moved: n = n' everywhere
}

TEST(RailCalibration, SimulatedBenchWithNoiseRecoversCentreAndRatios)
{
    Bench bench;
    auto obs = RailObservations::parse(hg::ConfigNode::parse(toYaml(bench.simulate(2024)), "rail.yaml"));
    auto cal = calibrateRail(obs);
    std::cout << formatRailReport(cal);

    EXPECT_NEAR(cal.centre.centre.x(), bench.cx, 0.5);
    EXPECT_NEAR(cal.centre.centre.y(), bench.cy, 0.5);
    EXPECT_EQ(cal.centre.stationary, 2); // the two points on the axis
    // Eq. 4.3.1-1 averaged over all range pairs and displacements.
    EXPECT_NEAR(cal.horizontal.overall.mean, bench.fx, 0.005 * bench.fx);
    EXPECT_NEAR(cal.vertical.overall.mean, bench.fy, 0.005 * bench.fy);
    EXPECT_EQ(cal.horizontal.rangePairs.size(), 10u);
    EXPECT_EQ(cal.horizontal.displacementsMm.size(), 7u);
    EXPECT_EQ(cal.horizontal.overall.count, 60); // 10 pairs x 6 displaced points
    // The least-squares fit over all observations.
    EXPECT_NEAR(cal.fit.fx, bench.fx, 0.005 * bench.fx);
    EXPECT_NEAR(cal.fit.fy, bench.fy, 0.005 * bench.fy);
    EXPECT_NEAR(cal.fit.cx, bench.cx, 0.5);
    EXPECT_NEAR(cal.fit.cy, bench.cy, 0.5);
    EXPECT_NEAR(cal.fit.rangeOffsetMm, bench.d0, 2.0);
    EXPECT_NEAR(cal.fit.rmsPx, bench.noisePx, 0.1);
    // The reported uncertainty is consistent with the actual error.
    EXPECT_LT(std::abs(cal.fit.fx - bench.fx), 4.0 * cal.fit.stdDev[0] + 1e-9);
}

TEST(RailCalibration, MisalignedMountIsAbsorbedByTheLeastSquaresFit)
{
    Bench bench;
    bench.h0 = 0.8; // the mount's zero is 0.8 mm off the optical axis
    bench.w0 = -0.6;
    auto cal = calibrateRail(bench.simulate(99));
    // The per-pair ratios carry the offset (v is not measured from the axis);
    // the fit estimates it.
    EXPECT_NEAR(cal.fit.fx, bench.fx, 0.005 * bench.fx);
    EXPECT_NEAR(cal.fit.fy, bench.fy, 0.005 * bench.fy);
    EXPECT_NEAR(cal.fit.mountOffsetHMm, bench.h0, 0.1);
    EXPECT_NEAR(cal.fit.mountOffsetVMm, bench.w0, 0.1);
    EXPECT_NEAR(cal.centre.centre.x(), bench.cx, 0.5);
    EXPECT_NEAR(cal.centre.centre.y(), bench.cy, 0.5);
}

TEST(RailCalibration, ObservationFileErrorsNameTheKey)
{
    auto fails = [](const std::string& yaml) {
        try {
            (void)calibrateRail(RailObservations::parse(hg::ConfigNode::parse(yaml, "rail.yaml")));
        } catch (const hg::InputError& e) {
            return std::string(e.what());
        }
        return std::string("no error");
    };
    EXPECT_NE(fails("horizontal: []\nvertical: []\n").find("horizontal"), std::string::npos);
    EXPECT_NE(fails("horizontal:\n  - displacement_mm: 5\n    samples:\n      - {range_mm: 1, pixel: [1, 2]}\n"
                    "      - {range_mm: 1, pixel: [1, 3]}\nvertical: []\n")
                  .find("rail.yaml:5: horizontal[0].samples[1].range_mm: range given twice"),
              std::string::npos);
    EXPECT_NE(fails("horizontal: []\nvertical: []\nunits: inch\n").find("units"), std::string::npos);
}
