// The cycle runner in-process with scripted devices and a hand-moved clock:
// retries, faults with their codes, aborts and fault resets from the PLC's
// COMMAND register, and recovery when the sequencer says — asserted on the
// PLC registers, the lamps, the stored records and the sequencer's state;
// the program's release each record names, across reloads. Waiting is polling under a deadline; time on the runner's
// clock passes only when the test moves it (settle times pass at once).
#include "cycle/cycle_runner.h"
#include "cycle/engine_inspector.h"
#include "hgtest/log_capture.h"
#include "hgtest/manual_clock.h"
#include "hgtest/paths.h"
#include "hgtest/station.h"
#include "hullgauge/align/alignment.h"
#include "hullgauge/calib/flat_field.h"
#include "hullgauge/common/error.h"
#include "hullgauge/inspect/inspector.h"
#include "hullgauge/inspect/part_map.h"
#include "hullgauge/model/mesh_io.h"
#include "hullgauge/model/part_program.h"
#include "hullgauge/sim/renderer.h"
#include "hullgauge/store/result_outbox.h"
#include "hullgauge/store/result_reader.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <fstream>
#include <gtest/gtest.h>
#include <iterator>
#include <map>
#include <mutex>
#include <opencv2/imgcodecs.hpp>
#include <set>
#include <tuple>

namespace hg::daemon {
namespace {

using hgtest::ManualClock;

using namespace std::chrono_literals;
using station::LampPattern;
using station::SequencerState;
namespace reg = station::reg;

/// Devices whose answers the test scripts call by call; every call is recorded.
class ScriptedDevices : public StationDevices {
  public:
    using Step = std::function<Status()>;
    explicit ScriptedDevices(const Clock& clock) : clock_(clock) {}

    std::deque<Step> moves, grabs, recoveries; ///< the next answers; success when empty
    Status startStatus;
    cv::Mat frame = cv::Mat(8, 8, CV_8UC1, cv::Scalar(200)); ///< what every grab returns (set before start)

    Status start() override { return startStatus; }
    void shutdown() override {}
    Status moveTo(const geometry::FixturePose& pose, std::chrono::milliseconds, bool retry) override
    {
        std::lock_guard lock(mutex_);
        moveRetries_.push_back(retry);
        poses_.push_back(pose);
        return next(moves);
    }
    void stopMotion() override { stopped_ = true; }
    /// The camera's regions (docs/camera.md, "Regions per grab"): a grab
    /// sends the region last asked for, cut from `frame` (or from what
    /// `render` makes at the last pose moved to); refusing, whole frames.
    bool refuseRegions = false;
    double regionChangeMs = 0.0; ///< reported by the first grab after a change
    std::function<cv::Mat(const geometry::FixturePose&)> render;
    Status setRegion(const cv::Rect& region) override
    {
        std::lock_guard lock(mutex_);
        calls_.push_back("region " + describe(region));
        if (refuseRegions) return Status::failure(StatusCode::NotAllowed, "scripted: no regions");
        changed_ = changed_ || region != region_;
        region_ = region;
        return Status::success();
    }
    Status grab(std::chrono::milliseconds, GrabbedFrame& out) override
    {
        std::lock_guard lock(mutex_);
        ++grabCount_;
        calls_.push_back("grab");
        const cv::Mat whole = render && !poses_.empty() ? render(poses_.back()) : frame;
        const cv::Rect cut = region_.empty() ? cv::Rect(0, 0, whole.cols, whole.rows) : region_;
        out.image = whole(cut).clone();
        out.origin = cut.tl();
        out.payloadBytes = out.image.total() * out.image.elemSize();
        out.regionChangeMs = changed_ ? regionChangeMs : 0.0;
        changed_ = false;
        return next(grabs);
    }
    static std::string describe(const cv::Rect& r)
    {
        return "[" + std::to_string(r.x) + ", " + std::to_string(r.y) + ", " + std::to_string(r.width) + ", " +
               std::to_string(r.height) + "]";
    }
    /// "region [x, y, w, h]" and "grab", in the order the runner called them.
    std::vector<std::string> calls() const
    {
        std::lock_guard lock(mutex_);
        return calls_;
    }
    Status recover() override
    {
        std::lock_guard lock(mutex_);
        recoverTimes_.push_back(clock_.now());
        return next(recoveries);
    }
    void showLamps(LampPattern pattern) override
    {
        std::lock_guard lock(mutex_);
        lamps_.push_back(pattern);
    }

    std::vector<LampPattern> lamps() const
    {
        std::lock_guard lock(mutex_);
        return lamps_;
    }
    std::vector<geometry::FixturePose> poses() const
    {
        std::lock_guard lock(mutex_);
        return poses_;
    }
    std::vector<bool> moveRetries() const
    {
        std::lock_guard lock(mutex_);
        return moveRetries_;
    }
    int grabCount() const
    {
        std::lock_guard lock(mutex_);
        return grabCount_;
    }
    std::vector<Clock::time_point> recoverTimes() const
    {
        std::lock_guard lock(mutex_);
        return recoverTimes_;
    }
    bool stopped() const { return stopped_; }

  private:
    static Status next(std::deque<Step>& script)
    {
        if (script.empty()) return Status::success();
        auto step = std::move(script.front());
        script.pop_front();
        return step();
    }
    const Clock& clock_;
    mutable std::mutex mutex_;
    std::vector<LampPattern> lamps_;
    std::vector<bool> moveRetries_;
    std::vector<geometry::FixturePose> poses_;
    std::vector<Clock::time_point> recoverTimes_;
    int grabCount_ = 0;
    std::vector<std::string> calls_;
    cv::Rect region_;
    bool changed_ = false;
    std::atomic<bool> stopped_{false};
};

/// Passes every part with three landmarks; the test may give the seat it
/// measured and call it a seating fault (set before the trigger).
class PassingInspector : public Inspector {
  public:
    Status begin(const station::PartProgramRef&) override { return Status::success(); }
    /// The changeover's load: recorded; fails for the programs in `unloadable`.
    Status prepare(const station::PartProgramRef& program) override
    {
        if (onPrepare) onPrepare(program.number);
        std::lock_guard lock(mutex);
        prepared.push_back(program.number);
        if (!unloadable.contains(program.number)) return Status::success();
        return Status::failure("scripted load failure");
    }
    void addView(std::size_t, const geometry::FixturePose&, cv::Mat, cv::Point) override {}
    InspectionOutcome finish() override
    {
        if (onFinish) onFinish();
        InspectionOutcome out;
        out.ok = true;
        out.part = "block";
        out.release = release;
        out.alignment = alignment;
        out.seatingFault = seatingFault;
        out.pass = !seatingFault;
        out.health = health;
        for (const char* id : {"A", "B", "C"})
            out.landmarks.push_back({id,
                                     seatingFault ? inspect::LandmarkStatus::NotInspected : inspect::LandmarkStatus::Ok,
                                     0.0, 0.1, 0.05, 0.2});
        return out;
    }
    void cancel() override {}
    std::optional<LoadedProgramInfo> loaded(std::uint16_t number) const override
    {
        return LoadedProgramInfo{number, "block", release};
    }
    std::size_t seatViews() const override { return seatAfter; }
    std::optional<align::AlignmentResult> provisionalSeat() override
    {
        ++provisionalCalls;
        return provisional;
    }

    std::optional<align::AlignmentResult> alignment;
    /// The station's health the views "showed" (none: not watched).
    std::optional<vision::HealthFigures> health;
    /// The release of the program "loaded" (none: a draft).
    std::optional<station::ProgramRelease> release;
    bool seatingFault = false;
    /// The seat of the first `seatAfter` views (0: the program does not correct poses).
    std::size_t seatAfter = 0;
    std::optional<align::AlignmentResult> provisional;
    std::atomic<int> provisionalCalls{0};
    /// Called when the verdict is asked for: after the last grab, before the result is published.
    std::function<void()> onFinish;
    std::function<void(std::uint16_t)> onPrepare;
    std::set<std::uint16_t> unloadable;
    std::mutex mutex;
    std::vector<std::uint16_t> prepared;
    std::vector<std::uint16_t> preparedPrograms()
    {
        std::lock_guard lock(mutex);
        return prepared;
    }
};

/// The simulated line's nest: counts the parts put in, each seated by a known shift.
class CountingSimulation : public SimulationControl {
  public:
    std::vector<std::string> parts() const override { return {"nominal"}; }
    std::string part() const override { return "nominal"; }
    bool selectPart(const std::string&) override { return true; }
    void newPart() override { ++newParts; }
    std::optional<SimulatedSeat> trueSeat() const override
    {
        // Part n is shifted 0.1·n mm along x and turned 0.2° about z through its centre (5, 5, 5).
        const int n = newParts.load();
        const geometry::Vec3 c(5, 5, 5);
        const auto R = geometry::RigidTransform::rotation(geometry::Vec3::UnitZ(), 0.2).R;
        return SimulatedSeat{{R, c + geometry::Vec3(0.1 * n, 0, 0) - R * c}, c};
    }
    std::atomic<int> newParts{0};
};

/// A seat as the aligner reports it: `shiftMm` along x, `rotationDeg` about z.
align::AlignmentResult measuredSeat(double shiftMm, double rotationDeg, bool withinLimits)
{
    align::AlignmentResult a;
    a.measured = true;
    a.seat = geometry::RigidTransform::rotation(geometry::Vec3::UnitZ(), rotationDeg);
    a.seat.t += geometry::Vec3(shiftMm, 0, 0);
    a.shiftMm = shiftMm;
    a.rotationDeg = rotationDeg;
    a.withinLimits = withinLimits;
    return a;
}

Status fails(StatusCode code)
{
    return Status::failure(code, "scripted failure");
}

bool eventually(const std::function<bool()>& condition, std::chrono::seconds deadline = 10s)
{
    const auto until = std::chrono::steady_clock::now() + deadline;
    while (!condition()) {
        if (std::chrono::steady_clock::now() > until) return false;
        std::this_thread::sleep_for(1ms); // polling; the deadline decides, not the sleep
    }
    return true;
}

class CycleRunnerTest : public ::testing::Test {
  protected:
    CycleRunnerTest() : devices(clock), store(dir / "results.db")
    {
        auto cfg = std::make_shared<station::DaemonConfig>();
        station::PartProgramRef program;
        program.number = 1;
        program.views = {{0, 20, 0}, {20, 20, 0}, {40, 20, 0}};
        cfg->programs[1] = program;
        cfg->results.database = dir / "results.db";
        cfg->results.imageDir = dir / "images";
        cfg->sequencer.settle = 50ms;
        config = cfg;
        registers.setKnownPrograms({1});
    }
    ~CycleRunnerTest() override { runner.reset(); }

    void start()
    {
        runner = std::make_unique<CycleRunner>(registers, devices, inspector, store, config, clock);
        runner->start([this] { ++readyCalls; });
    }
    void startReady()
    {
        start();
        // STATUS is the runner's last word on a state change: the lamps and the sequencer are set before it.
        ASSERT_TRUE(eventually([&] { return at(reg::Status) == 0; }));
        EXPECT_EQ(runner->state(), SequencerState::Ready);
    }
    /// The PLC's trigger: program 1 and a new TRIGGER_SEQ in one block.
    void trigger(std::uint16_t seq)
    {
        std::array<std::uint16_t, 2> block{seq, 1};
        ASSERT_EQ(registers.write(reg::TriggerSeq, block), station::ModbusException::None);
    }
    void command(std::uint16_t value)
    {
        std::array<std::uint16_t, 1> v{value};
        ASSERT_EQ(registers.write(reg::Command, v), station::ModbusException::None);
    }
    std::uint16_t at(std::uint16_t address) const { return registers.snapshot()[address]; }
    bool done(std::uint16_t seq) const { return at(reg::DoneSeq) == seq; }
    nlohmann::json lastRecord() const { return store.recent(1).at(0); }

