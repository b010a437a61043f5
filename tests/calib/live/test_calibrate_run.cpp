// `hullgauge calibrate run` end to end, as an operator runs it at the station:
// the Modbus fixture driver moves the fixture simulator (hullgauge-fixture-sim)
// through the poses; the simulated camera renders a backlit chessboard carried
// by the fixture at the pose the drive reports; the program detects, solves
// and writes the station. The camera twin renders with the TRUE rig
// (camera.driver.truth_station): skew, non-intersecting axes as in
// tests/calib/fixture_rig.h. The station file the run starts from holds other,
// nominal axes, so passing means recovering the rig, not reading the file back.
#include "hgtest/paths.h"
#include "hullgauge/common/config_node.h"
#include "hullgauge/geometry/transform.h"
#include "sim_process.h"
#include "station_yaml.h"

#include <atomic>
#include <chrono>
#include <cmath>
#include <fstream>
#include <gtest/gtest.h>
#include <iostream>
#include <sstream>
#include <thread>
#include <unistd.h>

namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using hg::geometry::Mat3;
using hg::geometry::RigidTransform;
using hg::geometry::Vec3;

constexpr double kSkewMm = 0.6;  // common perpendicular of the true axes
constexpr double kTiltDeg = 0.3; // true declination axis off perpendicular to the rotation axis
const std::string kPattern = "chessboard:8x5:15";
constexpr int kPoses = 12;
constexpr int kCorners = 8 * 5;

double rad(double deg)
{
    return deg * M_PI / 180.0;
}

std::string yaml(const Vec3& v)
{
    std::ostringstream s;
    s.precision(12);
    s << "[" << v.x() << ", " << v.y() << ", " << v.z() << "]";
    return s.str();
}

std::string yaml(const RigidTransform& T)
{
    std::ostringstream s;
    s << "{R: [";
    for (int r = 0; r < 3; ++r) s << (r ? ", " : "") << yaml(Vec3(T.R.row(r).transpose()));
    s << "], t: " << yaml(T.t) << "}";
    return s.str();
}

