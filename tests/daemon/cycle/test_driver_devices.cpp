// The daemon's device port over the drivers (src/daemon/cycle/driver_devices.cpp)
// on the simulated line with the in-process fixture twin: a fixture fault is
// the fixture's, never the camera's (docs/plc.md, fault codes 10, 21, 22).
#include "cycle/driver_devices.h"
#include "hgtest/paths.h"
#include "hullgauge/drivers/simulation.h"

#include <chrono>
#include <fstream>
#include <gtest/gtest.h>
#include <sstream>

namespace hg::daemon {
namespace {

using namespace std::chrono_literals;
namespace fs = std::filesystem;

/// config/sim, with the files of `overlay` laid over it as tools/simline lays
/// them, and the fixture's twin in the process (`backend: sim`, the one-word
/// switch docs/fixture.md promises) instead of the Modbus simulator.
station::DaemonConfig lineWithTwinFixture(const fs::path& dir, const std::string& overlay = {})
{
    fs::copy(hgtest::sourceDir() / "config" / "sim", dir, fs::copy_options::recursive);
    if (!overlay.empty())
        fs::copy(hgtest::sourceDir() / "config" / overlay, dir,
                 fs::copy_options::recursive | fs::copy_options::overwrite_existing);
    std::ifstream in(dir / "station.yaml");
    std::stringstream text;
    text << in.rdbuf();
    std::string station = text.str();
    const auto at = station.find("backend: modbus");
    EXPECT_NE(at, std::string::npos);
    station.replace(at, 15, "backend: sim");
    std::ofstream(dir / "station.yaml") << station;
    return station::loadDaemonConfig(dir / "hullgauged.yaml");
}

class TwinFixtureLine : public ::testing::Test {
  protected:
    void SetUp() override
    {
        hardware_ = makeDriverDevices(lineWithTwinFixture(dir_.path()));
        ASSERT_NE(hardware_.simulation, nullptr);
        faults_ = hardware_.simulation->fixtureFaults();
        ASSERT_NE(faults_, nullptr) << "the in-process fixture twin publishes its fault switches";
        ASSERT_TRUE(hardware_.devices->start().ok());
        ASSERT_TRUE(hardware_.devices->moveTo(pose_, 10s, false).ok());
    }
    void TearDown() override
    {
        if (hardware_.devices) hardware_.devices->shutdown();
    }