    hgtest::TempDir dir;
    ManualClock clock;
    ScriptedDevices devices;
    PassingInspector inspector;
    store::ResultStore store;
    PlcRegisters registers;
    std::shared_ptr<const station::DaemonConfig> config;
    std::unique_ptr<CycleRunner> runner;
    std::atomic<int> readyCalls{0};
};

/// Figures a station in good order shows: every one within the default limits (vision::HealthLimits).
vision::HealthFigures goodFigures()
{
    vision::HealthFigures f;
    f.backlight = 0.97;
    f.uniformity = 0.02;
    f.dustSpecks = 1;
    f.edgeWidthPx = 1.4;
    f.contrast = 0.85;
    f.noise = 0.006;
    f.predictedSigmaPx = 0.05;
    f.edgeBiasPx = 0.02;
    f.capability = 0.5;
    f.views = 3;
    f.probes = 6;
    return f;
}

// docs/health.md, "In the daemon", with figures built by hand: each cycle's
// health is stored beside its inspection, its warnings are HEALTH_WARNINGS
// (146, a bit per figure) with the result, the journal warns when a figure
// crosses its limit and says when it is back, the plant link gets each
// cycle's message, the status shows it and the lamps are asked for attention
// while a warning stands.
TEST_F(CycleRunnerTest, EachCyclesHealthIsStoredPublishedToThePlcAndJournalledAtItsLimits)
{
    std::mutex sinkMutex;
    std::vector<nlohmann::json> published;
    hgtest::LogCapture journal("health");
    const auto publishedCount = [&] {
        std::lock_guard lock(sinkMutex);
        return published.size();
    };
    inspector.health = goodFigures();
    runner = std::make_unique<CycleRunner>(registers, devices, inspector, store, config, clock);
    runner->setHealthSink([&](const nlohmann::json& m) {
        std::lock_guard lock(sinkMutex);
        published.push_back(m);
    });
    runner->start([] {});
    ASSERT_TRUE(eventually([&] { return at(reg::Status) == 0; }));
    trigger(1);
    ASSERT_TRUE(eventually([&] { return done(1); }));
    EXPECT_EQ(at(reg::HealthWarnings), 0);
    // The journal, the attention and the plant link follow the result's publication.
    ASSERT_TRUE(eventually([&] { return publishedCount() == 1; }));
    EXPECT_FALSE(runner->healthAttention());

    // A dimmer backlight (below 0.80 of the reference) and a blurred edge (wider than 3 px).
    auto worn = goodFigures();
    worn.backlight = 0.75;
    worn.edgeWidthPx = 3.5;
    worn.dustSpecks = vision::kNoFigure; // not measured this cycle
    // Silhouettes 0.3 px small all round (beyond ±0.25), the worst landmark at 0.95 of its bound (above 0.9).
    worn.edgeBiasPx = -0.3;
    worn.capability = 0.95;
    inspector.health = worn;
    trigger(2);
    ASSERT_TRUE(eventually([&] { return done(2); }));
    EXPECT_EQ(at(reg::HealthWarnings), (1 << 0) | (1 << 3) | (1 << 6) | (1 << 7)); // backlight, focus, bias, capability
    ASSERT_TRUE(eventually([&] { return publishedCount() == 2; }));
    EXPECT_TRUE(runner->healthAttention());
    // The operator's lamps: the verdict with amber steady beside it (docs/lamps.md).
    EXPECT_TRUE(eventually([&] { return devices.lamps().back() == LampPattern::PassAttention; }))
        << enumName(devices.lamps().back());
    EXPECT_EQ(journal.count(spdlog::level::warn, "backlight 0.75 of the reference — below limit 0.80"), 1)
        << journal.text();
    EXPECT_EQ(journal.count(spdlog::level::warn, "focus: edge width 3.50 px (10-90 %) — above limit 3.00"), 1)
        << journal.text();
    EXPECT_EQ(journal.count(spdlog::level::warn,
                            "edge bias -0.300 px (silhouettes against the CAD outline) — beyond limit ±0.250"),
              1)
        << journal.text();
    EXPECT_EQ(journal.count(spdlog::level::warn,
                            "capability 0.95 of the worst landmark's bound (4 U / zone) — above limit 0.90"),
              1)
        << journal.text();
    const auto status = runner->health();
    EXPECT_EQ(status["warnings"], nlohmann::json::array({"backlight", "focus", "edge_bias", "capability"}));
    EXPECT_EQ(status["figures"]["backlight"], 0.75);
    EXPECT_TRUE(status["figures"]["dust_specks"].is_null());
    EXPECT_EQ(status["states"][2]["sentence"], "dust not measured");
    EXPECT_TRUE(status["states"][2]["within"].is_null());
    EXPECT_EQ(status["states"][4]["within"], true);

    // The same again warns no more; back within, the journal says so once.
    trigger(3);
    ASSERT_TRUE(eventually([&] { return done(3) && publishedCount() == 3; }));
    inspector.health = goodFigures();
    trigger(4);
    ASSERT_TRUE(eventually([&] { return done(4); }));
    EXPECT_EQ(at(reg::HealthWarnings), 0);
    ASSERT_TRUE(eventually([&] { return publishedCount() == 4; }));
    EXPECT_FALSE(runner->healthAttention());
    EXPECT_TRUE(eventually([&] { return devices.lamps().back() == LampPattern::Pass; }))
        << enumName(devices.lamps().back());
    EXPECT_EQ(journal.count(spdlog::level::warn, "backlight"), 1) << journal.text();
    EXPECT_EQ(journal.count(spdlog::level::info, "back within its limit"), 4) << journal.text();

    // The store: one health row per cycle, with its inspection's id.
    const auto rows = store::ResultReader(dir / "results.db").health({});
    ASSERT_EQ(rows.size(), 4u);
    EXPECT_EQ(rows[1]["inspection_id"], 2);
    EXPECT_EQ(rows[1]["backlight"], 0.75);
    EXPECT_EQ(rows[1]["edge_bias_px"], -0.3);
    EXPECT_EQ(rows[1]["capability"], 0.95);
    EXPECT_EQ(rows[1]["warnings"], nlohmann::json::array({"backlight", "focus", "edge_bias", "capability"}));
    EXPECT_EQ(rows[3]["warnings"], nlohmann::json::array());
    // The plant link's messages, one per cycle, with the result's cycle id.
    std::lock_guard lock(sinkMutex);
    EXPECT_EQ(published[1]["warnings"], nlohmann::json::array({"backlight", "focus", "edge_bias", "capability"}));
    EXPECT_EQ(published[1]["warning_bits"], 1 + 8 + 64 + 128);
    EXPECT_EQ(published[1]["figures"]["edge_bias_px"], -0.3);
    EXPECT_EQ(published[1]["serial"], "");
    auto outbox = store::ResultOutbox(dir / "results.db").pending(1, 1);
    ASSERT_EQ(outbox.size(), 1u);
    EXPECT_EQ(published[1]["cycle_id"], outbox[0].cycleId);
}

TEST_F(CycleRunnerTest, FailTheFirstMovePassTheRetry)
{
    devices.moves.push_back([] { return fails(StatusCode::Timeout); });
    startReady();
    EXPECT_EQ(at(reg::Status), 0); // ready
    trigger(5);
    ASSERT_TRUE(eventually([&] { return done(5); }));
    // The first move of view 0 timed out, its retry passed; views 1 and 2 moved once each.
    EXPECT_EQ(devices.moveRetries(), (std::vector<bool>{false, true, false, false}));
    EXPECT_EQ(devices.grabCount(), 3);
    EXPECT_EQ(at(reg::Result), 1); // pass
    EXPECT_EQ(at(reg::FaultCode), 0);
    EXPECT_EQ(at(reg::Status), 2); // done
    EXPECT_EQ(at(reg::LandmarksTotal), 3);
    EXPECT_EQ(at(reg::LandmarkOkBits), 0b111);
    EXPECT_EQ(runner->state(), SequencerState::Done);
    EXPECT_EQ(devices.lamps(), (std::vector<LampPattern>{LampPattern::Off, LampPattern::Busy, LampPattern::Pass}));
    auto record = lastRecord();
    EXPECT_EQ(record["trigger_seq"], 5);
    EXPECT_EQ(record["verdict"], "pass");
    EXPECT_EQ(record["landmarks_total"], 3);
    // Three settle times of 50 ms passed on the runner's clock, nothing else did.
    EXPECT_EQ(record["cycle_ms"], 150);
    EXPECT_EQ(readyCalls.load(), 1);
}

TEST_F(CycleRunnerTest, APartNotSeatedIsResultThreeFault32AndTheNextTriggerIsTaken)
{
    inspector.alignment = measuredSeat(2.0004, 0.1234, false);
    inspector.seatingFault = true;
    startReady();
    trigger(3);
    ASSERT_TRUE(eventually([&] { return done(3); }));
    EXPECT_EQ(at(reg::Result), 3);             // aborted / error
    EXPECT_EQ(at(reg::FaultCode), 32);         // part-not-seated
    EXPECT_EQ(at(reg::Status), 2);             // done: no station fault, no recovery
    EXPECT_EQ(at(reg::SeatShiftUm), 2000);     // 2000.4 µm
    EXPECT_EQ(at(reg::SeatRotationMdeg), 123); // 123.4 mdeg
    EXPECT_EQ(at(reg::LandmarksTotal), 0);     // nothing was inspected
    EXPECT_TRUE(devices.recoverTimes().empty());
    EXPECT_EQ(runner->state(), SequencerState::Done);
    EXPECT_EQ(devices.lamps().back(), LampPattern::Reseat); // amber blinking: re-seat the part
    auto record = lastRecord();
    EXPECT_EQ(record["verdict"], "error");
    EXPECT_EQ(record["fault_code"], 32);
    ASSERT_TRUE(record["alignment"].is_object()); // the record keeps the pose
    EXPECT_DOUBLE_EQ(record["alignment"]["shift_mm"].get<double>(), 2.0004);
    EXPECT_DOUBLE_EQ(record["alignment"]["rotation_deg"].get<double>(), 0.1234);
    EXPECT_TRUE(record["simulation"].is_null()); // real hardware: no simulated part

    // Re-seated, the part is inspected; the registers show the new seat with its result.
    inspector.alignment = measuredSeat(0.25, 0.0, true);
    inspector.seatingFault = false;
    trigger(4);
    ASSERT_TRUE(eventually([&] { return done(4); }));
    EXPECT_EQ(at(reg::Result), 1);
    EXPECT_EQ(at(reg::FaultCode), 0);
    EXPECT_EQ(at(reg::SeatShiftUm), 250);
    EXPECT_EQ(at(reg::SeatRotationMdeg), 0);
    EXPECT_EQ(devices.lamps().back(), LampPattern::Pass);
    EXPECT_EQ(runner->describe()["last_cycle"]["alignment"]["shift_mm"], 0.25); // ctl status shows the last seat
}

TEST_F(CycleRunnerTest, TheSimulatedLineSeatsANewPartEveryCycleAndRecordsItsTrueSeat)
{
    CountingSimulation simulation;
    runner = std::make_unique<CycleRunner>(registers, devices, inspector, store, config, clock);
    runner->setSimulation(&simulation);
    runner->start([this] { ++readyCalls; });
    ASSERT_TRUE(eventually([&] { return at(reg::Status) == 0; }));
    EXPECT_EQ(simulation.newParts.load(), 0);
    trigger(1);
    ASSERT_TRUE(eventually([&] { return done(1); }));
    trigger(2);
    ASSERT_TRUE(eventually([&] { return done(2); }));
    EXPECT_EQ(simulation.newParts.load(), 2);
    auto record = lastRecord();
    EXPECT_EQ(record["simulation"]["part"], "nominal");
    const auto& seat = record["simulation"]["seat"];
    EXPECT_NEAR(seat["shift_mm"].get<double>(), 0.2, 1e-12); // part 2: 0.2 mm at the pivot
    EXPECT_NEAR(seat["rotation_deg"].get<double>(), 0.2, 1e-9);
    EXPECT_EQ(seat["centre"], nlohmann::json({5.0, 5.0, 5.0}));
    // R·c + t = c + d: the pivot moves by the shift alone.
    const double cx = 5.0;
    const double x = seat["R"][0][0].get<double>() * cx + seat["R"][0][1].get<double>() * cx +
                     seat["R"][0][2].get<double>() * cx + seat["t"][0].get<double>();
    EXPECT_NEAR(x, 5.2, 1e-12);
    EXPECT_EQ(runner->describe()["last_cycle"]["simulation"]["seat"]["centre"], seat["centre"]);
    runner.reset(); // before the simulation it was given
}

// The planned poses after the first views are corrected for the seat those
// views measured (docs/alignment.md, "Poses corrected for the seat"). The
// station is the tests' (camera 300 mm off on the part's -y side, turntable
// about z, tilt about x); the seat a turn of 0.3° about the turntable's axis,
// which the turntable takes off exactly: views 1 and 2 at rotation −0.3°.
TEST_F(CycleRunnerTest, PosesAfterTheFirstViewsAreCorrectedForTheirSeat)
{
    auto cfg = std::make_shared<station::DaemonConfig>(*config);
    cfg->station = hgtest::station();
    config = cfg;
    inspector.seatAfter = 1;
    inspector.provisional = measuredSeat(0.0, 0.3, true); // about z through the origin, the reference point
    inspector.alignment = inspector.provisional;
    startReady();
    trigger(7);
    ASSERT_TRUE(eventually([&] { return done(7); }));
    EXPECT_EQ(inspector.provisionalCalls.load(), 1);
    const auto poses = devices.poses();
    ASSERT_EQ(poses.size(), 3u);
    EXPECT_EQ(poses[0], (geometry::FixturePose{0, 20, 0})); // measured the seat: as planned
    EXPECT_NEAR(poses[1].rotationDeg, 20 - 0.3, 1e-9);
    EXPECT_NEAR(poses[1].declinationDeg, 20, 1e-9);
    EXPECT_NEAR(poses[2].rotationDeg, 40 - 0.3, 1e-9);
    EXPECT_NEAR(poses[2].declinationDeg, 20, 1e-9);
    EXPECT_EQ(at(reg::Result), 1);

    const auto pc = lastRecord()["alignment"]["pose_correction"];
    ASSERT_TRUE(pc.is_object());
    EXPECT_EQ(pc["after_views"], 1);
    EXPECT_EQ(pc["applied"], true);
    ASSERT_EQ(pc["views"].size(), 3u);
    EXPECT_EQ(pc["views"][0]["corrected"], false);
    EXPECT_EQ(pc["views"][1]["corrected"], true);
    EXPECT_NEAR(pc["views"][2]["commanded"]["rotation_deg"].get<double>(), 39.7, 1e-9);
    EXPECT_EQ(pc["views"][2]["planned"]["rotation_deg"], 40.0);
    // View 0 saw the part turned: its line of sight, at elevation 20° from the
    // reference point, is off by the chord angle 2·asin(cos 20° · sin 0.15°).
    const double expected =
        geometry::radToDeg(2 * std::asin(std::cos(geometry::degToRad(20)) * std::sin(geometry::degToRad(0.15))));
    EXPECT_NEAR(pc["views"][0]["sight_error_deg"].get<double>(), expected, 1e-9);
    EXPECT_LT(pc["views"][1]["sight_error_deg"].get<double>(), 1e-7);
    EXPECT_LT(pc["views"][2]["sight_error_deg"].get<double>(), 1e-7);
}

TEST_F(CycleRunnerTest, ASeatTheFirstViewsCannotMeasureLeavesThePosesAsPlanned)
{
    auto cfg = std::make_shared<station::DaemonConfig>(*config);
    cfg->station = hgtest::station();
    config = cfg;
    inspector.seatAfter = 2;
    inspector.provisional = measuredSeat(2.5, 0.3, false); // beyond the limits
    inspector.alignment = measuredSeat(0.0, 0.3, true);
    startReady();
    trigger(8);
    ASSERT_TRUE(eventually([&] { return done(8); }));
    EXPECT_EQ(devices.poses(), config->programs.at(1).views);
    const auto pc = lastRecord()["alignment"]["pose_correction"];
    EXPECT_EQ(pc["applied"], false);
    EXPECT_EQ(pc["after_views"], 2);

    // A program that does not correct poses is not asked for a seat at all.
    inspector.seatAfter = 0;
    inspector.provisionalCalls = 0;
    trigger(9);
    ASSERT_TRUE(eventually([&] { return done(9); }));
    EXPECT_EQ(inspector.provisionalCalls.load(), 0);
    EXPECT_FALSE(lastRecord()["alignment"].contains("pose_correction"));
}

TEST_F(CycleRunnerTest, GrabTimesOutTwiceFaultsWithItsCodeThenRecovers)
{
    devices.grabs.push_back([] { return Status::success(); });
    devices.grabs.push_back([] { return fails(StatusCode::Timeout); });
    devices.grabs.push_back([] { return fails(StatusCode::Timeout); });
    startReady();
    trigger(1);
    ASSERT_TRUE(eventually([&] { return done(1); }));
    EXPECT_EQ(at(reg::Result), 3);     // aborted / error
    EXPECT_EQ(at(reg::FaultCode), 10); // camera-timeout
    EXPECT_TRUE(devices.stopped());
    auto record = lastRecord();
    EXPECT_EQ(record["verdict"], "error");
    EXPECT_EQ(record["fault_code"], 10);
    // The sequencer recovers at once after a faulted cycle; the scripted recovery passes.
    ASSERT_TRUE(eventually([&] { return at(reg::Status) == 0; }));
    EXPECT_EQ(runner->state(), SequencerState::Ready);
    EXPECT_EQ(devices.recoverTimes().size(), 1u);
    EXPECT_EQ(devices.lamps(),
              (std::vector<LampPattern>{LampPattern::Off, LampPattern::Busy, LampPattern::Fault, LampPattern::Off}));
    EXPECT_EQ(devices.grabCount(), 3);
}

// `sequencer.retries` from a reload (docs/daemon.md): the next cycle takes it,
// the running one keeps the count it started with.
TEST_F(CycleRunnerTest, RetriesFromAReloadApplyFromTheNextCycle)
{
    const auto withRetries = [&](int retries) {
        auto cfg = std::make_shared<station::DaemonConfig>(*config);
        cfg->sequencer.retries = retries;
        return std::shared_ptr<const station::DaemonConfig>(std::move(cfg));
    };
    startReady(); // sequencer.retries 1
    runner->setConfig(withRetries(2));
    // View 0's grab times out twice; the third attempt, the second retry, passes.
    devices.grabs.push_back([] { return fails(StatusCode::Timeout); });
    devices.grabs.push_back([] { return fails(StatusCode::Timeout); });
    trigger(1);
    ASSERT_TRUE(eventually([&] { return done(1); }));
    EXPECT_EQ(at(reg::Result), 1);
    EXPECT_EQ(at(reg::FaultCode), 0);
    EXPECT_EQ(devices.grabCount(), 5);

    // A reload to no retries while a cycle runs: that cycle still retries twice.
    devices.grabs.push_back([&] {
        runner->setConfig(withRetries(0));
        return fails(StatusCode::Timeout);
    });
    devices.grabs.push_back([] { return fails(StatusCode::Timeout); });
    trigger(2);
    ASSERT_TRUE(eventually([&] { return done(2); }));
    EXPECT_EQ(at(reg::Result), 1);
    EXPECT_EQ(devices.grabCount(), 10);

    // The next cycle has none: its first timeout faults it. The recovery fails, so
    // the station stays in fault (the next attempt is due on the runner's clock).
    devices.grabs.push_back([] { return fails(StatusCode::Timeout); });
    devices.recoveries.push_back([] { return fails(StatusCode::CommunicationError); });
    trigger(3);
    ASSERT_TRUE(eventually([&] { return done(3); }));
    EXPECT_EQ(at(reg::Result), 3);
    EXPECT_EQ(at(reg::FaultCode), 10); // camera-timeout
    EXPECT_EQ(devices.grabCount(), 11);
    ASSERT_TRUE(eventually([&] { return devices.recoverTimes().size() == 1; }));
    EXPECT_EQ(runner->describe()["fault"], "no frame from the camera within the grab timeout (without a retry)");
}

// The operator's fault text (ctl status) says how many retries the cycle had.
TEST_F(CycleRunnerTest, TheFaultSaysHowManyRetriesTheCycleHad)
{
    auto cfg = std::make_shared<station::DaemonConfig>(*config);
    cfg->sequencer.retries = 2;
    config = cfg;
    for (int k = 0; k < 3; ++k) devices.moves.push_back([] { return fails(StatusCode::Timeout); });
    devices.recoveries.push_back([] { return fails(StatusCode::CommunicationError); });
    startReady();
    trigger(1);
    ASSERT_TRUE(eventually([&] { return done(1); }));
    EXPECT_EQ(at(reg::FaultCode), 20); // fixture-timeout
    EXPECT_EQ(devices.moveRetries(), (std::vector<bool>{false, true, true}));
    ASSERT_TRUE(eventually([&] { return devices.recoverTimes().size() == 1; }));
    EXPECT_EQ(runner->state(), SequencerState::Fault);
    auto status = runner->describe();
    EXPECT_EQ(status["fault_code"], 20);
    EXPECT_EQ(status["fault"], "the fixture did not reach position within the move timeout (after 2 retries)");
}

TEST_F(CycleRunnerTest, AbortMidCycleEndsItAsAbortedByThePlc)
{
    // The PLC writes COMMAND = 1 while the fixture moves to view 1.
    devices.moves.push_back([] { return Status::success(); });
    devices.moves.push_back([this] {
        command(1);
        return Status::success();
    });
    startReady();
    trigger(9);
    ASSERT_TRUE(eventually([&] { return done(9); }));
    EXPECT_EQ(at(reg::Result), 3);
    EXPECT_EQ(at(reg::FaultCode), 40); // aborted-by-plc
    EXPECT_EQ(at(reg::Status), 2);     // done: an abort is not a station fault
    EXPECT_EQ(devices.grabCount(), 1); // view 1 was never grabbed
    EXPECT_TRUE(devices.stopped());
    EXPECT_EQ(runner->state(), SequencerState::Done);
    EXPECT_EQ(lastRecord()["verdict"], "aborted");
    EXPECT_EQ(devices.lamps(), (std::vector<LampPattern>{LampPattern::Off, LampPattern::Busy, LampPattern::Off}));
    EXPECT_TRUE(devices.recoverTimes().empty());
}

TEST_F(CycleRunnerTest, AbortSentWhileIdleDoesNotAbortTheNextPart)
{
    startReady();
    command(1);                    // the PLC's abort, between cycles
    EXPECT_FALSE(runner->abort()); // the maintenance socket's, too
    trigger(4);
    ASSERT_TRUE(eventually([&] { return done(4); }));
    EXPECT_EQ(at(reg::Result), 1); // pass: all three views grabbed
    EXPECT_EQ(at(reg::FaultCode), 0);
    EXPECT_EQ(devices.grabCount(), 3);
    EXPECT_EQ(lastRecord()["verdict"], "pass");
}

// The register map alone, no runner thread: whether an abort is kept depends
// only on STATUS when it is written, never on when the runner looks.
TEST(PlcRegistersAbort, KeptOnlyWhileACycleOrCalibrationRuns)
{
    PlcRegisters registers;
    auto write = [&](std::uint16_t value) {
        std::array<std::uint16_t, 1> v{value};
        ASSERT_EQ(registers.write(reg::Command, v), station::ModbusException::None);
    };
    using station::PlcStatus;
    for (auto idle : {PlcStatus::Ready, PlcStatus::Done, PlcStatus::Fault, PlcStatus::Starting}) {
        registers.setStatus(idle);
        write(1);
        EXPECT_FALSE(registers.takeCommands().abort) << static_cast<int>(idle);
    }
    for (auto running : {PlcStatus::Busy, PlcStatus::Maintenance}) {
        registers.setStatus(running);
        write(1);
        EXPECT_TRUE(registers.takeCommands().abort) << static_cast<int>(running);
    }
    // A fault reset written with a dropped abort is still taken.
    registers.setStatus(PlcStatus::Fault);
    write(2);
    write(1);
    auto commands = registers.takeCommands();
    EXPECT_TRUE(commands.resetFault);
    EXPECT_FALSE(commands.abort);
    EXPECT_FALSE(registers.takeCommands().any());
}

TEST_F(CycleRunnerTest, FaultResetSentMidCycleIsAppliedAfterIt)
{
    // COMMAND = 2 arrives during the first grab; the grabs of view 1 then time out twice.
    devices.grabs.push_back([this] {
        command(2);
        return Status::success();
    });
    devices.grabs.push_back([] { return fails(StatusCode::Timeout); });
    devices.grabs.push_back([] { return fails(StatusCode::Timeout); });
    // The recovery right after the faulted cycle fails; the sequencer would wait 2 s to retry.
    devices.recoveries.push_back([] { return fails(StatusCode::Fault); });
    startReady();
    trigger(3);
    ASSERT_TRUE(eventually([&] { return done(3); }));
    EXPECT_EQ(at(reg::FaultCode), 10);
    // The reset was kept through the cycle: the second attempt follows at once, with no
    // time passing on the runner's clock, and brings the station back.
    ASSERT_TRUE(eventually([&] { return at(reg::Status) == 0; }));
    EXPECT_EQ(runner->state(), SequencerState::Ready);
    auto times = devices.recoverTimes();
    ASSERT_EQ(times.size(), 2u);
    EXPECT_EQ(times[1], times[0]);
    EXPECT_EQ(devices.lamps().back(), LampPattern::Off);
}

TEST_F(CycleRunnerTest, RecoverFailsThenSucceedsAfterTheSequencersWait)
{
    devices.startStatus = fails(StatusCode::CommunicationError);
    devices.recoveries.push_back([] { return fails(StatusCode::CommunicationError); });
    start();
    ASSERT_TRUE(eventually([&] { return at(reg::Status) == 3; }));
    EXPECT_EQ(runner->state(), SequencerState::Fault);
    EXPECT_EQ(runner->describe()["fault_code"], 43); // devices-down
    EXPECT_EQ(readyCalls.load(), 0);
    const auto t0 = clock.now();
    // Time passes on the runner's clock, 10 ms per poll, until the station is back: the
    // devices failed to start, so the first recovery is due 2 s later; it fails, and the
    // next one is due 2 s after that failure, and passes.
    ASSERT_TRUE(eventually([&] {
        clock.advance(10ms);
        return at(reg::Status) == 0;
    }));
    EXPECT_EQ(runner->state(), SequencerState::Ready);
    auto times = devices.recoverTimes();
    ASSERT_EQ(times.size(), 2u);
    EXPECT_GE(times[0] - t0, 2s);
    EXPECT_GE(times[1] - times[0], 2s);
    // READY=1 once, when the devices first came up (sent right after STATUS shows ready).
    EXPECT_TRUE(eventually([&] { return readyCalls.load() == 1; }));
    EXPECT_EQ(readyCalls.load(), 1);
    EXPECT_EQ(devices.lamps(), (std::vector<LampPattern>{LampPattern::Fault, LampPattern::Off}));
    // And the station serves triggers.
    trigger(1);
    ASSERT_TRUE(eventually([&] { return done(1); }));
    EXPECT_EQ(at(reg::Result), 1);
}

// ---- the production-line handshake (docs/plc.md) -----------------------------

TEST_F(CycleRunnerTest, AcquisitionDoneIsSetWhenTheLastFrameIsInBeforeDoneSeq)
{
    std::vector<std::array<std::uint16_t, 2>> atFinish; // ACQ_DONE_SEQ, DONE_SEQ when the verdict is asked for
    std::vector<std::uint16_t> acqAtGrab;               // ACQ_DONE_SEQ as each grab is asked for
    inspector.onFinish = [&] { atFinish.push_back({at(reg::AcqDoneSeq), at(reg::DoneSeq)}); };
    for (int k = 0; k < 3; ++k)
        devices.grabs.push_back([&] {
            acqAtGrab.push_back(at(reg::AcqDoneSeq));
            return Status::success();
        });
    startReady();
    trigger(5);
    ASSERT_TRUE(eventually([&] { return done(5); }));
    // Not before the last grab, set once it is in, before the verdict and DONE_SEQ.
    EXPECT_EQ(acqAtGrab, (std::vector<std::uint16_t>{0, 0, 0}));
    ASSERT_EQ(atFinish.size(), 1u);
    EXPECT_EQ(atFinish[0], (std::array<std::uint16_t, 2>{5, 0}));
    EXPECT_EQ(at(reg::AcqDoneSeq), 5);
    EXPECT_EQ(at(reg::ResultSeq), 1);
}

TEST_F(CycleRunnerTest, ACycleThatFaultsBeforeItsLastGrabSetsAcquisitionDoneWithDoneSeq)
{
    std::vector<std::uint16_t> acqAtMove;
    devices.moves.push_back([] { return Status::success(); });
    devices.moves.push_back([] { return Status::success(); });
    // View 2's move times out twice: the cycle faults before its last grab.
    devices.moves.push_back([&] {
        acqAtMove.push_back(at(reg::AcqDoneSeq));
        return fails(StatusCode::Timeout);
    });
    devices.moves.push_back([&] {
        acqAtMove.push_back(at(reg::AcqDoneSeq));
        return fails(StatusCode::Timeout);
    });
    startReady();
    trigger(6);
    ASSERT_TRUE(eventually([&] { return done(6); }));
    EXPECT_EQ(at(reg::FaultCode), 20); // fixture-timeout
    EXPECT_EQ(acqAtMove, (std::vector<std::uint16_t>{0, 0}));
    EXPECT_EQ(at(reg::AcqDoneSeq), 6);
    EXPECT_EQ(station::readCounters(registers.snapshot()), (station::PlcCounters{1, 0, 0, 1, 0}));
}

TEST_F(CycleRunnerTest, CountersFollowTheResultsAndCommandThreeResetsThem)
{
    startReady();
    trigger(1);
    ASSERT_TRUE(eventually([&] { return done(1); }));
    // The abort arrives while the fixture moves to view 1: RESULT 3, counted as a fault.
    devices.moves.push_back([] { return Status::success(); });
    devices.moves.push_back([this] {
        command(1);
        return Status::success();
    });
    trigger(2);
    ASSERT_TRUE(eventually([&] { return done(2); }));
    EXPECT_EQ(at(reg::Result), 3);
    trigger(2); // the same value: no trigger
    std::array<std::uint16_t, 2> unknown{3, 9};
    ASSERT_EQ(registers.write(reg::TriggerSeq, unknown), station::ModbusException::None); // refused: missed
    // A manual cycle is not the PLC's: not counted.
    EXPECT_EQ(registers.triggerManually(1, "BENCH"), station::RejectReason::None);
    ASSERT_TRUE(eventually([&] { return runner->describe()["cycles"] == 3; }));
    auto regs = registers.snapshot();
    // Read in one snapshot with DONE_SEQ 2: the counters include its result.
    EXPECT_EQ(regs[reg::DoneSeq], 2);
    EXPECT_EQ(station::readCounters(regs), (station::PlcCounters{2, 1, 0, 1, 1}));
    EXPECT_EQ(regs[reg::ResultSeq], 2);
    EXPECT_EQ(regs[reg::ResultRing + 8 + station::ring::TriggerSeq], 1); // result 1 in entry 1
    EXPECT_EQ(regs[reg::ResultRing + 16 + station::ring::TriggerSeq], 2);
    EXPECT_EQ(regs[reg::ResultRing + 16 + station::ring::FaultCode], 40);
    command(3);
    EXPECT_EQ(station::readCounters(registers.snapshot()), station::PlcCounters{});
    EXPECT_EQ(registers.snapshot()[reg::ResultSeq], 2); // not a counter
}

TEST_F(CycleRunnerTest, ChangeoverPreparesTheProgramBetweenCyclesAndShowsItReady)
{
    auto cfg = std::make_shared<station::DaemonConfig>(*config);
    station::PartProgramRef two = cfg->programs.at(1);
    two.number = 2;
    cfg->programs[2] = two;
    two.number = 4;
    cfg->programs[4] = two;
    config = cfg;
    registers.setKnownPrograms({1, 2, 4});
    inspector.unloadable = {4};
    // PART_PROGRAM 2 is written while the fixture moves to view 1 of trigger 1's cycle.
    std::atomic<bool> preparedDuringCycle{false};
    inspector.onPrepare = [&](std::uint16_t) {
        if (at(reg::DoneSeq) != 1) preparedDuringCycle = true;
    };
    devices.moves.push_back([] { return Status::success(); });
    devices.moves.push_back([this] {
        std::array<std::uint16_t, 1> program{2};
        EXPECT_EQ(registers.write(reg::PartProgram, program), station::ModbusException::None);
        return Status::success();
    });
    startReady();
    trigger(1);
    ASSERT_TRUE(eventually([&] { return done(1); }));
    EXPECT_EQ(at(reg::Result), 1); // the running cycle went on with program 1
    ASSERT_TRUE(eventually([&] { return at(reg::ProgramState) == 1; }));
    EXPECT_EQ(at(reg::ActiveProgram), 2);
    EXPECT_FALSE(preparedDuringCycle.load());
    EXPECT_EQ(inspector.preparedPrograms(), (std::vector<std::uint16_t>{2}));
    EXPECT_EQ(devices.grabCount(), 3);

    // Program 4 does not load: not ready, with the reason; a trigger is still accepted and
    // its cycle tries the load itself (FAULT_CODE 30 when that fails too, docs/plc.md).
    std::array<std::uint16_t, 1> four{4};
    ASSERT_EQ(registers.write(reg::PartProgram, four), station::ModbusException::None);
    ASSERT_TRUE(eventually([&] { return at(reg::ProgramState) == 4; }));
    EXPECT_EQ(at(reg::ActiveProgram), 4);
    // Program 9 is not configured: not ready at once, and its trigger is refused.
    std::array<std::uint16_t, 2> nine{2, 9};
    ASSERT_EQ(registers.write(reg::TriggerSeq, nine), station::ModbusException::None);
    EXPECT_EQ(at(reg::ActiveProgram), 9);
    EXPECT_EQ(at(reg::ProgramState), 3);
    EXPECT_EQ(at(reg::AckSeq), 1);
    EXPECT_EQ(at(reg::LastRejectReason), 2);
    EXPECT_EQ(inspector.preparedPrograms(), (std::vector<std::uint16_t>{2, 4}));
}

// The record names the release of the program the part was judged with
// (docs/daemon.md, "Result store"), and so does the status: the last cycle
// and the program loaded; a draft's result names none.
TEST_F(CycleRunnerTest, TheResultNamesTheReleaseOfTheProgramAndADraftsNone)
{
    const std::string digest(64, 'c');
    inspector.release = station::ProgramRelease{4, digest};
    startReady();
    trigger(1);
    ASSERT_TRUE(eventually([&] { return done(1); }));
    auto record = lastRecord();
    EXPECT_EQ(record["program_version"], 4);
    EXPECT_EQ(record["program_sha256"], digest);
    EXPECT_EQ(runner->describe()["last_cycle"]["program_version"], 4);
    EXPECT_EQ(runner->describe()["last_cycle"]["program_sha256"], digest);
    EXPECT_EQ(runner->program(), (nlohmann::json{{"number", 1},
                                                 {"part", "block"},
                                                 {"material", ""}, // the program names none (docs/daemon.md)
                                                 {"version", 4},
                                                 {"verification_sha256", digest}}));

    inspector.release.reset();
    trigger(2);
    ASSERT_TRUE(eventually([&] { return done(2); }));
    record = lastRecord();
    EXPECT_EQ(record["verdict"], "pass");
    EXPECT_TRUE(record["program_version"].is_null());
    EXPECT_TRUE(record["program_sha256"].is_null());
    EXPECT_TRUE(runner->describe()["last_cycle"]["program_version"].is_null());
    EXPECT_TRUE(runner->program()["version"].is_null());
    EXPECT_EQ(runner->program()["number"], 1);
}

TEST_F(CycleRunnerTest, AFaultResetOutsideAFaultChangesNothing)
{
    startReady();
    command(2);
    trigger(4);
    ASSERT_TRUE(eventually([&] { return done(4); }));
    EXPECT_EQ(at(reg::Result), 1);
    EXPECT_TRUE(devices.recoverTimes().empty());
}

} // namespace
} // namespace hg::daemon

