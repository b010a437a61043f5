// The simulated nest (docs/daemon.md, "Seating"): every new part is seated at
// random, uniformly within `simulation.seating`, about the nominal mesh's
// bounding-box centre; without the key every part sits as drawn.
#include "cycle/driver_devices.h"
#include "hgtest/paths.h"

#include <cmath>
#include <gtest/gtest.h>
#include <set>

namespace hg::daemon {
namespace {

station::DaemonConfig simulatedLine()
{
    return station::loadDaemonConfig(hgtest::sourceDir() / "config" / "sim" / "hullgauged.yaml");
}

TEST(SimulatedSeating, EveryNewPartIsSeatedUniformlyWithinThePlay)
{
    auto config = simulatedLine();
    ASSERT_TRUE(config.simulatedSeating) << "config/sim seats its parts";
    config.simulatedSeating = station::DaemonConfig::Seating{0.3, 0.3, 5};
    auto hardware = makeDriverDevices(config);
    ASSERT_NE(hardware.simulation, nullptr);
    // The stepped block spans x in [-30, 30], y in [-20, 20], z in [0, 30] (config/sim/README.md).
    const geometry::Vec3 centre(0, 0, 15);
    constexpr int kParts = 2000;
    double shiftSum = 0, angleSum = 0, maxShift = 0, maxAngle = 0;
    std::set<double> shifts;
    for (int i = 0; i < kParts; ++i) {
        hardware.simulation->newPart();
        const auto seat = hardware.simulation->trueSeat();
        ASSERT_TRUE(seat);
        EXPECT_LT((seat->centre - centre).norm(), 1e-12);
        ASSERT_TRUE(geometry::isRotation(seat->seat.R, 1e-12));
        const double shift = (seat->seat.apply(centre) - centre).norm();
        const double angle = geometry::rotationAngleDeg(geometry::Mat3::Identity(), seat->seat.R);
        shiftSum += shift;
        angleSum += angle;
        maxShift = std::max(maxShift, shift);
        maxAngle = std::max(maxAngle, angle);
        shifts.insert(shift);
    }
    EXPECT_LE(maxShift, 0.3 + 1e-12);
    EXPECT_LE(maxAngle, 0.3 + 1e-9);
    EXPECT_EQ(shifts.size(), static_cast<std::size_t>(kParts)) << "a new seat for every part";
    // Uniform in a ball of radius r: the mean distance from its centre is 3r/4 (the standard
    // deviation of the mean of 2000 draws is r·0.19/√2000 ≈ 0.0013 mm here).
    EXPECT_NEAR(shiftSum / kParts, 0.225, 0.01);
    EXPECT_NEAR(angleSum / kParts, 0.225, 0.01);
    // The extreme draws come near the play.
    EXPECT_GT(maxShift, 0.29);
    EXPECT_GT(maxAngle, 0.29);
}

TEST(SimulatedSeating, TheSameSeedSeatsTheSameParts)
{
    auto config = simulatedLine();
    auto first = makeDriverDevices(config);
    auto second = makeDriverDevices(config);
    for (int i = 0; i < 5; ++i) {
        first.simulation->newPart();
        second.simulation->newPart();
        EXPECT_EQ(first.simulation->trueSeat()->seat.R, second.simulation->trueSeat()->seat.R);
        EXPECT_EQ(first.simulation->trueSeat()->seat.t, second.simulation->trueSeat()->seat.t);
    }
}

TEST(SimulatedSeating, WithoutTheKeyEveryPartSitsAsDrawn)
{
    auto config = simulatedLine();
    config.simulatedSeating.reset();
    auto hardware = makeDriverDevices(config);
    hardware.simulation->newPart();
    EXPECT_FALSE(hardware.simulation->trueSeat());
}

} // namespace
} // namespace hg::daemon