    hgtest::TempDir dir_;
    StationHardware hardware_;
    drivers::SimFixtureControl* faults_ = nullptr;
    geometry::FixturePose pose_{30.0, 20.0, 0.0};
};

// A drive that stops answering after it arrived leaves the part where it is:
// the camera still sees it (a camera knows nothing of the drive), and the next
// move is the one that fails, as a communication fault (FAULT 22).
TEST_F(TwinFixtureLine, ADriveThatStopsAnsweringFailsTheNextMoveNotTheGrab)
{
    GrabbedFrame before, after;
    ASSERT_TRUE(hardware_.devices->grab(2s, before).ok());
    faults_->injectFault(drivers::SimulatedFault::NoAnswer);
    const Status grabbed = hardware_.devices->grab(2s, after);
    EXPECT_TRUE(grabbed.ok()) << grabbed.message();
    // The same silhouette (the frames differ by the camera's noise only).
    ASSERT_EQ(after.image.size(), before.image.size());
    const auto dark = [](const GrabbedFrame& frame) { return cv::countNonZero(frame.image < 128); };
    ASSERT_GT(dark(before), 1000) << "the part is in view";
    EXPECT_NEAR(dark(after), dark(before), 0.005 * dark(before)) << "the part is shown where it was held";
    const Status moved = hardware_.devices->moveTo({-30.0, 10.0, 0.0}, 2s, false);
    ASSERT_FALSE(moved.ok());
    EXPECT_TRUE(moved.code() == StatusCode::Timeout || moved.code() == StatusCode::CommunicationError)
        << moved.message();
}

// A drive fault latched after arrival: the frame is taken, the next move
// reports the drive's fault (FAULT 21 once a reset does not clear it).
TEST_F(TwinFixtureLine, ALatchedDriveFaultFailsTheNextMoveNotTheGrab)
{
    faults_->injectFault(drivers::SimulatedFault::DriveFault, 17);
    GrabbedFrame frame;
    const Status grabbed = hardware_.devices->grab(2s, frame);
    EXPECT_TRUE(grabbed.ok()) << grabbed.message();
    const Status moved = hardware_.devices->moveTo({-30.0, 10.0, 0.0}, 2s, false);
    ASSERT_FALSE(moved.ok());
    EXPECT_EQ(moved.code(), StatusCode::Fault) << moved.message();
}

// config/sim-aging: every new part is a cycle of the camera's aging, which
// takes a step every 5 cycles (back light · 0.97, blur + 0.1 px, halo + 0.05
// px, 2 specks more); the status shows it and a reset makes the optics new.
TEST(SimulatedAging, EveryNewPartAgesTheCameraAndAResetMakesItNew)
{
    hgtest::TempDir dir;
    StationHardware hardware = makeDriverDevices(lineWithTwinFixture(dir.path(), "sim-aging"));
    ASSERT_NE(hardware.simulation, nullptr);
    SimulationControl& sim = *hardware.simulation;
    auto optics = sim.optics();
    EXPECT_EQ(optics["cycles"], 0);
    EXPECT_EQ(optics["dust_specks"], 2);
    EXPECT_DOUBLE_EQ(optics["background_level"].get<double>(), 0.92);
    EXPECT_DOUBLE_EQ(optics["vignetting"].get<double>(), 0.1);
    for (int i = 0; i < 14; ++i) sim.newPart();
    optics = sim.optics();
    EXPECT_EQ(optics["cycles"], 14);
    EXPECT_EQ(optics["aging_steps"], 2);
    EXPECT_NEAR(optics["background_level"].get<double>(), 0.92 * 0.97 * 0.97, 1e-12);
    EXPECT_NEAR(optics["blur_sigma_px"].get<double>(), 0.8, 1e-12);
    EXPECT_NEAR(optics["halo_px"].get<double>(), 0.1, 1e-12);
    EXPECT_EQ(optics["dust_specks"], 6);
    sim.resetAging();
    optics = sim.optics();
    EXPECT_EQ(optics["cycles"], 0);
    EXPECT_EQ(optics["aging_steps"], 0);
    EXPECT_EQ(optics["dust_specks"], 2);
    EXPECT_DOUBLE_EQ(optics["background_level"].get<double>(), 0.92);
}

// `sim-part none`: the camera grabs the empty fixture, the back light alone.
TEST_F(TwinFixtureLine, ThePartNoneShowsTheEmptyFixture)
{
    SimulationControl& sim = *hardware_.simulation;
    const auto parts = sim.parts();
    EXPECT_EQ(parts.back(), "none");
    GrabbedFrame withPart, empty;
    ASSERT_TRUE(hardware_.devices->grab(2s, withPart).ok());
    ASSERT_GT(cv::countNonZero(withPart.image < 128), 1000) << "the part is in view";
    ASSERT_TRUE(sim.selectPart("none"));
    EXPECT_EQ(sim.part(), "none");
    ASSERT_TRUE(hardware_.devices->grab(2s, empty).ok());
    EXPECT_EQ(cv::countNonZero(empty.image < 128), 0);
    // config/sim's back light, 0.92 of full scale, with its noise of 1.5 grey levels.
    EXPECT_NEAR(cv::mean(empty.image)[0], 0.92 * 255.0, 0.5);
    ASSERT_TRUE(sim.selectPart("nominal"));
    ASSERT_TRUE(hardware_.devices->grab(2s, withPart).ok());
    EXPECT_GT(cv::countNonZero(withPart.image < 128), 1000);
}

} // namespace
} // namespace hg::daemon