namespace hg::daemon {
namespace {

// A camera frame on demand (docs/hmi.md, "Maintenance"): grabbed between
// cycles at the pose asked for, segmented with the station's settings
// (Otsu, dark object), the station back to ready after it.
TEST_F(CycleRunnerTest, ASnapshotIsGrabbedAtItsPoseWithTheSilhouetteItShows)
{
    // Backlight 220 with a dark 20 × 10 px part at 20 on a 64 × 48 frame.
    devices.frame = cv::Mat(48, 64, CV_8UC1, cv::Scalar(220));
    devices.frame(cv::Rect(10, 12, 20, 10)).setTo(cv::Scalar(20));
    startReady();
    EXPECT_EQ(runner->snapshot().png(), nullptr);
    Status queued = runner->requestSnapshot({geometry::FixturePose{30, 10, 0}});
    ASSERT_TRUE(queued.ok()) << queued.message();
    ASSERT_TRUE(eventually([&] { return runner->snapshot().status().value("state", "") == "done"; }));
    const auto s = runner->snapshot().status();
    EXPECT_EQ(s.at("id"), 1);
    EXPECT_EQ(s.at("width"), 64);
    EXPECT_EQ(s.at("height"), 48);
    EXPECT_EQ(s.at("depth_bits"), 8);
    EXPECT_DOUBLE_EQ(s.at("object_fraction").get<double>(), 200.0 / (64 * 48));
    EXPECT_EQ(s.at("backlight_grey"), 220);
    EXPECT_EQ(s.at("object_grey"), 20);
    const double t = s.at("segmentation").at("threshold").get<double>();
    EXPECT_TRUE(t >= 20 && t < 220) << t;
    EXPECT_EQ(s.at("pose").at("rotation_deg"), 30);
    ASSERT_EQ(devices.poses().size(), 1u);
    EXPECT_EQ(devices.poses()[0], (geometry::FixturePose{30, 10, 0}));
    // Whole frames, whatever region the last cycle left the camera on.
    EXPECT_EQ(devices.calls(), (std::vector<std::string>{"region [0, 0, 0, 0]", "grab"}));
    const auto png = runner->snapshot().png();
    ASSERT_NE(png, nullptr);
    const auto decoded = cv::imdecode(*png, cv::IMREAD_UNCHANGED);
    EXPECT_EQ(decoded.size(), cv::Size(64, 48));
    EXPECT_EQ(decoded.type(), CV_8UC3);
    // Production was paused for it (the amber lamp busy) and resumes.
    const auto lamps = devices.lamps();
    EXPECT_NE(std::find(lamps.begin(), lamps.end(), LampPattern::Busy), lamps.end());
    ASSERT_TRUE(eventually([&] { return at(reg::Status) == 0; }));
    EXPECT_EQ(runner->state(), SequencerState::Ready);
    // A second one without a pose: the fixture stays, the id counts up.
    queued = runner->requestSnapshot({});
    ASSERT_TRUE(queued.ok()) << queued.message();
    ASSERT_TRUE(eventually([&] {
        const auto st = runner->snapshot().status();
        return st.value("state", "") == "done" && st.value("id", 0) == 2;
    }));
    EXPECT_EQ(devices.poses().size(), 1u);
    EXPECT_TRUE(runner->snapshot().status().at("pose").is_null());
}

TEST_F(CycleRunnerTest, ASnapshotWhoseGrabFailsSaysWhyAndTheStationRecovers)
{
    devices.grabs.push_back([] { return fails(StatusCode::Timeout); });
    startReady();
    const Status queued = runner->requestSnapshot({});
    ASSERT_TRUE(queued.ok()) << queued.message();
    ASSERT_TRUE(eventually([&] { return runner->snapshot().status().value("state", "") == "failed"; }));
    EXPECT_NE(runner->snapshot().status().value("error", "").find("camera:"), std::string::npos);
    EXPECT_EQ(runner->snapshot().png(), nullptr);
    ASSERT_TRUE(eventually([&] { return devices.recoverTimes().size() == 1; }));
    ASSERT_TRUE(eventually([&] { return at(reg::Status) == 0; }));
    // The next trigger runs as ever.
    trigger(7);
    ASSERT_TRUE(eventually([&] { return done(7); }));
    EXPECT_EQ(at(reg::Result), 1);
}

TEST_F(CycleRunnerTest, ASnapshotIsRefusedWhileTheStationIsFaulted)
{
    devices.startStatus = fails(StatusCode::IoError);
    start();
    ASSERT_TRUE(eventually([&] { return at(reg::Status) == 3; }));
    const Status refused = runner->requestSnapshot({});
    const std::string& why = refused.message();
    EXPECT_FALSE(refused.ok());
    EXPECT_NE(why.find("not ready (fault)"), std::string::npos) << why;
}

} // namespace
} // namespace hg::daemon

