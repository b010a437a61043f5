// The daemon's mastering run (docs/mastering.md, "The mastering run") against a
// station played here: its triggers store master rows with deviations chosen by
// hand in a real result store, its reload reads the set file the run wrote. The
// set is checked against the arithmetic of docs/mastering.md done by hand; the
// purpose the run found must come back on every end; its refusals name why.
#include "hgtest/paths.h"
#include "hullgauge/common/json.h"
#include "hullgauge/store/result_store.h"
#include "mastering_run.h"

#include <cmath>
#include <deque>
#include <fstream>
#include <gtest/gtest.h>
#include <mutex>

namespace hg::daemon {
namespace {

using namespace std::chrono_literals;

std::string fileText(const std::filesystem::path& file)
{
    std::ifstream in(file, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

constexpr const char* kCertificate = "master: MASTER-1\n"
                                     "certificate: CMM report 2026-0412\n"
                                     "landmarks:\n"
                                     "  tall-top: {value_mm: 0.020, uncertainty_mm: 0.002}\n";

/// The station as the run sees it. `readings`: the tall-top deviation each accepted trigger's row
/// carries; `refuse`: the answer to every trigger; `silent`: triggers are accepted, no row ever comes.
class PlayedStation {
  public:
    explicit PlayedStation(const hgtest::TempDir& dir) : store_(dir / "results.db")
    {
        auto cfg = std::make_shared<station::DaemonConfig>();
        cfg->results.database = dir / "results.db";
        cfg->mastering.folder = dir / "masters";
        std::filesystem::create_directories(cfg->mastering.folder);
        cfg->programs[1].number = 1;
        config_ = cfg;
    }

    template <class F> auto locked(F f)
    {
        std::lock_guard lock(mutex_);
        return f();
    }

    MasteringStation ports()
    {
        return {
            .purpose = [this] { return locked([&] { return purpose_; }); },
            .setPurpose = [this](station::CyclePurpose p) { locked([&] { purposes_.push_back(purpose_ = p); }); },
            .trigger = [this](std::uint16_t program, const std::string& serial) { return trigger(program, serial); },
            .config = [this] { return locked([&] { return config_; }); },
            .material = [](std::uint16_t) { return std::optional<std::string>(""); },
            .reload = [this] { reload(); },
            .audit = [this](store::AuditEntry e) { locked([&] { audit_.push_back(std::move(e)); }); }};
    }

    /// A stored master row of `serial` with a tall-top deviation of `deviation`; its id.
    std::int64_t storeRow(const std::string& serial, double deviation)
    {
        station::InspectionRecord r;
        r.startedUnixMs = 1'776'000'000'000;
        r.manual = true;
        r.serial = serial;
        r.program = 1;
        r.part = "block";
        r.purpose = station::CyclePurpose::Master;
        r.verdict = station::Verdict::Pass;
        station::LandmarkOutcome l;
        l.id = "tall-top";
        l.status = inspect::LandmarkStatus::Ok;
        l.toleranceMm = 0.1;
        l.deviationMm = deviation;
        l.uncertaintyMm = 0.004;
        r.landmarks.push_back(l);
        return store_.commit(r);
    }

    std::deque<double> readings;
    station::RejectReason refuse = station::RejectReason::None;
    bool silent = false;
    station::CyclePurpose purpose_ = station::CyclePurpose::Study;
    std::vector<station::CyclePurpose> purposes_;
    std::vector<store::AuditEntry> audit_;

  private:
    station::RejectReason trigger(std::uint16_t program, const std::string& serial)
    {
        EXPECT_EQ(program, 1);
        EXPECT_EQ(locked([&] { return purpose_; }), station::CyclePurpose::Master);
        if (refuse != station::RejectReason::None || silent) return refuse;
        const double deviation = locked([&] {
            const double d = readings.front();
            readings.pop_front();
            return d;
        });
        storeRow(serial, deviation);
        return station::RejectReason::None;
    }

    // As the daemon's reload: the set in the folder becomes the program's set in force.
    void reload()
    {
        auto cfg = std::make_shared<station::DaemonConfig>(*locked([&] { return config_; }));
        const auto set = parseJson(fileText(cfg->mastering.folder / "program-1.json"), "set");
        cfg->programs[1].correctionId = set["id"].get<std::string>();
        locked([&] { config_ = cfg; });
    }

    std::mutex mutex_;
    store::ResultStore store_;
    std::shared_ptr<const station::DaemonConfig> config_;
};

MasteringRequest request(std::size_t cycles)
{
    MasteringRequest r;
    r.program = 1;
    r.cycles = cycles;
    r.master = study::parseMasterCertificate(kCertificate, "MASTER-1.yaml");
    r.timeout = 30s;
    r.who = "erik";
    r.role = "engineer";
    r.source = "hmi 127.0.0.1";
    return r;
}

/// Polls the run's status (every 10 ms, at most 30 s) until `done` holds; the status then.
template <class Done> nlohmann::json awaitStatus(const MasteringRun& run, Done done)
{
    const auto deadline = std::chrono::steady_clock::now() + 30s;
    auto s = run.status();
    while (!done(s) && std::chrono::steady_clock::now() < deadline) {
        std::this_thread::sleep_for(10ms);
        s = run.status();
    }
    return s;
}

/// The run's status once its thread has ended (its audit entry recorded, the purpose put back).
nlohmann::json awaitEnd(const MasteringRun& run)
{
    return awaitStatus(run, [&run](const nlohmann::json&) { return !run.running(); });
}

TEST(MasteringRun, ComputesTheSetFromExactlyItsCyclesPutsItInForceAndRestoresThePurpose)
{
    hgtest::TempDir dir;
    PlayedStation station(dir);
    // An older master row of the same serial: not one of the run's, so not in the set.
    station.storeRow("MASTER-1", 0.5);
    station.readings = {0.010, 0.012, 0.014};
    MasteringRun run(station.ports());
    ASSERT_TRUE(run.start(request(3)).ok());
    const auto s = awaitEnd(run);
    ASSERT_EQ(s.value("state", std::string()), "done") << s.dump(2);
    // By hand: mean 0.012, s 0.002, offset 0.020 − 0.012 = 0.008;
    // U_corr = 2·sqrt((0.002/2)² + 0.002²/3) = 2·sqrt(1e-6 + 1.3333e-6) = 0.0030551 mm.
    const auto& l = s["set"]["landmarks"].at(0);
    EXPECT_EQ(l["id"], "tall-top");
    EXPECT_NEAR(l["offset_mm"].get<double>(), 0.008, 1e-12);
    EXPECT_NEAR(l["spread_mm"].get<double>(), 0.002, 1e-12);
    EXPECT_NEAR(l["uncertainty_mm"].get<double>(), 2.0 * std::sqrt(1e-6 + 4e-6 / 3.0), 1e-12);
    EXPECT_EQ(l["cycles"], 3);
    EXPECT_EQ(s["results"], nlohmann::json({2, 3, 4}));
    EXPECT_EQ(s["progress"].at(2), "master cycle 3 of 3: pass (result 4)");
    EXPECT_EQ(station.ports().config()->programs.at(1).correctionId, s["set"]["id"].get<std::string>());
    EXPECT_EQ(station.purposes_,
              (std::vector<station::CyclePurpose>{station::CyclePurpose::Master, station::CyclePurpose::Study}));
    ASSERT_EQ(station.audit_.size(), 1u);
    const auto& e = station.audit_[0];
    EXPECT_EQ(e.action, "mastering.set");
    EXPECT_EQ(e.who, "erik");
    EXPECT_EQ(e.outcome, "done");
    EXPECT_EQ(e.before, "");
    EXPECT_EQ(e.after, fileText(dir / "masters" / "program-1.json"));
}

TEST(MasteringRun, ARefusedTriggerEndsTheRunWithThePurposeItFound)
{
    hgtest::TempDir dir;
    PlayedStation station(dir);
    station.refuse = station::RejectReason::UnknownProgram;
    MasteringRun run(station.ports());
    ASSERT_TRUE(run.start(request(3)).ok());
    const auto s = awaitEnd(run);
    EXPECT_EQ(s.value("state", std::string()), "failed");
    EXPECT_EQ(s.value("error", std::string()), "trigger refused: unknown part program");
    EXPECT_EQ(station.purpose_, station::CyclePurpose::Study);
    EXPECT_FALSE(std::filesystem::exists(dir / "masters" / "program-1.json"));
    ASSERT_EQ(station.audit_.size(), 1u);
    EXPECT_EQ(station.audit_[0].outcome, "failed");
    EXPECT_EQ(station.audit_[0].before, station.audit_[0].after);
}

TEST(MasteringRun, ACancelEndsTheWaitAndASecondRunIsRefusedMeanwhile)
{
    hgtest::TempDir dir;
    PlayedStation station(dir);
    station.silent = true;
    MasteringRun run(station.ports());
    ASSERT_TRUE(run.start(request(3)).ok());
    awaitStatus(run, [](const nlohmann::json& s) { return s.value("cycle", 0) == 1; });
    const Status second = run.start(request(3));
    EXPECT_FALSE(second.ok());
    EXPECT_EQ(second.message(), "a mastering run is already running (master cycle 1 of 3 of program 1)");
    EXPECT_TRUE(run.cancel("tester"));
    const auto s = awaitEnd(run);
    EXPECT_EQ(s.value("error", std::string()), "cancelled by tester waiting for the result of master cycle 1 of 3");
    EXPECT_EQ(station.purpose_, station::CyclePurpose::Study);
    EXPECT_FALSE(run.cancel("tester")); // nothing runs any more
}

TEST(MasteringRun, IsRefusedWithoutAMasteringFolderOrForAProgramNotConfigured)
{
    hgtest::TempDir dir;
    PlayedStation station(dir);
    MasteringRun run(station.ports());
    auto other = request(3);
    other.program = 7;
    EXPECT_EQ(run.start(other).message(), "program: 7 is not a configured part program");
    auto ports = station.ports();
    auto bare = std::make_shared<station::DaemonConfig>(*ports.config());
    bare->mastering.folder.clear();
    ports.config = [bare] { return bare; };
    MasteringRun withoutFolder(ports);
    EXPECT_EQ(withoutFolder.start(request(3)).message(),
              "the daemon has no mastering.folder to keep the set in (docs/mastering.md, \"In the daemon\")");
    EXPECT_TRUE(station.purposes_.empty());
}

} // namespace
} // namespace hg::daemon