std::string readText(const fs::path& p)
{
    std::ifstream in(p);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

std::vector<fs::path> backupsOf(const fs::path& file)
{
    std::vector<fs::path> out;
    for (const auto& e : fs::directory_iterator(file.parent_path()))
        if (e.path().filename().string().rfind(file.filename().string() + ".bak-", 0) == 0) out.push_back(e.path());
    return out;
}

int count(const std::string& text, const std::string& what)
{
    int n = 0;
    for (auto at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
    return n;
}

/// The rig as it is: camera 400 mm from the fixture origin looking down 55°
/// at the turntable; rotation axis z through the origin; declination axis
/// along x tilted 0.3° towards z, 0.6 mm off along y (so the origin is the
/// foot of the axes' common perpendicular, the frame the calibration writes).
/// The board lies on the turntable, 20 mm up, turned 10°, centred on the axis.
struct TrueRig {
    RigidTransform cameraFromFixture;
    Vec3 declinationAxis{std::cos(rad(kTiltDeg)), 0.0, std::sin(rad(kTiltDeg))};
    Vec3 declinationPoint{0.0, kSkewMm, 0.0};
    RigidTransform partFromTarget;

    TrueRig()
    {
        const double el = rad(55.0);
        const Vec3 centre(0.0, -400.0 * std::cos(el), 400.0 * std::sin(el));
        Mat3 fixtureFromCamera;
        fixtureFromCamera.col(2) = (-centre).normalized();
        fixtureFromCamera.col(0) = Vec3::UnitX();
        fixtureFromCamera.col(1) = fixtureFromCamera.col(2).cross(Vec3::UnitX());
        cameraFromFixture = RigidTransform{fixtureFromCamera, centre}.inverse();
        partFromTarget = RigidTransform::rotation(Vec3::UnitZ(), 10.0);
        // Inner corners span 105 x 60 mm: their centre on the turntable axis.
        partFromTarget.t = Vec3(0.0, 0.0, 20.0) - partFromTarget.R * Vec3(52.5, 30.0, 0.0);
    }
};

/// The station file's fixture section after a calibration run, checked against
/// the true rig with the bounds of the fixture-axis calibration on simulated
/// corners (0.05°, 0.1 mm).
hg::ConfigNode expectRecoveredRig(const fs::path& station, const TrueRig& rig)
{
    auto fixture = hg::ConfigNode::loadFile(station)["fixture"];
    const Mat3 R = fixture["camera_from_fixture"]["R"].asMatrix3();
    const Vec3 t = fixture["camera_from_fixture"]["t"].asVector3();
    const auto angleDeg = [](const Vec3& a, const Vec3& b) {
        return std::atan2(a.cross(b).norm(), a.dot(b)) * 180.0 / M_PI;
    };
    std::cout << "camera_from_fixture off by " << hg::geometry::rotationAngleDeg(R, rig.cameraFromFixture.R) << " deg, "
              << (t - rig.cameraFromFixture.t).norm() << " mm; declination axis off by "
              << angleDeg(fixture["declination_axis"].asVector3(), rig.declinationAxis) << " deg, "
              << (fixture["declination_axis_point"].asVector3() - rig.declinationPoint).norm() << " mm\n";
    // Same bounds as the fixture-axis calibration on simulated corners.
    EXPECT_LT(hg::geometry::rotationAngleDeg(R, rig.cameraFromFixture.R), 0.05);
    EXPECT_LT((t - rig.cameraFromFixture.t).norm(), 0.1)
        << t.transpose() << " vs " << rig.cameraFromFixture.t.transpose();
    EXPECT_LT(angleDeg(fixture["rotation_axis"].asVector3(), Vec3::UnitZ()), 0.05);
    EXPECT_LT(fixture["rotation_axis_point"].asVector3().norm(), 0.1);
    EXPECT_LT(angleDeg(fixture["declination_axis"].asVector3(), rig.declinationAxis), 0.05)
        << fixture["declination_axis"].asVector3().transpose();
    EXPECT_LT((fixture["declination_axis_point"].asVector3() - rig.declinationPoint).norm(), 0.1)
        << fixture["declination_axis_point"].asVector3().transpose();
    EXPECT_NEAR(fixture["calibration"]["axes_distance_mm"].asDouble(), kSkewMm, 0.1);
    EXPECT_NEAR(fixture["calibration"]["axes_angle_deg"].asDouble(), 90.0 - kTiltDeg, 0.05);
    return fixture;
}

const char* kCamera = "camera:\n  image_size: [800, 600]\n  K: [[1100, 0, 400.5], [0, 1100, 300.25], [0, 0, 1]]\n";

class CalibrateRun : public ::testing::Test {
  protected:
    void SetUp() override
    {
        // The simulator serves the register map of the fixture tests' station.
        fixturetest::StationOptions o;
        auto simStation = hgtest::writeFile(dir / "sim-station.yaml", fixturetest::stationYaml(o));
        sim = std::make_unique<fixturetest::FixtureSimulator>(simStation, dir.path());
        o.port = sim->port();
        const std::string full = fixturetest::stationYaml(o);
        const std::string driver = full.substr(full.find("  driver:\n"));

        std::ostringstream truth;
        truth << kCamera
              << "fixture:\n  type: rotation_declination\n  camera_from_fixture: " << yaml(rig.cameraFromFixture)
              << "\n  rotation_axis: [0, 0, 1]\n  rotation_axis_point: [0, 0, 0]\n"
              << "  declination_axis: " << yaml(rig.declinationAxis)
              << "\n  declination_axis_point: " << yaml(rig.declinationPoint) << "\n";
        hgtest::writeFile(dir / "truth.yaml", truth.str());

        // What the station file says before calibration: the drawing's axes
        // (through one point, perpendicular) and a camera placed 3° and ~8 mm off.
        RigidTransform nominal =
            RigidTransform::rotation(Vec3(1.0, 2.0, 0.5).normalized(), 3.0) * rig.cameraFromFixture;
        nominal.t += Vec3(4.0, -3.0, 6.0);
        std::ostringstream st;
        st << kCamera
           << "  driver:\n    backend: sim\n    truth_station: truth.yaml\n    target:\n      pattern: " << kPattern
           << "\n      part_from_target: " << yaml(rig.partFromTarget)
           << "\n    blur_sigma_px: 0.6\n    noise_sigma: 1.0\n    seed: 11\n"
           << "fixture:\n  type: rotation_declination\n  camera_from_fixture: " << yaml(nominal)
           << "\n  rotation_axis: [0, 0, 1]\n  declination_axis: [1, 0, 0]\n"
           << "  rotation_range_deg: [-180, 180]\n  declination_range_deg: [0, 60]\n"
           << driver;
        stationText = st.str();
        station = hgtest::writeFile(dir / "station.yaml", stationText);

        // A grid: views that differ in rotation only and in declination only.
        std::ostringstream poses;
        for (double phi : {0.0, 20.0, 40.0})
            for (double theta : {-45.0, -15.0, 15.0, 45.0})
                poses << "- {rotation_deg: " << theta << ", declination_deg: " << phi << "}\n";
        posesFile = hgtest::writeFile(dir / "poses.yaml", poses.str());
    }

    std::vector<std::string> command() const
    {
        return {(hgtest::binaryDir() / "bin" / "hullgauge").string(),
                "calibrate",
                "run",
                "--station",
                station.string(),
                "--pattern",
                kPattern,
                "--poses",
                posesFile.string()};
    }

    TrueRig rig;
    hgtest::TempDir dir;
    std::unique_ptr<fixturetest::FixtureSimulator> sim;
    std::string stationText;
    fs::path station;
    fs::path posesFile;
};

TEST_F(CalibrateRun, RecoversTheTrueSkewAxesThroughTheDriversAndKeepsABackup)
{
    std::string line;
    for (const auto& a : command()) line += a + " ";
    auto r = hgtest::run(line);
    ASSERT_EQ(r.status, 0) << r.err;
    // Progress on stderr: homing, then one line per pose with the corners found.
    EXPECT_NE(r.err.find("homing the fixture"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("[1/12] rotation -45 deg, declination 0 deg: 40 corners"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("[12/12] rotation 45 deg, declination 40 deg: 40 corners"), std::string::npos) << r.err;
    EXPECT_EQ(count(r.err, ": " + std::to_string(kCorners) + " corners"), kPoses) << r.err;
    EXPECT_NE(r.out.find("distance between axes"), std::string::npos) << r.out;

    auto fixture = expectRecoveredRig(station, rig);
    EXPECT_EQ(fixture["calibration"]["views"].asInt(), kPoses);
    // The driver sections survive the rewrite.
    EXPECT_EQ(fixture["driver"]["backend"].asString(), "modbus");

    auto backups = backupsOf(station);
    ASSERT_EQ(backups.size(), 1u);
    EXPECT_EQ(readText(backups[0]), stationText);
}

TEST_F(CalibrateRun, FixtureFaultMidSequenceIsExitThreeNamingTheStepAndLeavesTheStation)
{
    const auto log = dir / "run.log";
    fixturetest::ChildProcess run(command(), log);
    // Let three poses pass, then latch a drive fault (FAULT_MODE 5, code 17).
    const auto deadline = std::chrono::steady_clock::now() + 40s;
    while (std::chrono::steady_clock::now() < deadline && run.running() &&
           readText(log).find("[3/12]") == std::string::npos)
        std::this_thread::sleep_for(5ms);
    ASSERT_NE(readText(log).find("[3/12]"), std::string::npos) << readText(log);
    sim->setControl(0, 5);
    while (std::chrono::steady_clock::now() < deadline && run.running()) std::this_thread::sleep_for(10ms);
    ASSERT_FALSE(run.running()) << "calibrate run did not stop after the fault";
    const int status = run.terminate();
    const std::string text = readText(log);
    EXPECT_EQ(status, 3) << text;
    EXPECT_NE(text.find("calibrate run: move to rotation"), std::string::npos) << text;
    EXPECT_NE(text.find("drive fault 17 (following error)"), std::string::npos) << text;
    EXPECT_EQ(text.find("[12/12]"), std::string::npos) << text;
    EXPECT_EQ(readText(station), stationText);
    EXPECT_TRUE(backupsOf(station).empty());
}

TEST_F(CalibrateRun, SimulatedCameraWithoutATargetIsBadInputNamingTheKey)
{
    std::string text = stationText;
    const auto from = text.find("    target:\n");
    const auto to = text.find("    blur_sigma_px:");
    ASSERT_NE(from, std::string::npos);
    text.erase(from, to - from);
    hgtest::writeFile(station, text);
    std::string line;
    for (const auto& a : command()) line += a + " ";
    auto r = hgtest::run(line);
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_NE(r.err.find("camera.driver.target"), std::string::npos) << r.err;
    EXPECT_EQ(readText(station), text);
    EXPECT_TRUE(backupsOf(station).empty());
}

// The same calibration through the running daemon (docs/daemon.md, maintenance
// socket): hullgauged with this station and a part program, the operator
// puts the target on the fixture (`ctl sim-part target`) and runs `ctl
// calibrate`; production is paused meanwhile (PLC STATUS 5 = maintenance,
// sequencer `calibrating`) and resumes afterwards; the station file is
// rewritten with a backup and the true rig recovered.
TEST_F(CalibrateRun, ThroughTheDaemonMaintenanceSocketWithProductionPaused)
{
    const fs::path cfg = hgtest::sourceDir() / "config" / "sim";
    for (const char* f : {"stepped-block.yaml", "stepped-block.stl", "stepped-block-views.yaml"})
        fs::copy_file(cfg / f, dir / f);
    // The daemon also drives the operator lamps.
    hgtest::writeFile(station, stationText + "lamps:\n  backend: sim\n  consumer: hullgauge\n  blink_period_s: 1.0\n"
                                             "  green: LAMP_GREEN\n  amber: LAMP_AMBER\n  red: LAMP_RED\n");
    const std::string before = readText(station);
    const fs::path socket = dir / "hg.sock";
    const int plcPort = 20000 + static_cast<int>(::getpid() % 20000);
    std::ostringstream d;
    d << "station: station.yaml\nprograms:\n  1: {part: stepped-block.yaml, views: stepped-block-views.yaml}\n"
      << "plc: {bind: 127.0.0.1, port: " << plcPort << ", unit_id: 1, allowed_clients: [127.0.0.1]}\n"
      << "results: {database: results.db, images: images}\n"
      << "sequencer: {move_timeout_s: 10, grab_timeout_s: 5, settle_s: 0.02}\n"
      << "maintenance: {socket: hg.sock}\n"
      << "simulation:\n  parts: {nominal: stepped-block.stl}\n";
    const auto daemonConfig = hgtest::writeFile(dir / "hullgauged.yaml", d.str());
    fixturetest::ChildProcess daemon(
        {(hgtest::binaryDir() / "bin" / "hullgauged").string(), "--config", daemonConfig.string()},
        dir / "hullgauged.log");
    const std::string ctl = (hgtest::binaryDir() / "bin" / "hullgauge").string() + " ctl --socket " + socket.string();
    bool ready = false;
    for (int i = 0; i < 200 && !ready; ++i) { // bounded: 20 s
        auto r = hgtest::run(ctl + " --json status");
        ready = r.status == 0 && r.out.find("\"state\": \"ready\"") != std::string::npos;
        if (!ready) std::this_thread::sleep_for(100ms);
    }
    ASSERT_TRUE(ready) << readText(dir / "hullgauged.log");

    ASSERT_EQ(hgtest::run(ctl + " sim-part target").status, 0);
    // Follow the daemon's state while the calibration runs in the background.
    std::atomic<bool> done{false};
    std::atomic<bool> sawMaintenance{false};
    std::thread watcher([&] {
        while (!done) {
            auto r = hgtest::run(ctl + " --json status");
            if (r.out.find("\"state\": \"calibrating\"") != std::string::npos &&
                r.out.find("\"status\": 5") != std::string::npos)
                sawMaintenance = true;
            std::this_thread::sleep_for(50ms);
        }
    });
    auto r = hgtest::run(ctl + " calibrate --pattern " + kPattern + " --poses " + posesFile.string() +
                         " --wait-timeout 120");
    done = true;
    watcher.join();
    ASSERT_EQ(r.status, 0) << r.err << readText(dir / "hullgauged.log");
    EXPECT_TRUE(sawMaintenance) << "production was not seen paused (sequencer calibrating, PLC STATUS 5)";
    EXPECT_NE(r.err.find("[1/12] rotation -45 deg, declination 0 deg: 40 corners"), std::string::npos) << r.err;
    EXPECT_EQ(count(r.err, ": " + std::to_string(kCorners) + " corners"), kPoses) << r.err;
    EXPECT_NE(r.out.find("written: " + station.string()), std::string::npos) << r.out;
    auto fixture = expectRecoveredRig(station, rig);
    EXPECT_EQ(fixture["calibration"]["views"].asInt(), kPoses);
    const auto backups = backupsOf(station);
    ASSERT_EQ(backups.size(), 1u);
    EXPECT_EQ(readText(backups.front()), before);

    // Production resumes: ready again, and a trigger runs a cycle.
    auto s = hgtest::run(ctl + " --json status");
    EXPECT_NE(s.out.find("\"state\": \"ready\""), std::string::npos) << s.out;
    EXPECT_NE(s.out.find("\"status\": 0"), std::string::npos) << s.out;
    auto text = hgtest::run(ctl + " status");
    EXPECT_NE(text.out.find("calibration:  done, 12/12 poses"), std::string::npos) << text.out;
    EXPECT_NE(text.out.find("lamps:        green off, amber off, red off, backend sim"), std::string::npos) << text.out;
    // A second request while none runs is accepted; bad input is refused at once naming it.
    auto bad = hgtest::run(ctl + " calibrate --pattern chessboard:8x5 --poses " + posesFile.string());
    EXPECT_EQ(bad.status, 3) << bad.err;
    EXPECT_NE(bad.err.find("pattern"), std::string::npos) << bad.err;
    EXPECT_EQ(daemon.terminate(10000), 0) << readText(dir / "hullgauged.log");
}

} // namespace