namespace hg::daemon {
namespace {

namespace fs = std::filesystem;

// Regions per view (docs/daemon.md, "Regions per view") on the simulated line
// (config/sim): the daemon's engine inspector, and a camera that cuts each
// grab from the simulated camera's rendering at the pose commanded, of a part
// seated 0.2 mm / 0.2° off (so the views after the first two are taken at
// poses corrected for the seat).
class CameraRegions : public ::testing::Test {
  protected:
    struct Run {
        std::vector<std::string> calls;           ///< the camera's calls, in order
        std::vector<geometry::FixturePose> poses; ///< the poses commanded
        std::vector<nlohmann::json> records;      ///< one per part
    };

    static fs::path simFolder() { return hgtest::sourceDir() / "config" / "sim"; }

    static geometry::RigidTransform seat()
    {
        const auto turn = geometry::RigidTransform::rotation(geometry::Vec3(1, -2, 3).normalized(), 0.2);
        const geometry::Vec3 centre(0, 0, 15);
        return {turn.R, centre + geometry::Vec3(0.2, -0.1, 0.0) - turn.R * centre};
    }

    /// One cycle per part through the runner; `regions` the station's camera.regions.
    static Run run(const std::vector<std::string>& parts, bool regions, bool refuse)
    {
        hgtest::TempDir dir;
        auto cfg = std::make_shared<station::DaemonConfig>(station::loadDaemonConfig(simFolder() / "hullgauged.yaml"));
        cfg->results.database = dir / "results.db";
        cfg->results.imageDir = dir / "images";
        cfg->results.saveFailedImages = false;
        cfg->cameraRegions = regions;
        const ConfigNode driver = (*cfg->station.document)["camera"]["driver"];
        sim::RenderOptions options;
        options.backgroundLevel = driver["background_level"].asDouble();
        options.objectLevel = driver["object_level"].asDouble();
        options.blurSigmaPx = driver["blur_sigma_px"].asDouble();
        options.noiseSigma = driver["noise_sigma"].asDouble();
        options.seed = 7;
        std::map<std::string, fs::path> meshes(cfg->simulatedParts.begin(), cfg->simulatedParts.end());
        std::unique_ptr<sim::SilhouetteRenderer> renderer;

        ManualClock clock;
        ScriptedDevices devices(clock);
        devices.refuseRegions = refuse;
        devices.regionChangeMs = 1.5;
        devices.render = [&](const geometry::FixturePose& pose) {
            return renderer->render(align::seatedCamera(cfg->station.cameraAt(pose), seat()), options);
        };
        auto inspector = makeEngineInspector(*cfg);
        store::ResultStore store(dir / "results.db");
        PlcRegisters registers;
        registers.setKnownPrograms({1});
        Run out;
        {
            CycleRunner runner(registers, devices, *inspector, store, cfg, clock);
            runner.start([] {});
            EXPECT_TRUE(eventually([&] { return registers.snapshot()[reg::Status] == 0; }, 60s));
            std::uint16_t seq = 0;
            for (const std::string& part : parts) {
                renderer = std::make_unique<sim::SilhouetteRenderer>(
                    std::vector<model::TriangleMesh>{model::loadMesh(meshes.at(part))});
                std::array<std::uint16_t, 2> block{++seq, 1};
                EXPECT_EQ(registers.write(reg::TriggerSeq, block), station::ModbusException::None);
                EXPECT_TRUE(eventually([&] { return registers.snapshot()[reg::DoneSeq] == seq; }, 120s)) << part;
                out.records.push_back(store.recent(1).at(0));
            }
        }
        out.calls = devices.calls();
        out.poses = devices.poses();
        return out;
    }

    /// The region asked for before each grab, in order (empty: whole frames).
    static std::vector<std::string> regionBeforeEachGrab(const std::vector<std::string>& calls)
    {
        std::vector<std::string> out;
        std::string last = "region [0, 0, 0, 0]";
        for (const std::string& c : calls)
            if (c == "grab")
                out.push_back(last);
            else
                last = c;
        return out;
    }

    /// What a record decides: verdict, landmarks, the seat; not its timings (ms).
    static nlohmann::json judged(nlohmann::json record)
    {
        nlohmann::json alignment = record["alignment"];
        if (alignment.is_object()) {
            alignment.erase("ms");
            if (alignment.contains("pose_correction")) alignment["pose_correction"].erase("ms");
        }
        return {{"verdict", record["verdict"]}, {"landmarks", record["landmarks"]}, {"alignment", alignment}};
    }
};

TEST_F(CameraRegions, TheCameraSendsEachViewsBoundsAndTheVerdictsAreThoseOfWholeFrames)
{
    const std::vector<std::string> parts = {"nominal", "face-low"};
    const Run regions = run(parts, true, false);
    const Run whole = run(parts, false, false);

    // Each grab was preceded by the bounds of what that view's inspection
    // reads through the camera of the pose commanded (the core's own
    // Inspector::regions, built as the program says: docs/inspection.md).
    auto cfg = station::loadDaemonConfig(simFolder() / "hullgauged.yaml");
    const auto program = model::loadPartProgram(cfg.programs.at(1).partFile);
    const auto options = inspect::inspectionOptions(program.inspection);
    const auto map = inspect::buildInspectionMap(program, options);
    const inspect::Inspector core(map, options, inspect::makeAligner(program),
                                  inspect::makeDeviationGauge(program, cfg.station.calibration));
    std::vector<std::string> expected;
    for (const auto& pose : regions.poses)
        expected.push_back("region " + ScriptedDevices::describe(core.regions(cfg.station.cameraAt(pose)).bounds));
    ASSERT_EQ(regions.poses.size(), 2 * cfg.programs.at(1).views.size());
    EXPECT_EQ(regionBeforeEachGrab(regions.calls), expected);
    bool corrected = false;
    for (std::size_t k = 0; k < regions.poses.size(); ++k)
        corrected = corrected || !(regions.poses[k] == cfg.programs.at(1).views[k % cfg.programs.at(1).views.size()]);
    EXPECT_TRUE(corrected) << "views after the first two are taken at poses corrected for the seat";
    // With camera.regions false the camera is asked for whole frames.
    for (const std::string& r : regionBeforeEachGrab(whole.calls)) EXPECT_EQ(r, "region [0, 0, 0, 0]");

    // The same verdicts, landmarks and seats, to the last bit, as the whole frames give.
    ASSERT_EQ(regions.records.size(), parts.size());
    ASSERT_EQ(whole.records.size(), parts.size());
    for (std::size_t i = 0; i < parts.size(); ++i) {
        SCOPED_TRACE(parts[i]);
        EXPECT_EQ(judged(regions.records[i]), judged(whole.records[i]));
        EXPECT_EQ(regions.records[i]["verdict"], parts[i] == "nominal" ? "pass" : "fail");
        // The camera's time applying the regions is in the cycle's timing (1.5 ms per change).
        EXPECT_GT(regions.records[i]["timing"]["region"].get<double>(), 0.0);
        EXPECT_EQ(whole.records[i]["timing"]["region"].get<double>(), 0.0);
    }
}

// docs/camera.md, "A camera that cannot": it sends whole frames; the
// inspection, told so by each frame's origin and size, judges the same.
/// The daemon's cycle runner and engine inspector on a copy of the simulated
/// line (config/sim), its nominal part rendered at the poses commanded. The
/// configuration is loaded as the daemon loads it at start and at every
/// reload (daemon.cpp, loadConfig): every part program checked in full.
class SimulatedLine {
  public:
    SimulatedLine()
    {
        fs::copy(hgtest::sourceDir() / "config" / "sim", folder(), fs::copy_options::recursive);
        std::ifstream in(programFile());
        draft_.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
        if (!draft_.empty() && draft_.back() != '\n') draft_ += '\n';
    }
    ~SimulatedLine() { runner_.reset(); }

    fs::path folder() const { return dir_.path() / "sim"; }
    fs::path daemonFile() const { return folder() / "hullgauged.yaml"; }
    fs::path programFile() const { return folder() / "stepped-block.yaml"; }
    /// The simulated line's program as config/sim has it (a draft), ending in a newline.
    const std::string& draft() const { return draft_; }
    /// `program` with the record of docs/commissioning.md, "Release".
    static std::string released(const std::string& program, int version, const std::string& digest)
    {
        return program + "release:\n  version: " + std::to_string(version) + "\n  verification_sha256: " + digest +
               "\n  released_by: jdoe\n  released_at: 2026-12-06T13:05:12+01:00\n";
    }

    /// Loads the configuration and starts the runner; false when it does not become ready.
    bool start()
    {
        config_ = loadConfig();
        station_ = config_->station;
        const ConfigNode driver = (*station_.document)["camera"]["driver"];
        options_.backgroundLevel = driver["background_level"].asDouble();
        options_.objectLevel = driver["object_level"].asDouble();
        options_.blurSigmaPx = driver["blur_sigma_px"].asDouble();
        options_.noiseSigma = driver["noise_sigma"].asDouble();
        options_.seed = 7;
        const std::map<std::string, fs::path> meshes(config_->simulatedParts.begin(), config_->simulatedParts.end());
        renderer_ = std::make_unique<sim::SilhouetteRenderer>(
            std::vector<model::TriangleMesh>{model::loadMesh(meshes.at("nominal"))});
        devices_.render = [this](const geometry::FixturePose& pose) {
            // The empty nest shows the bare backlight (`sim-part none`).
            return (nest_.empty ? backlight_ : *renderer_).render(station_.cameraAt(pose), options_);
        };
        inspector_ = makeEngineInspector(*config_);
        store_ = std::make_unique<store::ResultStore>(dir_ / "results.db");
        registers_->setKnownPrograms({1});
        runner_ = std::make_unique<CycleRunner>(*registers_, devices_, *inspector_, *store_, config_, clock_);
        runner_->setSimulation(&nest_);
        runner_->start([] {});
        return eventually([&] { return registers_->snapshot()[reg::Status] == 0; }, 60s);
    }
    /// The daemon stopped and started again on the same files: a new runner, inspection,
    /// PLC registers and store connection; the clock and the devices go on.
    bool restart()
    {
        runner_.reset();
        store_.reset();
        registers_ = std::make_unique<PlcRegisters>();
        return start();
    }
    /// A PLC trigger of program 1; the row it stored.
    nlohmann::json cycle()
    {
        std::array<std::uint16_t, 2> block{++seq_, 1};
        EXPECT_EQ(registers_->write(reg::TriggerSeq, block), station::ModbusException::None);
        EXPECT_TRUE(eventually([&] { return registers_->snapshot()[reg::DoneSeq] == seq_; }, 120s)) << seq_;
        return store_->recent(1).at(0);
    }
    /// SIGHUP as the main loop takes it (daemon.cpp, MainLoop::reload): a configuration
    /// that does not validate is refused (false) and the running one stays.
    bool reload()
    {
        try {
            runner_->setConfig(loadConfig());
            registers_->setKnownPrograms({1});
            return true;
        } catch (const InputError&) {
            return false;
        }
    }
    /// The simulated line's nest: the nominal part or, when it can (`canEmpty`), nothing (`sim-part none`).
    class Nest : public SimulationControl {
      public:
        std::vector<std::string> parts() const override
        {
            return canEmpty ? std::vector<std::string>{"nominal", "none"} : std::vector<std::string>{"nominal"};
        }
        std::string part() const override { return empty ? "none" : "nominal"; }
        bool selectPart(const std::string& name) override
        {
            if (name != "nominal" && !(name == "none" && canEmpty)) return false;
            empty = name == "none";
            return true;
        }
        std::atomic<bool> canEmpty{true};
        std::atomic<bool> empty{false};
    };

    CycleRunner& runner() { return *runner_; }
    Nest& nest() { return nest_; }
    const sim::RenderOptions& renderOptions() const { return options_; }
    store::ResultStore& store() { return *store_; }
    PlcRegisters& registers() { return *registers_; }
    ManualClock& clock() { return clock_; }
    /// The lamp patterns the runner commanded, in order.
    std::vector<LampPattern> lamps() const { return devices_.lamps(); }
    /// The TRIGGER_SEQ the next trigger writes.
    std::uint16_t nextSeq() { return ++seq_; }

  private:
    std::shared_ptr<const station::DaemonConfig> loadConfig() const
    {
        auto cfg = std::make_shared<station::DaemonConfig>(station::loadDaemonConfig(daemonFile()));
        for (const auto& [number, ref] : cfg->programs) checkEngineProgram(ref, cfg->station);
        cfg->results.saveFailedImages = false;
        return cfg;
    }

    hgtest::TempDir dir_;
    std::string draft_;
    std::shared_ptr<const station::DaemonConfig> config_;
    geometry::Station station_;
    sim::RenderOptions options_;
    std::unique_ptr<sim::SilhouetteRenderer> renderer_;
    const sim::SilhouetteRenderer backlight_{}; ///< nothing in front of the backlight
    Nest nest_;
    ManualClock clock_;
    ScriptedDevices devices_{clock_};
    std::unique_ptr<Inspector> inspector_;
    std::unique_ptr<store::ResultStore> store_;
    std::unique_ptr<PlcRegisters> registers_ = std::make_unique<PlcRegisters>();
    std::uint16_t seq_ = 0;
    std::unique_ptr<CycleRunner> runner_;
};

// A new version of a part program goes in by a reload (docs/daemon.md,
// "Configuration reference"): `hullgauge commission` writes the new release
// over the old file, the reload validates the configuration as the daemon's
// does (every part program loaded in full) and the next result names the new
// version; a reload that refuses the new file leaves the version loaded
// before serving.
TEST(ProgramReload, TheNextResultNamesTheNewVersionAndARefusedFileLeavesThePreviousServing)
{
    SimulatedLine line;
    const auto released = [&](int version, const std::string& digest) {
        return SimulatedLine::released(line.draft(), version, digest);
    };
    const std::string v1(64, '1');
    const std::string v2(64, '2');
    ASSERT_TRUE(line.start());
    CycleRunner& runner = line.runner();
    const fs::path programFile = line.programFile();
    const auto cycle = [&] { return line.cycle(); };
    const auto reload = [&] { return line.reload(); };

    // The simulated line's program is a draft: its result names no release.
    auto record = cycle();
    EXPECT_EQ(record["verdict"], "pass");
    EXPECT_TRUE(record["program_version"].is_null());
    EXPECT_TRUE(record["program_sha256"].is_null());
    EXPECT_TRUE(runner.program()["version"].is_null());

    // Released as version 1 over the same file: the reload loads it anew.
    hgtest::writeFile(programFile, released(1, v1));
    ASSERT_TRUE(reload());
    record = cycle();
    EXPECT_EQ(record["verdict"], "pass");
    EXPECT_EQ(record["program_version"], 1);
    EXPECT_EQ(record["program_sha256"], v1);
    EXPECT_EQ(runner.program()["version"], 1);

    // Version 2 written over it with its digest cut short: refused, version 1 serves on.
    hgtest::writeFile(programFile, released(2, std::string(63, '2')));
    EXPECT_FALSE(reload());
    record = cycle();
    EXPECT_EQ(record["verdict"], "pass");
    EXPECT_EQ(record["program_version"], 1);
    EXPECT_EQ(record["program_sha256"], v1);

    // Version 2 as released: the reload takes it, the next result names it.
    hgtest::writeFile(programFile, released(2, v2));
    ASSERT_TRUE(reload());
    record = cycle();
    EXPECT_EQ(record["verdict"], "pass");
    EXPECT_EQ(record["program_version"], 2);
    EXPECT_EQ(record["program_sha256"], v2);
    EXPECT_EQ(runner.program()["version"], 2);
    EXPECT_EQ(runner.program()["verification_sha256"], v2);
    EXPECT_EQ(line.store().count(), 4);
}

// The correction set in force (docs/mastering.md, "In the daemon"): the
// daemon applies `<mastering.folder>/program-1.json` to every production
// result of the release it was mastered on, and the stored row keeps the raw
// deviation, the corrected one and the set's id. The set is written by hand:
// one master certified at +0.010 mm (U 0.002 mm) read at −0.010 mm (s 0.002 mm
// over 4 cycles) on two landmarks, so the offset is +0.020 mm and
// U_corr = 2·sqrt(0.001² + (0.002/√4)²) = 0.0028284 mm. A new release outdates
// it (uncorrected results, no id); a set mastered on the new release, read by
// the next reload, applies again.
TEST(Mastering, AProductionResultIsStoredWithItsRawAndCorrectedDeviationAndTheCorrectionId)
{
    SimulatedLine line;
    const std::string program = line.draft() + "inspection: {deviation: true}\n";
    hgtest::writeFile(line.programFile(), SimulatedLine::released(program, 1, std::string(64, '1')));
    std::ofstream(line.daemonFile(), std::ios::app) << "mastering: {folder: masters}\n";
    fs::create_directories(line.folder() / "masters");
    const auto writeSet = [&](int version, const std::string& id) {
        nlohmann::json point = {{"master", "MASTER-1"},  {"certified_mm", 0.010}, {"certified_uncertainty_mm", 0.002},
                                {"measured_mm", -0.010}, {"spread_mm", 0.002},    {"cycles", 4}};
        nlohmann::json set = {{"id", id},
                              {"program", 1},
                              {"program_version", version},
                              {"material", ""},
                              {"created_unix_ms", 1000},
                              {"landmarks", nlohmann::json::array()}};
        for (const char* landmark : {"step-top", "tall-top"})
            set["landmarks"].push_back({{"id", landmark}, {"points", {point}}});
        hgtest::writeFile(line.folder() / "masters" / "program-1.json", set.dump());
    };
    writeSet(1, "p1-v1-20261207T080000Z");
    ASSERT_TRUE(line.start());

    const double correctionU = 2.0 * std::sqrt(0.001 * 0.001 + 0.001 * 0.001);
    // Every corrected landmark: corrected = raw + 0.020 mm, U' = sqrt(U² + U_corr²); the others as measured.
    const auto expectCorrected = [&](const nlohmann::json& record, const std::string& id) {
        EXPECT_EQ(record["purpose"], "production");
        EXPECT_EQ(record["correction_id"], id);
        int corrected = 0;
        for (const auto& l : record["landmarks"]) {
            SCOPED_TRACE(l.dump());
            const std::string landmark = l["id"];
            if (landmark != "step-top" && landmark != "tall-top") {
                EXPECT_FALSE(l.contains("raw_deviation_mm"));
                continue;
            }
            ASSERT_TRUE(l.contains("raw_deviation_mm"));
            ++corrected;
            const double raw = l["raw_deviation_mm"], rawU = l["raw_uncertainty_mm"];
            EXPECT_NEAR(l["deviation_mm"].get<double>(), raw + 0.020, 1e-12);
            EXPECT_NEAR(l["uncertainty_mm"].get<double>(), std::hypot(rawU, correctionU), 1e-12);
            EXPECT_EQ(l["correction"]["id"], id);
            EXPECT_NEAR(l["correction"]["offset_mm"].get<double>(), 0.020, 1e-12);
            EXPECT_NEAR(l["correction"]["uncertainty_mm"].get<double>(), correctionU, 1e-12);
            // The nominal part: its raw reading is near zero (the simulated line's own bias is small).
            EXPECT_NEAR(raw, 0.0, std::max(rawU, 0.02));
        }
        EXPECT_EQ(corrected, 2);
    };
    expectCorrected(line.cycle(), "p1-v1-20261207T080000Z");

    // Released as version 2: the set mastered on version 1 is not applied.
    hgtest::writeFile(line.programFile(), SimulatedLine::released(program, 2, std::string(64, '2')));
    ASSERT_TRUE(line.reload());
    const nlohmann::json record = line.cycle();
    EXPECT_EQ(record["program_version"], 2);
    EXPECT_TRUE(record["correction_id"].is_null());
    for (const auto& l : record["landmarks"]) EXPECT_FALSE(l.contains("raw_deviation_mm")) << l.dump();

    // The master measured on version 2: the next reload applies its set.
    writeSet(2, "p1-v2-20261207T090000Z");
    ASSERT_TRUE(line.reload());
    expectCorrected(line.cycle(), "p1-v2-20261207T090000Z");
    EXPECT_EQ(line.store().count(), 3);
}

// A correction set file that is not one, or is another program's, is refused
// with the configuration, naming the file and the field.
TEST(Mastering, ACorrectionSetOfAnotherProgramOrMalformedIsRefusedNamingTheFileAndField)
{
    SimulatedLine line;
    const fs::path daemonFile = line.daemonFile();
    std::ofstream(daemonFile, std::ios::app) << "mastering: {folder: masters}\n";
    const auto refusal = [&] {
        try {
            station::loadDaemonConfig(daemonFile);
        } catch (const InputError& e) {
            return std::string(e.what());
        }
        return std::string("accepted");
    };
    EXPECT_NE(refusal().find("mastering.folder"), std::string::npos) << refusal();
    fs::create_directories(line.folder() / "masters");
    const fs::path setFile = line.folder() / "masters" / "program-1.json";
    hgtest::writeFile(setFile, R"({"id": "p2-draft-x", "program": 2, "program_version": null, "material": "",
                                   "created_unix_ms": 0, "landmarks": []})");
    std::string error = refusal();
    EXPECT_NE(error.find(setFile.string()), std::string::npos) << error;
    EXPECT_NE(error.find("the correction set of program 2"), std::string::npos) << error;
    hgtest::writeFile(setFile, R"({"id": "p1-draft-x", "program": 1, "program_version": null, "material": "",
                                   "created_unix_ms": 0, "landmarks": [{"id": "step-top", "points": []}]})");
    error = refusal();
    EXPECT_NE(error.find("landmarks[0].points"), std::string::npos) << error;
    EXPECT_NE(error.find(setFile.string()), std::string::npos) << error;
}

// Re-mastering due in the daemon (docs/mastering.md, "Re-mastering due"):
// program 1, released as version 1, with a set mastered on it at the clock's
// wall time; `mastering.due` gives 8 h and a grace of 2 production cycles.
// 8 h less 1 ms after the set: not due; at 8 h MASTER_DUE reads 1 with a grace of 2;
// two production parts later it reads 2 and a production trigger is refused
// with LAST_REJECT_REASON 4 (nothing acknowledged); a master cycle is
// accepted and judged; a new set read by a reload clears it and production
// is accepted again.
TEST(MasteringDue, PastItsAgeSignalledThenProductionRefusedPastTheGraceMasterAcceptedNewSetClears)
{
    SimulatedLine line;
    hgtest::writeFile(line.programFile(), SimulatedLine::released(line.draft(), 1, std::string(64, '1')));
    std::ofstream(line.daemonFile(), std::ios::app)
        << "mastering: {folder: masters, due: {max_age_h: 8, grace_cycles: 2}}\n";
    fs::create_directories(line.folder() / "masters");
    const auto writeSet = [&](const std::string& id, std::int64_t createdUnixMs) {
        const nlohmann::json set = {{"id", id},
                                    {"program", 1},
                                    {"program_version", 1},
                                    {"material", ""},
                                    {"created_unix_ms", createdUnixMs},
                                    {"landmarks", nlohmann::json::array()}};
        hgtest::writeFile(line.folder() / "masters" / "program-1.json", set.dump());
    };
    const std::int64_t createdUnixMs = line.clock().wallMs();
    writeSet("p1-v1-20260302T080000Z", createdUnixMs);
    ASSERT_TRUE(line.start());
    PlcRegisters& registers = line.registers();
    const auto reg = [&](std::uint16_t address) { return registers.snapshot()[address]; };
    const auto status = [&] { return line.runner().describe()["mastering"]["1"]; };

    EXPECT_EQ(line.cycle()["verdict"], "pass");
    EXPECT_EQ(reg(reg::ActiveProgram), 1);
    EXPECT_EQ(reg(reg::MasterDue), 0);
    EXPECT_EQ(reg(reg::MasterGraceLeft), 2);
    EXPECT_EQ(status()["due"], false);

    // The cycle's moves and settles took the hand-moved time on: to 8 h less 1 ms after the set.
    line.clock().advance(8h - 1ms - std::chrono::milliseconds(line.clock().wallMs() - createdUnixMs));
    EXPECT_EQ(status()["due"], false);
    EXPECT_EQ(reg(reg::MasterDue), 0);

    // At 8 h to the millisecond: due, and the registers say so between cycles without a trigger.
    line.clock().advance(1ms);
    EXPECT_EQ(status()["due"], true);
    ASSERT_TRUE(eventually([&] { return reg(reg::MasterDue) == 1; })) << status().dump();
    EXPECT_EQ(reg(reg::MasterGraceLeft), 2);
    EXPECT_EQ(status()["cause"], "age");
    EXPECT_EQ(status()["production_refused"], false);

    // The grace: two production parts still judged, the second uses it up.
    EXPECT_EQ(line.cycle()["verdict"], "pass");
    EXPECT_EQ(reg(reg::MasterDue), 1);
    EXPECT_EQ(reg(reg::MasterGraceLeft), 1);
    EXPECT_EQ(line.cycle()["verdict"], "pass");
    EXPECT_EQ(reg(reg::MasterDue), 2);
    EXPECT_EQ(reg(reg::MasterGraceLeft), 0);
    EXPECT_EQ(status()["production_refused"], true);

    // A production trigger is refused in the write itself: ACK_SEQ stays, the reason is 4.
    const auto ackBefore = reg(reg::AckSeq);
    const auto rejectedBefore = reg(reg::RejectedTriggers);
    std::array<std::uint16_t, 2> block{line.nextSeq(), 1};
    ASSERT_EQ(registers.write(reg::TriggerSeq, block), station::ModbusException::None);
    EXPECT_EQ(reg(reg::AckSeq), ackBefore);
    EXPECT_EQ(reg(reg::RejectedTriggers), rejectedBefore + 1);
    EXPECT_EQ(reg(reg::LastRejectReason), 4);
    EXPECT_EQ(line.store().count(), 3);

    // A master cycle (CYCLE_PURPOSE 1) is accepted and judged.
    const std::array<std::uint16_t, 1> master{1};
    ASSERT_EQ(registers.write(reg::CyclePurpose, master), station::ModbusException::None);
    const auto masterRecord = line.cycle();
    EXPECT_EQ(masterRecord["purpose"], "master");
    EXPECT_EQ(masterRecord["verdict"], "pass");
    EXPECT_EQ(reg(reg::MasterDue), 2);

    // The new set, read by a reload, clears it: production is accepted again.
    writeSet("p1-v1-20260302T160000Z", line.clock().wallMs());
    ASSERT_TRUE(line.reload());
    EXPECT_EQ(reg(reg::MasterDue), 0);
    EXPECT_EQ(reg(reg::MasterGraceLeft), 2);
    EXPECT_EQ(status()["due"], false);
    const std::array<std::uint16_t, 1> production{0};
    ASSERT_EQ(registers.write(reg::CyclePurpose, production), station::ModbusException::None);
    const auto record = line.cycle();
    EXPECT_EQ(record["purpose"], "production");
    EXPECT_EQ(record["verdict"], "pass");
    EXPECT_EQ(line.store().count(), 5);
}

// `mastering.due` is read strictly (docs/daemon.md): a value out of range or
// an unknown key is refused naming its key path.
TEST(MasteringDue, AKeyOutOfRangeOrUnknownIsRefusedNamingIt)
{
    for (const auto& [due, key] : std::vector<std::pair<std::string, std::string>>{
             {"{max_age_h: 0}", "mastering.due.max_age_h"},
             {"{max_parts: 0}", "mastering.due.max_parts"},
             {"{grace_cycles: -1}", "mastering.due.grace_cycles"},
             {"{on_program_change: maybe}", "mastering.due.on_program_change"},
             {"{grace: 3}", "grace"}}) {
        SimulatedLine line;
        fs::create_directories(line.folder() / "masters");
        std::ofstream(line.daemonFile(), std::ios::app) << "mastering: {folder: masters, due: " << due << "}\n";
        try {
            station::loadDaemonConfig(line.daemonFile());
            ADD_FAILURE() << due << " accepted";
        } catch (const InputError& e) {
            EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
        }
    }
}

// The part's temperature from the PLC (docs/mastering.md, "Temperature";
// PART_TEMPERATURE, docs/plc.md): program 1 released as version 1 in aluminium,
// α = 23e-6 /K about the origin, a set mastered on it at 20.0 °C (no landmark
// corrected) and `temperature: {source: plc, sigma_c: 0.5, mastering_step_c: 2}`.
// Without a write the register holds 0x8000: no temperature, nothing referred.
// 2150 (21.50 °C): the row holds 21.5 and each landmark measured the expansion
// α·(T − 20)·((p − c)·n) taken out, (p − c)·n worked from the stepped block's
// faces (config/sim/make-meshes.py: x ∈ [−30, 30], y ∈ [−20, 20], the tall
// block's top at z = 30, the step's at 15), U_T = 2·α·|(p − c)·n|·0.5; a step
// of 1.5 °C is not due. 2210 (22.10 °C, a step of 2.1): MASTER_DUE reads 1,
// cause `temperature`, the whole grace left.
TEST(MasteringDue, ThePartsTemperatureFromThePlcIsRecordedReferredTo20CAndAStepMakesItDue)
{
    SimulatedLine line;
    const std::string program =
        line.draft() + "material: {name: aluminium, expansion_per_k: 23.0e-6, expansion_centre: [0, 0, 0]}\n";
    hgtest::writeFile(line.programFile(), SimulatedLine::released(program, 1, std::string(64, '1')));
    std::ofstream(line.daemonFile(), std::ios::app)
        << "mastering: {folder: masters, due: {grace_cycles: 2}}\n"
        << "temperature: {source: plc, sigma_c: 0.5, mastering_step_c: 2}\n";
    fs::create_directories(line.folder() / "masters");
    const nlohmann::json set = {{"id", "p1-v1-aluminium-20260302T070000Z"},
                                {"program", 1},
                                {"program_version", 1},
                                {"material", "aluminium"},
                                {"created_unix_ms", line.clock().wallMs()},
                                {"temperature_c", 20.0},
                                {"landmarks", nlohmann::json::array()}};
    hgtest::writeFile(line.folder() / "masters" / "program-1.json", set.dump());
    ASSERT_TRUE(line.start());
    PlcRegisters& registers = line.registers();
    const auto reg = [&](std::uint16_t address) { return registers.snapshot()[address]; };
    const auto status = [&] { return line.runner().describe()["mastering"]["1"]; };
    const auto writeTemperature = [&](std::uint16_t word) {
        const std::array<std::uint16_t, 1> value{word};
        ASSERT_EQ(registers.write(reg::PartTemperature, value), station::ModbusException::None);
    };

    auto record = line.cycle();
    EXPECT_EQ(record["verdict"], "pass");
    EXPECT_TRUE(record["temperature_c"].is_null());
    for (const auto& l : record["landmarks"]) EXPECT_FALSE(l.contains("thermal_mm")) << l.dump();
    EXPECT_EQ(reg(reg::MasterDue), 0);

    // (p − c)·n per landmark: its position on the face it lies on, along that face's outward normal.
    const std::map<std::string, double> along = {
        {"tall-top", 30.0}, {"tall-corner", 30.0}, {"tall-side", 30.0}, {"tall-foot", 30.0}, {"riser", 0.0},
        {"step-top", 15.0}, {"step-side", 30.0},   {"end-front", 20.0}, {"end-back", 20.0},  {"step-top-back", 15.0}};
    const double alpha = 23.0e-6;
    writeTemperature(2150);
    record = line.cycle();
    EXPECT_EQ(record["verdict"], "pass");
    EXPECT_EQ(record["temperature_c"], 21.5);
    EXPECT_EQ(line.runner().describe()["last_cycle"]["temperature_c"], 21.5);
    std::set<std::string> referred;
    for (const auto& l : record["landmarks"]) {
        SCOPED_TRACE(l.dump());
        if (!l.contains("raw_deviation_mm")) continue;
        const std::string id = l["id"];
        referred.insert(id);
        const double d = along.at(id);
        EXPECT_NEAR(l["thermal_mm"].get<double>(), alpha * (21.5 - 20.0) * d, 1e-12);
        EXPECT_NEAR(l["thermal_uncertainty_mm"].get<double>(), 2.0 * alpha * d * 0.5, 1e-12);
        EXPECT_NEAR(l["deviation_mm"].get<double>(),
                    l["raw_deviation_mm"].get<double>() - l["thermal_mm"].get<double>(), 1e-12);
        EXPECT_NEAR(l["uncertainty_mm"].get<double>(),
                    std::hypot(l["raw_uncertainty_mm"].get<double>(), 2.0 * alpha * d * 0.5), 1e-12);
        EXPECT_TRUE(l["correction"].is_null());
    }
    // The nominal part's every landmark is measured on the simulated line, so every one is referred.
    EXPECT_EQ(referred.size(), along.size()) << record["landmarks"].dump();
    EXPECT_EQ(reg(reg::MasterDue), 0);
    EXPECT_EQ(status()["due"], false);

    // 22.10 °C: 2.1 from the set's 20.0, beyond the step of 2.
    writeTemperature(2210);
    record = line.cycle();
    EXPECT_EQ(record["verdict"], "pass");
    EXPECT_EQ(record["temperature_c"], 22.1);
    EXPECT_EQ(reg(reg::MasterDue), 1);
    EXPECT_EQ(reg(reg::MasterGraceLeft), 2);
    EXPECT_EQ(status()["cause"], "temperature");
    EXPECT_EQ(line.store().count(), 3);
}

// `temperature` is read strictly (docs/daemon.md): a bad value, a key of the
// other source, an unknown key, or a mastering step without `mastering.due`
// is refused naming its key path.
TEST(MasteringDue, ATemperatureKeyOutOfRangeOrOutOfPlaceIsRefusedNamingIt)
{
    for (const auto& [temperature, mastering, key] : std::vector<std::tuple<std::string, std::string, std::string>>{
             {"{source: thermocouple}", "", "temperature.source: unknown temperature source 'thermocouple'"},
             {"{sigma_c: 0.5}", "", "missing required key 'source'"},
             {"{source: plc, sigma_c: -1}", "", "temperature.sigma_c"},
             {"{source: plc, scale: 0.001}", "", "temperature.scale: only with source: file"},
             {"{source: file}", "", "missing required key 'file'"},
             {"{source: file, file: nowhere/t}", "", "temperature.file: its folder does not exist"},
             {"{source: file, file: t, max_age_s: 0}", "", "temperature.max_age_s"},
             {"{source: plc, mastering_step_c: 2}", "", "temperature.mastering_step_c: re-mastering due is off"},
             {"{source: plc, mastering_step_c: 0}", "mastering: {folder: masters, due: {}}\n",
              "temperature.mastering_step_c"},
             {"{source: plc, step_c: 2}", "", "temperature.step_c: unknown key"}}) {
        SimulatedLine line;
        fs::create_directories(line.folder() / "masters");
        std::ofstream(line.daemonFile(), std::ios::app) << mastering << "temperature: " << temperature << "\n";
        try {
            station::loadDaemonConfig(line.daemonFile());
            ADD_FAILURE() << temperature << " accepted";
        } catch (const InputError& e) {
            EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
            EXPECT_NE(std::string(e.what()).find("hullgauged.yaml:"), std::string::npos) << e.what();
        }
    }
    // Both sources as they are meant, the step joining the rules of mastering.due.
    SimulatedLine line;
    fs::create_directories(line.folder() / "masters");
    std::ofstream(line.daemonFile(), std::ios::app)
        << "mastering: {folder: masters, due: {max_parts: 100}}\n"
        << "temperature: {source: file, file: sensor/temp1_input, scale: 0.001, sigma_c: 0.2, max_age_s: 30, "
           "mastering_step_c: 1.5}\n";
    fs::create_directories(line.folder() / "sensor");
    const auto cfg = station::loadDaemonConfig(line.daemonFile());
    ASSERT_TRUE(cfg.temperature);
    EXPECT_EQ(cfg.temperature->source, station::TemperatureSource::File);
    EXPECT_EQ(cfg.temperature->file, line.folder() / "sensor" / "temp1_input");
    EXPECT_EQ(cfg.temperature->scale, 0.001);
    EXPECT_EQ(cfg.temperature->sigmaC, 0.2);
    EXPECT_EQ(cfg.temperature->maxAge, std::chrono::milliseconds(30'000));
    EXPECT_EQ(cfg.mastering.due->maxTemperatureStepC, 1.5);
    EXPECT_EQ(cfg.mastering.due->maxParts, 100u);
}

/// The simulated line for re-mastering due in the daemon (docs/mastering.md,
/// "Due in the daemon"): program 1 released as `version`, `mastering.due` as
/// given, and a set mastered on `setVersion` at the clock's wall time (no
/// landmarks: it corrects nothing, its id goes with every result it judged).
class DueLine : public SimulatedLine {
  public:
    DueLine(const std::string& due, int version = 1, int setVersion = 1)
    {
        writeProgram(version);
        std::ofstream(daemonFile(), std::ios::app) << "mastering: {folder: masters, due: " << due << "}\n";
        fs::create_directories(folder() / "masters");
        const nlohmann::json set = {{"id", setId},
                                    {"program", 1},
                                    {"program_version", setVersion},
                                    {"material", ""},
                                    {"created_unix_ms", clock().wallMs()},
                                    {"landmarks", nlohmann::json::array()}};
        hgtest::writeFile(folder() / "masters" / "program-1.json", set.dump());
    }
    void writeProgram(int version)
    {
        hgtest::writeFile(programFile(), released(draft(), version, std::string(64, char('0' + version))));
    }
    /// `sequencer.mastering` of program 1 (`ctl status`).
    nlohmann::json status() { return runner().describe()["mastering"]["1"]; }
    std::uint16_t reg(std::uint16_t address) { return registers().snapshot()[address]; }
    /// A cycle of `purpose` (CYCLE_PURPOSE, latched with the trigger); the purpose is production again after it.
    nlohmann::json cycleOf(station::CyclePurpose purpose)
    {
        const std::array<std::uint16_t, 1> value{static_cast<std::uint16_t>(purpose)};
        EXPECT_EQ(registers().write(reg::CyclePurpose, value), station::ModbusException::None);
        auto record = cycle();
        const std::array<std::uint16_t, 1> production{0};
        EXPECT_EQ(registers().write(reg::CyclePurpose, production), station::ModbusException::None);
        return record;
    }
    /// A production trigger refused in the write itself: LAST_REJECT_REASON 4, ACK_SEQ unchanged, nothing stored.
    void expectProductionRefused()
    {
        const auto ack = reg(reg::AckSeq);
        const auto rows = store().count();
        std::array<std::uint16_t, 2> block{nextSeq(), 1};
        ASSERT_EQ(registers().write(reg::TriggerSeq, block), station::ModbusException::None);
        EXPECT_EQ(reg(reg::LastRejectReason), 4);
        EXPECT_EQ(reg(reg::AckSeq), ack);
        EXPECT_EQ(store().count(), rows);
    }
    /// The lamps come to `pattern` (between cycles the runner looks at least every 200 ms).
    bool lampsShow(LampPattern pattern)
    {
        return eventually([&] { return !lamps().empty() && lamps().back() == pattern; });
    }

    const std::string setId = "p1-v1-20260302T080000Z";
};

// Due by the part count: at exactly the 3rd production part judged with the
// set (master and study cycles between are not parts), MASTER_DUE 1 with the
// grace of 1, the cause `parts`, the verdict lamp with amber beside it; the
// part of the grace leaves MASTER_DUE 2 and its verdict still shown; the next
// production trigger is refused with LAST_REJECT_REASON 4 and the lamps say so.
TEST(MasteringDue, AtTheNthProductionPartSignalledOnThePlcTheStatusAndTheLampsThenRefused)
{
    DueLine line("{max_parts: 3, grace_cycles: 1}");
    ASSERT_TRUE(line.start());
    for (int part = 1; part <= 2; ++part) {
        const auto record = line.cycle();
        EXPECT_EQ(record["verdict"], "pass");
        EXPECT_EQ(record["correction_id"], line.setId);
        EXPECT_EQ(line.reg(reg::MasterDue), 0) << part;
        EXPECT_EQ(line.lamps().back(), LampPattern::Pass) << part;
    }
    EXPECT_EQ(line.cycleOf(station::CyclePurpose::Master)["purpose"], "master");
    EXPECT_EQ(line.cycleOf(station::CyclePurpose::Study)["purpose"], "study");
    EXPECT_EQ(line.reg(reg::MasterDue), 0);
    EXPECT_EQ(line.status()["due"], false);

    EXPECT_EQ(line.cycle()["verdict"], "pass"); // the 3rd production part
    EXPECT_EQ(line.reg(reg::MasterDue), 1);
    EXPECT_EQ(line.reg(reg::MasterGraceLeft), 1);
    EXPECT_EQ(line.status()["cause"], "parts");
    EXPECT_EQ(line.status()["production_refused"], false);
    // Shown with DONE_SEQ: green and amber.
    EXPECT_EQ(line.lamps().back(), LampPattern::PassAttention);

    EXPECT_EQ(line.cycle()["verdict"], "pass"); // the grace
    EXPECT_EQ(line.reg(reg::MasterDue), 2);
    EXPECT_EQ(line.reg(reg::MasterGraceLeft), 0);
    EXPECT_EQ(line.status()["production_refused"], true);
    EXPECT_EQ(line.lamps().back(), LampPattern::PassAttention); // the part's verdict is not hidden
    line.expectProductionRefused();
    EXPECT_TRUE(line.lampsShow(LampPattern::Refused)) << hg::enumName(line.lamps().back());
    // A master cycle is still judged and shows its verdict, amber beside it.
    EXPECT_EQ(line.cycleOf(station::CyclePurpose::Master)["verdict"], "pass");
    EXPECT_EQ(line.lamps().back(), LampPattern::PassAttention);
    EXPECT_EQ(line.reg(reg::MasterDue), 2);
}

// Due by a new calibration: a reload that finds another calibration date in
// the station file (docs/calibration.md) makes it due at once, `calibration_changed`,
// MASTER_DUE 1, the lamps of the part in the nest gaining amber between cycles;
// the old station file back does not clear it.
TEST(MasteringDue, ANewCalibrationDateReadByAReloadMakesItDue)
{
    DueLine line("{grace_cycles: 2}");
    const fs::path stationFile = line.folder() / "station.yaml";
    std::string station;
    {
        std::ifstream in(stationFile);
        station.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    }
    const auto withDate = [&](const std::string& date) {
        std::string text = station;
        const auto camera = text.find("camera:\n");
        EXPECT_NE(camera, std::string::npos);
        text.insert(camera + 8, "  calibration: {date: " + date + "}\n");
        return text;
    };
    hgtest::writeFile(stationFile, withDate("20260301T070000Z"));
    ASSERT_TRUE(line.start());
    EXPECT_EQ(line.cycle()["verdict"], "pass");
    EXPECT_EQ(line.reg(reg::MasterDue), 0);
    EXPECT_EQ(line.lamps().back(), LampPattern::Pass);

    hgtest::writeFile(stationFile, withDate("20260302T093000Z"));
    ASSERT_TRUE(line.reload());
    EXPECT_EQ(line.reg(reg::MasterDue), 1);
    EXPECT_EQ(line.reg(reg::MasterGraceLeft), 2);
    EXPECT_EQ(line.status()["cause"], "calibration_changed");
    EXPECT_TRUE(line.lampsShow(LampPattern::PassAttention)) << hg::enumName(line.lamps().back());

    hgtest::writeFile(stationFile, withDate("20260301T070000Z"));
    ASSERT_TRUE(line.reload());
    EXPECT_EQ(line.reg(reg::MasterDue), 1);
    EXPECT_EQ(line.status()["cause"], "calibration_changed");
    EXPECT_EQ(line.cycle()["verdict"], "pass");
    EXPECT_EQ(line.reg(reg::MasterGraceLeft), 1);
}

// Due by a new release of the program: the reload loads version 2 for the
// active program (the changeover it prepares), the set mastered on version 1
// no longer fits — `program_changed`, MASTER_DUE 1 —; the grace's part is
// judged uncorrected and a production trigger after it refused.
TEST(MasteringDue, ANewReleaseOfTheProgramMakesItDueAndProductionIsRefusedPastTheGrace)
{
    DueLine line("{grace_cycles: 1}");
    ASSERT_TRUE(line.start());
    EXPECT_EQ(line.cycle()["correction_id"], line.setId);
    EXPECT_EQ(line.reg(reg::ActiveProgram), 1);
    EXPECT_EQ(line.reg(reg::MasterDue), 0);

    line.writeProgram(2);
    ASSERT_TRUE(line.reload());
    ASSERT_TRUE(eventually([&] { return line.reg(reg::MasterDue) == 1; }, 60s)) << line.status().dump();
    EXPECT_EQ(line.status()["cause"], "program_changed");
    EXPECT_EQ(line.reg(reg::MasterGraceLeft), 1);
    EXPECT_TRUE(line.lampsShow(LampPattern::PassAttention)) << hg::enumName(line.lamps().back());

    const auto record = line.cycle();
    EXPECT_EQ(record["program_version"], 2);
    EXPECT_TRUE(record["correction_id"].is_null());
    EXPECT_EQ(line.reg(reg::MasterDue), 2);
    line.expectProductionRefused();
    EXPECT_TRUE(line.lampsShow(LampPattern::Refused)) << hg::enumName(line.lamps().back());
}

// The counts are the result store's (docs/mastering.md, "Due in the daemon"):
// 4 production parts of 5 judged, the daemon restarts on the same store; the
// 5th part after the restart makes it due with the whole grace of 2, and two
// more use it up.
TEST(MasteringDue, ARestartContinuesThePartCountAndTheGraceFromTheResultStore)
{
    DueLine line("{max_parts: 5, grace_cycles: 2}");
    ASSERT_TRUE(line.start());
    for (int part = 1; part <= 4; ++part) EXPECT_EQ(line.cycle()["correction_id"], line.setId) << part;
    EXPECT_EQ(line.reg(reg::MasterDue), 0);

    ASSERT_TRUE(line.restart());
    EXPECT_EQ(line.cycle()["verdict"], "pass"); // the 5th
    EXPECT_EQ(line.reg(reg::MasterDue), 1);
    EXPECT_EQ(line.reg(reg::MasterGraceLeft), 2);
    EXPECT_EQ(line.status()["cause"], "parts");
    EXPECT_EQ(line.cycle()["verdict"], "pass");
    EXPECT_EQ(line.reg(reg::MasterGraceLeft), 1);
    EXPECT_EQ(line.cycle()["verdict"], "pass");
    EXPECT_EQ(line.reg(reg::MasterDue), 2);
    line.expectProductionRefused();
    EXPECT_EQ(line.store().count(), 7);

    // Restarted once more while refused: the first production trigger is refused (the
    // program is known from the start, before any load), the lamps saying so; the master runs.
    ASSERT_TRUE(line.restart());
    line.expectProductionRefused();
    EXPECT_EQ(line.reg(reg::MasterDue), 2);
    EXPECT_EQ(line.status()["cause"], "parts");
    EXPECT_TRUE(line.lampsShow(LampPattern::Refused)) << hg::enumName(line.lamps().back());
    EXPECT_EQ(line.cycleOf(station::CyclePurpose::Master)["verdict"], "pass");
    EXPECT_EQ(line.lamps().back(), LampPattern::PassAttention);
}

TEST_F(CameraRegions, ACameraRefusingRegionsSendsWholeFramesWithTheSameVerdicts)
{
    const std::vector<std::string> parts = {"face-low"};
    const Run refused = run(parts, true, true);
    const Run whole = run(parts, false, false);
    EXPECT_NE(regionBeforeEachGrab(refused.calls).front(), "region [0, 0, 0, 0]") << "regions were asked for";
    ASSERT_EQ(refused.records.size(), 1u);
    EXPECT_EQ(judged(refused.records[0]), judged(whole.records[0]));
    EXPECT_EQ(refused.records[0]["verdict"], "fail");
}

/// The flat-field action's end: done or failed (its status).
nlohmann::json flatFieldEnded(SimulatedLine& line)
{
    nlohmann::json status;
    EXPECT_TRUE(eventually(
        [&] {
            status = line.runner().flatField();
            return status.value("state", "") == "done" || status.value("state", "") == "failed";
        },
        60s));
    return status;
}

// docs/health.md, "In the daemon", on the simulated line (config/sim): the
// maintenance action `flat-field` grabs whole frames of the empty nest (the
// simulation shows none while it grabs and puts the part back after), writes
// the reference beside the station file — its levels the backlight the
// simulated camera renders, background_level of full scale, within one grey
// level — and the cycles after it are judged against it: their backlight
// 1.0 of the reference, contrast, noise and edge width those the simulated
// camera renders, within their limits; one health row each.
TEST(StationHealth, TheFlatFieldIsTakenOfTheEmptyNestAndTheNextCyclesAreJudgedAgainstIt)
{
    SimulatedLine line;
    ASSERT_TRUE(line.start());
    const auto before = line.cycle();
    EXPECT_EQ(before["verdict"], "pass");
    // Without a reference the backlight is not measured; the edges are.
    auto rows = store::ResultReader(line.store().file()).health({});
    ASSERT_EQ(rows.size(), 1u);
    EXPECT_TRUE(rows[0]["backlight"].is_null()) << rows[0].dump();
    EXPECT_TRUE(line.runner().health()["reference"].is_null());

    ASSERT_TRUE(line.runner().requestFlatField({4}).ok());
    const auto status = flatFieldEnded(line);
    ASSERT_EQ(status.value("state", ""), "done") << status.dump();
    EXPECT_EQ(line.nest().part(), "nominal") << "the part is back in the nest after the grabs";
    const auto file = line.folder() / "flat-field.json";
    EXPECT_EQ(status["file"], file.string());
    ASSERT_TRUE(fs::exists(file));
    const vision::FlatField reference = calib::readFlatField(file);
    EXPECT_EQ(reference.sensor, cv::Size(1280, 960));
    double darkest = 0, brightest = 0;
    cv::minMaxLoc(reference.level, &darkest, &brightest);
    const double background = line.renderOptions().backgroundLevel * 255.0;
    EXPECT_NEAR(darkest * 255.0, background, 1.0);
    EXPECT_NEAR(brightest * 255.0, background, 1.0);
    EXPECT_EQ(line.runner().health()["reference"]["taken_unix_ms"], reference.takenUnixMs);

    for (int k = 0; k < 3; ++k) EXPECT_EQ(line.cycle()["verdict"], "pass");
    rows = store::ResultReader(line.store().file()).health({});
    ASSERT_EQ(rows.size(), 4u);
    // What the simulated camera renders (config/sim's camera.driver): the contrast is
    // background_level − object_level, the noise noise_sigma grey levels, and the edge a step
    // blurred by σ = blur_sigma_px and integrated over the pixel (variance 1/12 px²), whose
    // 10–90 % width is 2·Φ⁻¹(0.9)·σ_total.
    const auto& render = line.renderOptions();
    const double width = 2.5631031310892007 * std::sqrt(render.blurSigmaPx * render.blurSigmaPx + 1.0 / 12.0);
    const auto warned = [](const nlohmann::json& row, const char* figure) {
        const auto& w = row["warnings"];
        return std::find(w.begin(), w.end(), figure) != w.end();
    };
    for (std::size_t k = 0; k < rows.size(); ++k) {
        SCOPED_TRACE(rows[k].dump());
        if (k > 0) {
            ASSERT_TRUE(rows[k]["backlight"].is_number());
            EXPECT_NEAR(rows[k]["backlight"].get<double>(), 1.0, 0.01);
            EXPECT_TRUE(rows[k]["uniformity"].is_number()) << "measured against the reference";
        }
        for (const char* figure : {"backlight", "focus", "contrast", "noise"}) EXPECT_FALSE(warned(rows[k], figure));
        EXPECT_NEAR(rows[k]["contrast"].get<double>(), render.backgroundLevel - render.objectLevel, 0.01);
        EXPECT_NEAR(rows[k]["noise"].get<double>(), render.noiseSigma / 255.0, 0.15 * render.noiseSigma / 255.0);
        EXPECT_NEAR(rows[k]["edge_width_px"].get<double>(), width, 0.2);
    }
    // HEALTH_WARNINGS: nothing of the backlight, the focus, the contrast or the noise (bits 0, 3, 4, 5).
    EXPECT_EQ(line.registers().snapshot()[reg::HealthWarnings] & 0b111001, 0);
}

// A nest that cannot be emptied (on a station: the operator left the part in):
// the reference is refused with buildFlatField's reason, nothing is written,
// and production goes on as before.
TEST(StationHealth, AFlatFieldOfANestThatIsNotEmptyIsRefusedWithTheReasonAndNothingWritten)
{
    SimulatedLine line;
    ASSERT_TRUE(line.start());
    EXPECT_EQ(line.cycle()["verdict"], "pass");
    line.nest().canEmpty = false;
    ASSERT_TRUE(line.runner().requestFlatField({2}).ok());
    const auto status = flatFieldEnded(line);
    ASSERT_EQ(status.value("state", ""), "failed") << status.dump();
    EXPECT_NE(status.value("error", "").find("the reference was refused"), std::string::npos) << status.dump();
    EXPECT_FALSE(fs::exists(line.folder() / "flat-field.json"));
    EXPECT_TRUE(line.runner().health()["reference"].is_null());
    EXPECT_EQ(line.cycle()["verdict"], "pass");
    // A request out of range is refused at once, naming it.
    const Status refused = line.runner().requestFlatField({65});
    EXPECT_FALSE(refused.ok());
    EXPECT_NE(refused.message().find("frames: 65 is outside 1..64"), std::string::npos) << refused.message();
}

} // namespace
} // namespace hg::daemon
