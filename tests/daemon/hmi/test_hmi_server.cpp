// The web HMI's server over real HTTP on 127.0.0.1 (cpp-httplib's client and
// raw sockets as peers): the JSON API against a result store written by the
// daemon's own writer, and the security rules of docs/hmi.md ("Security").
// The daemon's main loop is played by a thread that answers the mailbox.
#include "command_mailbox.h"
#include "cycle/image_archive.h"
#include "hgtest/manual_clock.h"
#include "hgtest/password_hash.h"
#include "hgtest/paths.h"
#include "hgtest/station.h"
#include "hmi/fake_loop.h"
#include "hmi/hmi_auth.h"
#include "hmi/hmi_server.h"
#include "hullgauge/station/sequencer.h"
#include "hullgauge/store/result_reader.h"
#include "hullgauge/store/result_store.h"

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <httplib.h>
#include <netinet/in.h>
#include <opencv2/imgcodecs.hpp>
#include <poll.h>
#include <sys/socket.h>
#include <thread>
#include <unistd.h>

namespace hg::daemon {
namespace {

using hgtest::ManualClock;

using nlohmann::json;
using namespace std::chrono_literals;

station::InspectionRecord record(std::uint16_t seq, station::Verdict verdict, const std::string& serial)
{
    station::InspectionRecord r;
    r.startedUnixMs = 1'764'000'000'000 + seq * 1000;
    r.triggerSeq = seq;
    r.serial = serial;
    r.program = 1;
    r.part = "block";
    r.verdict = verdict;
    r.cycleMs = 900 + seq;
    const bool bad = verdict == station::Verdict::Fail;
    using inspect::LandmarkStatus;
    r.landmarks = {{"c1", LandmarkStatus::Ok, 0.0, 0.125, 0.0625, 0.2},
                   {"c2", bad ? LandmarkStatus::OutOfTolerance : LandmarkStatus::Ok, bad ? 0.5 : 0.0,
                    bad ? 0.625 : 0.125, bad ? 0.5625 : 0.0625, 0.2}};
    return r;
}

class HmiServerTest : public ::testing::Test {
  protected:
    void SetUp() override
    {
        auto cfg = std::make_shared<station::DaemonConfig>();
        cfg->results.database = dir / "results.db";
        cfg->results.imageDir = dir / "images";
        cfg->http.enabled = true;
        cfg->http.port = 0;
        cfg->http.assets = hgtest::sourceDir() / "share" / "hmi";
        cfg->http.passwordHash = hgtest::sha512CryptOf("line-7 secret");
        cfg->http.burst = 1000;
        {
            store::ResultStore store(cfg->results.database);
            ImageArchive archive(cfg->results.imageDir, {});
            ViewEvidence v{cv::Mat(12, 16, CV_8UC1, cv::Scalar(200)), {}, {}};
            const auto folder = archive.save(1'764'000'001'000, "A-1", {v, v}, true);
            store.commit(record(1, station::Verdict::Fail, "A-1"), folder.string());
            store.commit(record(2, station::Verdict::Pass, "B,\"2\""));
            store.commit(record(3, station::Verdict::Pass, "A-3"));
            // A row naming a folder outside the archive must never be served from.
            store.commit(record(4, station::Verdict::Fail, "X"), "/etc");
        }
        config = cfg;
    }
    void start(std::function<void(station::DaemonConfig&)> tweak = {}, HmiServer::SnapshotSource snapshots = {})
    {
        auto cfg = std::make_shared<station::DaemonConfig>(*config);
        if (tweak) tweak(*cfg);
        server = std::make_unique<HmiServer>(cfg, mailbox, clock, std::move(snapshots), utcOffset);
        loop = std::make_unique<FakeLoop>(mailbox);
        client = std::make_unique<httplib::Client>("127.0.0.1", server->port());
        client->set_read_timeout(10, 0);
    }
    json getJson(const std::string& path, int expectStatus = 200)
    {
        auto res = client->Get(path.c_str());
        EXPECT_TRUE(res) << path;
        if (!res) return {};
        EXPECT_EQ(res->status, expectStatus) << path << ": " << res->body;
        return json::parse(res->body, nullptr, false);
    }
    /// Signs in; returns the session cookie and the CSRF token.
    std::pair<std::string, std::string> signIn()
    {
        auto res = client->Post("/api/login", R"({"password": "line-7 secret"})", "application/json");
        EXPECT_TRUE(res && res->status == 200) << (res ? res->body : "no answer");
        const auto cookie = res->get_header_value("Set-Cookie");
        EXPECT_NE(cookie.find("HttpOnly"), std::string::npos) << cookie;
        EXPECT_NE(cookie.find("SameSite=Strict"), std::string::npos) << cookie;
        return {cookie.substr(0, cookie.find(';')), json::parse(res->body).at("csrf").get<std::string>()};
    }

    hgtest::TempDir dir;
    std::shared_ptr<const station::DaemonConfig> config;
    ManualClock clock;
    CommandMailbox mailbox;
    /// The station's zone for the shifts: none is the machine's; a test that counts a shift sets one.
    station::UtcOffset utcOffset;
    std::unique_ptr<HmiServer> server;
    std::unique_ptr<FakeLoop> loop;
    std::unique_ptr<httplib::Client> client;
};

TEST_F(HmiServerTest, TheApiAnswersFromTheStoreAndTheMainLoop)
{
    start();
    const auto status = getJson("/api/status");
    EXPECT_EQ(status["sequencer"]["state"], "ready");
    EXPECT_EQ(status["last_result"]["id"], 4);
    EXPECT_FALSE(status.contains("pid")); // nothing of the process for the network
    EXPECT_EQ(status["disk"]["archive_folders"], 1);

    const auto fails = getJson("/api/results?verdict=fail");
    ASSERT_EQ(fails["results"].size(), 2u);
    EXPECT_EQ(fails["results"][0]["serial"], "X");
    EXPECT_EQ(fails["results"][1]["failed_landmarks"], json::array({"c2"}));

    const auto search = getJson("/api/results?serial=A-");
    ASSERT_EQ(search["results"].size(), 2u);
    EXPECT_EQ(search["results"][0]["serial"], "A-3");

    const auto page = getJson("/api/results?limit=2");
    EXPECT_EQ(page["next_before"], 3);
    const auto next = getJson("/api/results?limit=2&before=3");
    EXPECT_EQ(next["results"][0]["id"], 2);
    EXPECT_EQ(next["results"][0]["serial"], "B,\"2\"");

    const auto one = getJson("/api/results/1");
    EXPECT_EQ(one["landmarks"][1]["status"], "out_of_tolerance");
    EXPECT_EQ(one["image_files"], json::array({"view_0.png", "view_1.png"}));
    auto png = client->Get("/api/results/1/images/view_1.png");
    ASSERT_TRUE(png);
    EXPECT_EQ(png->status, 200);
    EXPECT_EQ(png->get_header_value("Content-Type"), "image/png");
    EXPECT_EQ(png->body.substr(1, 3), "PNG");
}

// The reject views' files (docs/hmi.md, "Reject views"): each view's overlay and the plain frame it
// names, from the part's folder only; 404 for a part archived without them.
TEST_F(HmiServerTest, TheOverlayAndPlainFrameOfAViewAreServedFromThePartsFolderOnly)
{
    start();
    const auto overlay = getJson("/api/results/1/views/0.json");
    EXPECT_EQ(overlay["image_size"], json::array({16, 12}));
    EXPECT_EQ(overlay["frame"], "frame_0.png");
    EXPECT_TRUE(overlay["outline"].is_array());
    auto png = client->Get("/api/results/1/images/frame_1.png");
    ASSERT_TRUE(png);
    EXPECT_EQ(png->status, 200);
    EXPECT_EQ(png->get_header_value("Content-Type"), "image/png");
    EXPECT_EQ(png->body.substr(1, 3), "PNG");
    getJson("/api/results/1/views/2.json", 404);
    getJson("/api/results/1/images/frame_2.png", 404);
    getJson("/api/results/4/views/0.json", 404);
    getJson("/api/results/4/images/frame_0.png", 404);
    const std::filesystem::path folder = getJson("/api/results/1")["image_files"].empty()
                                             ? std::filesystem::path()
                                             : *std::filesystem::directory_iterator(dir / "images");
    ASSERT_FALSE(folder.empty());
    // An overlay naming a frame outside its folder is not followed.
    hgtest::writeFile(folder / "view_1.json", R"({"frame": "../../results.db"})");
    getJson("/api/results/1/images/frame_1.png", 404);
    // A part archived before the overlays: no view_<k>.json, the page shows the annotated picture.
    std::filesystem::remove(folder / "view_0.json");
    EXPECT_NE(getJson("/api/results/1/views/0.json", 404)["error"].get<std::string>().find("overlay of view 0"),
              std::string::npos);
}

// The line view's words and counts (docs/hmi.md, "Line view"): the fault with
// its sentence and action from the daemon's one table, the PLC status by its
// name, and the current shift's production cycles counted from the store — in
// a zone one hour east of UTC, whatever the machine's.
TEST_F(HmiServerTest, TheStatusNamesTheFaultAndCountsTheCurrentShift)
{
    const auto at = [](const char* utc) { return store::parseUtc(utc, "test"); };
    {
        store::ResultStore store(config->results.database);
        const auto commit = [&](std::uint16_t seq, station::Verdict verdict, const char* utc,
                                std::function<void(station::InspectionRecord&)> tweak = {}) {
            auto r = record(seq, verdict, "S-" + std::to_string(seq));
            r.startedUnixMs = at(utc);
            if (tweak) tweak(r);
            store.commit(r);
        };
        commit(10, station::Verdict::Pass, "2026-03-02T04:59:59"); // the night before (local 05:59:59)
        commit(11, station::Verdict::Pass, "2026-03-02T05:00:00"); // the early shift's first second
        commit(12, station::Verdict::Fail, "2026-03-02T06:00:00");
        commit(13, station::Verdict::Aborted, "2026-03-02T07:00:00");
        commit(14, station::Verdict::Error, "2026-03-02T07:10:00");
        commit(15, station::Verdict::Pass, "2026-03-02T07:20:00", [](auto& r) { r.manual = true; });
        commit(16, station::Verdict::Fail, "2026-03-02T07:30:00",
               [](auto& r) { r.purpose = station::CyclePurpose::Master; });
    }
    utcOffset = [](std::int64_t) { return std::int64_t{3600}; };
    start([](station::DaemonConfig& c) { c.shifts = {{"early", 6 * 60}, {"late", 14 * 60}, {"night", 22 * 60}}; });
    loop->setStatus({{"ok", true},
                     {"sequencer", {{"state", "fault"}, {"fault_code", 21}, {"fault", "the drive says no"}}},
                     {"plc", {{"status", 3}, {"fault_code", 0}}}});

    // The manual clock reads 2026-03-02T08:00Z: 09:00 local, the early shift since 05:00Z.
    auto status = getJson("/api/status");
    EXPECT_EQ(status["plc"]["status_name"], "fault");
    EXPECT_EQ(status["fault"]["code"], 21);
    EXPECT_EQ(status["fault"]["name"], "fixture-fault");
    EXPECT_EQ(status["fault"]["sentence"], "the drive says no"); // the sequencer's, counting its cycle's retries
    EXPECT_EQ(status["fault"]["action"], std::string(station::faultAction(station::FaultCode::FixtureFault)));
    EXPECT_EQ(status["fault"]["source"], "station");
    const auto& shift = status["shift"];
    EXPECT_EQ(shift["name"], "early");
    EXPECT_EQ(shift["started_utc"], "2026-03-02T05:00:00.000Z");
    EXPECT_EQ(shift["cycles"], 4); // neither the manual nor the master cycle, nor the one before 05:00Z
    EXPECT_EQ(shift["pass"], 1);
    EXPECT_EQ(shift["fail"], 1);
    EXPECT_EQ(shift["aborted"], 1);
    EXPECT_EQ(shift["error"], 1);
    EXPECT_DOUBLE_EQ(shift["yield"].get<double>(), 0.5);

    // The last result's fault code when the station itself is not in fault; 22:30 local is the night shift.
    loop->setStatus({{"ok", true}, {"sequencer", {{"state", "done"}}}, {"plc", {{"status", 2}, {"fault_code", 32}}}});
    clock.advance(std::chrono::hours(13) + std::chrono::minutes(30));
    status = getJson("/api/status");
    EXPECT_EQ(status["plc"]["status_name"], "done");
    EXPECT_EQ(status["fault"]["name"], "part-not-seated");
    EXPECT_EQ(status["fault"]["source"], "last_result");
    EXPECT_EQ(status["fault"]["sentence"], station::describe(station::FaultCode::PartNotSeated, 1));
    EXPECT_EQ(status["shift"]["name"], "night");
    EXPECT_EQ(status["shift"]["started_utc"], "2026-03-02T21:00:00.000Z");
    EXPECT_EQ(status["shift"]["cycles"], 0);
    EXPECT_TRUE(status["shift"]["yield"].is_null());
}

TEST_F(HmiServerTest, SpcChartsThePlcsProductionCyclesOldestFirst)
{
    {
        // Cycles the SPC must leave out: a master part, a maintenance-triggered one, an aborted one.
        store::ResultStore store(config->results.database);
        auto master = record(5, station::Verdict::Fail, "M-5");
        master.purpose = station::CyclePurpose::Master;
        auto manual = record(6, station::Verdict::Fail, "H-6");
        manual.manual = true;
        store.commit(master);
        store.commit(manual);
        store.commit(record(7, station::Verdict::Aborted, "Z-7"));
    }
    start();
    const auto body = getJson("/api/spc?program=1&landmark=c2");
    EXPECT_EQ(body["cycles"], 4);
    EXPECT_EQ(body["landmark_ids"], json::array({"c1", "c2"}));
    ASSERT_EQ(body["landmarks"].size(), 1u);
    const auto& c2 = body["landmarks"][0];
    // The bracket middles of c2 in rows 1..4 (fail, pass, pass, fail), oldest first.
    const std::vector<double> expected{0.5625, 0.0625, 0.0625, 0.5625};
    ASSERT_EQ(c2["points"].size(), expected.size());
    for (std::size_t i = 0; i < expected.size(); ++i) EXPECT_DOUBLE_EQ(c2["points"][i]["value_mm"], expected[i]);
    // Baseline = all 4 values: CL 0.3125, MR̄ = (0.5 + 0 + 0.5) / 3, σ = MR̄ / 1.128.
    const double sigma = (1.0 / 3.0) / 1.128;
    EXPECT_NEAR(c2["i_chart"]["centre_mm"].get<double>(), 0.3125, 1e-12);
    EXPECT_NEAR(c2["i_chart"]["ucl_mm"].get<double>(), 0.3125 + 3 * sigma, 1e-9);
    EXPECT_EQ(c2["baseline"]["used"], 4);
    EXPECT_TRUE(c2["baseline"]["short"].get<bool>());
    EXPECT_EQ(c2["yield"]["within"], 2); // 0.5625 is beyond the ±0.2 zone

    EXPECT_EQ(getJson("/api/spc?program=1")["landmarks"].size(), 2u);
    EXPECT_EQ(getJson("/api/spc?program=2")["landmark_ids"], json::array());
    EXPECT_NE(getJson("/api/spc", 400)["error"].get<std::string>().find("program"), std::string::npos);
    EXPECT_NE(getJson("/api/spc?program=1&landmark=c9", 404)["error"].get<std::string>().find("c9"), std::string::npos);
    EXPECT_NE(getJson("/api/spc?program=1&rules=shewhart", 400)["error"].get<std::string>().find("shewhart"),
              std::string::npos);
}

TEST_F(HmiServerTest, TheParetoCountsFailedLandmarksAndNamesTheFaults)
{
    {
        // Rows 1..4: c2 failed in 1 and 4 (row 4's serial X). Two camera timeouts and an abort by the
        // PLC end cycles 5..7; a master part failing c2 and a maintenance-triggered fault are left out.
        store::ResultStore store(config->results.database);
        for (std::uint16_t seq : {5, 6}) {
            auto faulted = record(seq, station::Verdict::Error, "E");
            faulted.faultCode = station::FaultCode::CameraTimeout;
            store.commit(faulted);
        }
        auto aborted = record(7, station::Verdict::Aborted, "Z");
        aborted.faultCode = station::FaultCode::AbortedByPlc;
        store.commit(aborted);
        auto master = record(8, station::Verdict::Fail, "M");
        master.purpose = station::CyclePurpose::Master;
        store.commit(master);
        auto manual = record(9, station::Verdict::Error, "H");
        manual.manual = true;
        manual.faultCode = station::FaultCode::FixtureTimeout;
        store.commit(manual);
    }
    start();
    const auto p = getJson("/api/pareto?program=1");
    EXPECT_EQ(p["cycles"], 7);
    EXPECT_EQ(p["failed_cycles"], 2);
    EXPECT_EQ(p["faulted_cycles"], 3);
    ASSERT_EQ(p["landmarks"].size(), 1u);
    EXPECT_EQ(p["landmarks"][0]["id"], "c2");
    EXPECT_EQ(p["landmarks"][0]["count"], 2);
    EXPECT_EQ(p["landmarks"][0]["by_status"]["out_of_tolerance"], 2);
    ASSERT_EQ(p["faults"].size(), 2u);
    EXPECT_EQ(p["faults"][0]["code"], 10);
    EXPECT_EQ(p["faults"][0]["count"], 2);
    EXPECT_EQ(p["faults"][0]["name"], "camera-timeout");
    EXPECT_EQ(p["faults"][0]["sentence"], station::describe(station::FaultCode::CameraTimeout));
    EXPECT_NEAR(p["faults"][0]["cumulative_share"].get<double>(), 2.0 / 3.0, 1e-12);
    EXPECT_EQ(p["faults"][1]["code"], 40);
    EXPECT_EQ(p["faults"][1]["name"], "aborted-by-plc");
    // The period: rows start at 1 764 000 000 000 + seq s; from seq 4 on (2025-11-24T16:00:04Z).
    const auto late = getJson("/api/pareto?program=1&since=2025-11-24T16:00:04");
    EXPECT_EQ(late["cycles"], 4);
    EXPECT_EQ(late["since"], "2025-11-24T16:00:04.000Z");
    EXPECT_EQ(getJson("/api/pareto?program=2")["cycles"], 0);
    EXPECT_EQ(getJson("/api/pareto")["program"], nullptr);
    EXPECT_NE(getJson("/api/pareto?since=yesterday", 400)["error"].get<std::string>().find("since"), std::string::npos);
    EXPECT_NE(getJson("/api/pareto?program=0", 400)["error"].get<std::string>().find("program"), std::string::npos);
}

TEST_F(HmiServerTest, TheResultsPageDownloadsItsSelection)
{
    start();
    auto csv = client->Get("/api/export?format=csv&verdict=pass");
    ASSERT_TRUE(csv);
    EXPECT_EQ(csv->status, 200) << csv->body;
    EXPECT_EQ(csv->get_header_value("Content-Type").rfind("text/csv", 0), 0u);
    EXPECT_EQ(csv->get_header_value("Content-Disposition"), "attachment; filename=\"hullgauge-results.csv\"");
    // RFC 4180: a header and one CRLF-ended row per landmark of the two passed cycles; the serial
    // with a comma and quotes quoted, its quotes doubled.
    std::size_t lines = 0;
    for (std::size_t at = csv->body.find("\r\n"); at != std::string::npos; at = csv->body.find("\r\n", at + 2)) ++lines;
    EXPECT_EQ(lines, 1u + 2u * 2u) << csv->body;
    EXPECT_NE(csv->body.find("\"B,\"\"2\"\"\""), std::string::npos) << csv->body;
    EXPECT_EQ(csv->body.find("A-1"), std::string::npos) << "a failed cycle in a selection of passes";

    auto dfq = client->Get("/api/export?format=aqdef&program=1");
    ASSERT_TRUE(dfq);
    EXPECT_EQ(dfq->status, 200) << dfq->body;
    EXPECT_EQ(dfq->get_header_value("Content-Disposition"), "attachment; filename=\"hullgauge-results.dfq\"");
    EXPECT_EQ(dfq->body.rfind("K0100 2", 0), 0u) << dfq->body.substr(0, 80);

    // A cycle of the simulated line: excluded (K0002 129) unless the download includes it, then said so.
    {
        store::ResultStore store(config->results.database);
        auto simulated = record(5, station::Verdict::Pass, "SIM-5");
        simulated.simulation = {{"part", "nominal"}};
        store.commit(simulated);
    }
    auto kept = client->Get("/api/export?format=aqdef&serial=SIM-5");
    auto tried = client->Get("/api/export?format=aqdef&serial=SIM-5&include_simulated=true");
    ASSERT_TRUE(kept && tried);
    EXPECT_NE(kept->body.find("K0002/1 129"), std::string::npos) << kept->body;
    EXPECT_EQ(kept->body.find("simulated, included"), std::string::npos) << kept->body;
    EXPECT_EQ(tried->body.find("K0002/1 129"), std::string::npos) << tried->body;
    EXPECT_NE(tried->body.find("simulated, included"), std::string::npos) << tried->body;
    EXPECT_NE(getJson("/api/export?format=csv&include_simulated=yes", 400)["error"].get<std::string>().find(
                  "include_simulated"),
              std::string::npos);

    EXPECT_NE(getJson("/api/export?format=xml", 400)["error"].get<std::string>().find("xml"), std::string::npos);
    EXPECT_NE(getJson("/api/export?format=csv&since=yesterday", 400)["error"].get<std::string>().find("since"),
              std::string::npos);
}

TEST_F(HmiServerTest, BadRequestsAreAnsweredWith4xxNamingTheProblem)
{
    start();
    EXPECT_NE(getJson("/api/results?program=abc", 400)["error"].get<std::string>().find("program"), std::string::npos);
    EXPECT_NE(getJson("/api/results?since=2026-02-30", 400)["error"].get<std::string>().find("since"),
              std::string::npos);
    EXPECT_NE(getJson("/api/results?verdict=maybe", 400)["error"].get<std::string>().find("verdict"),
              std::string::npos);
    getJson("/api/results?limit=100000", 400);
    // A parameter that is not UTF-8 is named in the answer, its bad byte replaced (U+FFFD).
    EXPECT_NE(getJson("/api/results?verdict=%F8", 400)["error"].get<std::string>().find("\xEF\xBF\xBD"),
              std::string::npos);
    getJson("/api/results/99", 404);
    getJson("/api/results/1/images/view_9.png", 404);
    // The row whose folder lies outside the archive has no images to serve.
    EXPECT_TRUE(getJson("/api/results/4")["image_files"].empty());
    getJson("/api/results/4/images/view_1.png", 404);
    auto traversal = client->Get("/assets/..%2f..%2fetc%2fpasswd");
    ASSERT_TRUE(traversal);
    EXPECT_EQ(traversal->status, 404);
    auto del = client->Delete("/api/results/1");
    ASSERT_TRUE(del);
    EXPECT_EQ(del->status, 405);
    auto longUri = client->Get(("/api/results?serial=" + std::string(10000, 'a')).c_str());
    ASSERT_TRUE(longUri);
    EXPECT_EQ(longUri->status, 414);
}

/// Sends `raw` on a fresh connection and returns the status line of the answer.
std::string rawRequest(int port, const std::string& raw)
{
    const int fd = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(static_cast<std::uint16_t>(port));
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    timeval timeout{10, 0};
    setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
    if (connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
        close(fd);
        return "no connection";
    }
    [[maybe_unused]] auto sent = send(fd, raw.data(), raw.size(), MSG_NOSIGNAL);
    char buf[256] = {};
    const auto n = recv(fd, buf, sizeof buf - 1, 0);
    close(fd);
    const std::string answer(buf, n > 0 ? static_cast<std::size_t>(n) : 0);
    return answer.substr(0, answer.find("\r\n"));
}

TEST_F(HmiServerTest, MalformedAndOversizedRequestsAreRefusedAndTheServerServesOn)
{
    start([](station::DaemonConfig& c) { c.http.maxRequestBytes = 4096; });
    EXPECT_EQ(rawRequest(server->port(), "GARBAGE\r\n\r\n").substr(0, 12), "HTTP/1.1 400");
    EXPECT_EQ(
        rawRequest(server->port(), "GET /api/status HTTP/1.1\r\nHost: x\r\n" + std::string(9000, 'h') + "\r\n\r\n")
            .substr(0, 9),
        "HTTP/1.1 ");
    auto big = client->Post("/api/login", std::string(8192, '{'), "application/json");
    ASSERT_TRUE(big);
    EXPECT_EQ(big->status, 413);
    EXPECT_EQ(getJson("/api/status")["sequencer"]["state"], "ready");
}

// What the HTTP library once let through (docs/hmi.md, "Bounded"): a chunked
// body past the limit was read whole (400, not 413), 200 000 headers were
// answered 200, and a request naming another host with a matching Origin
// signed in (DNS rebinding). The gate answers each before the library sees it.
TEST_F(HmiServerTest, TheGateRefusesWhatTheLibraryOnceLetThrough)
{
    start([](station::DaemonConfig& c) { c.http.maxRequestBytes = 4096; });
    const int port = server->port();
    EXPECT_EQ(rawRequest(port, "POST /api/login HTTP/1.1\r\nHost: 127.0.0.1\r\nTransfer-Encoding: chunked\r\n\r\n"
                               "2000\r\n" +
                                   std::string(0x2000, '{') + "\r\n0\r\n\r\n"),
              "HTTP/1.1 413 Content Too Large");
    std::string headers;
    for (int i = 0; i < 2000; ++i) headers += "X-" + std::to_string(i) + ": a\r\n";
    EXPECT_EQ(rawRequest(port, "GET /api/status HTTP/1.1\r\nHost: 127.0.0.1\r\n" + headers + "\r\n"),
              "HTTP/1.1 431 Request Header Fields Too Large");
    const std::string login = R"({"password": "line-7 secret"})";
    EXPECT_EQ(rawRequest(port, "POST /api/login HTTP/1.1\r\nHost: a.example\r\nOrigin: http://a.example\r\n"
                               "Content-Type: application/json\r\nContent-Length: " +
                                   std::to_string(login.size()) + "\r\n\r\n" + login),
              "HTTP/1.1 421 Misdirected Request");
    EXPECT_EQ(rawRequest(port, "POST /api/login HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Length: -1\r\n\r\n"),
              "HTTP/1.1 400 Bad Request");
    EXPECT_EQ(rawRequest(port, "FOO /api/status HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n"),
              "HTTP/1.1 405 Method Not Allowed");
    // A refusal that quotes bytes that are not UTF-8 (a Host of Latin-1 bytes, found by fuzzing:
    // the listener's thread once died on it) is answered, the bytes as U+FFFD.
    EXPECT_EQ(rawRequest(port, "GET /api/status HTTP/1.1\r\nHost: \xe0\xce\xcd\r\n\r\n"),
              "HTTP/1.1 421 Misdirected Request");
    EXPECT_EQ(getJson("/api/status")["sequencer"]["state"], "ready");
}

/// A connection to the HMI that has sent `head` and sends nothing more.
int slowClient(int port, const std::string& head)
{
    const int fd = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(static_cast<std::uint16_t>(port));
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    EXPECT_EQ(connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
    EXPECT_EQ(send(fd, head.data(), head.size(), MSG_NOSIGNAL), static_cast<ssize_t>(head.size()));
    return fd;
}

/// The status line the server sent on `fd`, waiting at most `seconds`; empty when none.
std::string statusLineOn(int fd, int seconds)
{
    pollfd p{fd, POLLIN, 0};
    if (poll(&p, 1, seconds * 1000) != 1) return {};
    char buf[256] = {};
    const auto n = recv(fd, buf, sizeof buf - 1, MSG_DONTWAIT);
    const std::string answer(buf, n > 0 ? static_cast<std::size_t>(n) : 0);
    return answer.substr(0, answer.find("\r\n"));
}

// Fifty clients that stop half-way through a head or a body hold a slot each
// of the gate, never one of the threads that answer: the line view is answered
// while every one of them is still waiting (four such clients once held every
// HMI thread for as long as they lasted). Their deadline runs on the station's
// clock: moved past it, each is answered 408 and closed.
TEST_F(HmiServerTest, SlowClientsHoldTheirOwnSlotsNotTheThreadsThatAnswer)
{
    start([](station::DaemonConfig& c) { c.http.threads = 2; });
    std::vector<int> slow;
    for (int i = 0; i < 25; ++i) slow.push_back(slowClient(server->port(), "GET /api/status HTTP/1.1\r\nHost: 1"));
    for (int i = 0; i < 25; ++i)
        slow.push_back(slowClient(server->port(), "POST /api/login HTTP/1.1\r\nHost: 127.0.0.1\r\n"
                                                  "Content-Type: application/json\r\nContent-Length: 30\r\n\r\n{"));
    for (int i = 0; i < 5; ++i) EXPECT_EQ(getJson("/api/status")["sequencer"]["state"], "ready") << i;
    for (int fd : slow) EXPECT_EQ(statusLineOn(fd, 0), "") << "a slow client was answered before its deadline";
    clock.advance(std::chrono::milliseconds(5001));
    for (int fd : slow) {
        EXPECT_EQ(statusLineOn(fd, 10), "HTTP/1.1 408 Request Timeout");
        close(fd);
    }
    EXPECT_EQ(getJson("/api/status")["sequencer"]["state"], "ready");
}

TEST_F(HmiServerTest, MaintenanceNeedsASignedInSessionAndItsCsrfToken)
{
    start();
    const std::string body = R"({"command": "purpose", "purpose": "master"})";
    auto anonymous = client->Post("/api/maintenance", body, "application/json");
    ASSERT_TRUE(anonymous);
    EXPECT_EQ(anonymous->status, 401);
    auto wrong = client->Post("/api/login", R"({"password": "guess"})", "application/json");
    ASSERT_TRUE(wrong);
    EXPECT_EQ(wrong->status, 401);

    const auto [cookie, csrf] = signIn();
    auto noToken = client->Post("/api/maintenance", {{"Cookie", cookie}}, body, "application/json");
    ASSERT_TRUE(noToken);
    EXPECT_EQ(noToken->status, 403);
    EXPECT_NE(noToken->body.find("CSRF token missing"), std::string::npos) << noToken->body;
    // A token that is there but wrong is said to be wrong, not missing.
    auto wrongToken =
        client->Post("/api/maintenance", {{"Cookie", cookie}, {"X-CSRF-Token", csrf + "x"}}, body, "application/json");
    ASSERT_TRUE(wrongToken);
    EXPECT_EQ(wrongToken->status, 403);
    EXPECT_NE(wrongToken->body.find("does not match"), std::string::npos) << wrongToken->body;
    EXPECT_EQ(wrongToken->body.find("missing"), std::string::npos) << wrongToken->body;
    auto form = client->Post("/api/maintenance", {{"Cookie", cookie}, {"X-CSRF-Token", csrf}}, body, "text/plain");
    ASSERT_TRUE(form);
    EXPECT_EQ(form->status, 415);
    auto crossSite = client->Post("/api/maintenance",
                                  {{"Cookie", cookie}, {"X-CSRF-Token", csrf}, {"Origin", "http://evil.example"}}, body,
                                  "application/json");
    ASSERT_TRUE(crossSite);
    EXPECT_EQ(crossSite->status, 403);
    auto notOffered = client->Post("/api/maintenance", {{"Cookie", cookie}, {"X-CSRF-Token", csrf}},
                                   R"({"command": "results"})", "application/json");
    ASSERT_TRUE(notOffered);
    EXPECT_EQ(notOffered->status, 400);
    for (const auto& c : loop->commands()) EXPECT_NE(c.at("command"), "purpose") << "refused requests reached the loop";

    auto ok = client->Post("/api/maintenance", {{"Cookie", cookie}, {"X-CSRF-Token", csrf}}, body, "application/json");
    ASSERT_TRUE(ok);
    EXPECT_EQ(ok->status, 200) << ok->body;
    const auto seen = loop->commands();
    ASSERT_FALSE(seen.empty());
    // Handed on with who asked (docs/audit.md): the name signed in with the shared password, an engineer.
    auto handed = seen.back();
    EXPECT_EQ(handed["caller"], json({{"who", "engineer"}, {"role", "engineer"}, {"source", "hmi 127.0.0.1"}}));
    handed.erase("caller");
    EXPECT_EQ(handed, json::parse(body));

    // The session ends when it has been idle too long.
    clock.advance(std::chrono::duration_cast<std::chrono::milliseconds>(config->http.sessionIdle) + 1s);
    auto stale =
        client->Post("/api/maintenance", {{"Cookie", cookie}, {"X-CSRF-Token", csrf}}, body, "application/json");
    ASSERT_TRUE(stale);
    EXPECT_EQ(stale->status, 401);
}

// The maintenance page's health charts (docs/hmi.md, "JSON API"; docs/health.md):
// the store's health rows of the window, oldest first, read by whoever reaches
// the page (no sign-in, as every reading); the station's health now from the
// main loop's status; the flat-field reference asked for by a signed-in engineer.
TEST_F(HmiServerTest, TheHealthChartsReadTheStoredFiguresOfAWindowAndTheStationsHealthNow)
{
    {
        store::ResultStore store(config->results.database);
        const auto commit = [&](std::uint16_t seq, const char* utc, double backlight,
                                std::vector<vision::HealthFigure> warnings) {
            auto r = record(seq, station::Verdict::Pass, "H-" + std::to_string(seq));
            r.startedUnixMs = store::parseUtc(utc, "test");
            r.health = station::HealthRecord{};
            r.health->figures.backlight = backlight;
            r.health->figures.edgeWidthPx = 1.25;
            r.health->warnings = std::move(warnings);
            return store.commit(r);
        };
        // Before the default window (the last 7 days before the clock's 2026-03-02T08:00Z), and in it.
        commit(10, "2026-02-20T12:00:00", 0.99, {});
        commit(11, "2026-03-01T12:00:00", 0.5, {vision::HealthFigure::Backlight});
        commit(12, "2026-03-01T12:01:00", 0.98, {});
    }
    start();
    const json now{{"enabled", true}, {"warnings", json::array()}, {"reference", nullptr}, {"flat_field", nullptr}};
    auto status = json{{"ok", true}, {"sequencer", {{"state", "ready"}}}, {"plc", {{"status", 0}}}, {"health", now}};
    loop->setStatus(status);

    const auto week = getJson("/api/health");
    EXPECT_EQ(week["since"], "2026-02-23T08:00:00.000Z");
    EXPECT_TRUE(week["until"].is_null());
    EXPECT_EQ(week["cycles"], 2);
    ASSERT_EQ(week["rows"].size(), 2u);
    EXPECT_EQ(week["rows"][0]["time"], "2026-03-01T12:00:00.000Z");
    EXPECT_EQ(week["rows"][0]["backlight"], 0.5);
    EXPECT_EQ(week["rows"][0]["warnings"], json::array({"backlight"}));
    EXPECT_TRUE(week["rows"][0]["dust_specks"].is_null());
    EXPECT_EQ(week["rows"][1]["backlight"], 0.98);
    EXPECT_EQ(week["rows"][1]["edge_width_px"], 1.25);
    EXPECT_EQ(week["now"], now);

    const auto all = getJson("/api/health?since=2026-01-01&until=2026-03-01T12:00:30Z");
    ASSERT_EQ(all["rows"].size(), 2u);
    EXPECT_EQ(all["rows"][0]["backlight"], 0.99);
    EXPECT_EQ(all["rows"][1]["backlight"], 0.5);
    EXPECT_EQ(all["until"], "2026-03-01T12:00:30.000Z");
    EXPECT_EQ(getJson("/api/health?since=2026-01-01&limit=1")["rows"][0]["backlight"], 0.98);
    EXPECT_NE(getJson("/api/health?since=yesterday", 400)["error"].get<std::string>().find("since"), std::string::npos);
    EXPECT_NE(getJson("/api/health?limit=0", 400)["error"].get<std::string>().find("limit"), std::string::npos);

    // The flat-field reference: a signed-in engineer's maintenance command, handed on with who asked.
    const std::string body = R"({"command": "flat-field", "take": true, "frames": 4})";
    auto anonymous = client->Post("/api/maintenance", body, "application/json");
    ASSERT_TRUE(anonymous);
    EXPECT_EQ(anonymous->status, 401);
    const auto [cookie, csrf] = signIn();
    auto taken =
        client->Post("/api/maintenance", {{"Cookie", cookie}, {"X-CSRF-Token", csrf}}, body, "application/json");
    ASSERT_TRUE(taken);
    EXPECT_EQ(taken->status, 200) << taken->body;
    auto handed = loop->commands().back();
    EXPECT_EQ(handed["caller"]["role"], "engineer");
    handed.erase("caller");
    EXPECT_EQ(handed, json::parse(body));
}

// The maintenance page's camera frame (docs/hmi.md, "Maintenance"): asked for
// by a signed-in engineer through the loop, shown to whoever reads the page.
TEST_F(HmiServerTest, TheCameraSnapshotIsAskedForSignedInAndServedAsPng)
{
    std::shared_ptr<const std::vector<unsigned char>> png;
    start({}, [&png] { return png; });
    auto none = client->Get("/api/snapshot.png");
    ASSERT_TRUE(none);
    EXPECT_EQ(none->status, 404);

    const std::string body = R"({"command": "snapshot", "grab": true, "rotation_deg": 30})";
    auto anonymous = client->Post("/api/maintenance", body, "application/json");
    ASSERT_TRUE(anonymous);
    EXPECT_EQ(anonymous->status, 401);
    const auto [cookie, csrf] = signIn();
    auto asked =
        client->Post("/api/maintenance", {{"Cookie", cookie}, {"X-CSRF-Token", csrf}}, body, "application/json");
    ASSERT_TRUE(asked);
    EXPECT_EQ(asked->status, 200) << asked->body;
    auto handed = loop->commands().back();
    handed.erase("caller"); // who asked: tests/daemon/hmi/test_access.cpp
    EXPECT_EQ(handed, json::parse(body));
    EXPECT_EQ(getJson("/api/snapshot").at("did"), "snapshot");

    std::vector<unsigned char> encoded;
    cv::imencode(".png", cv::Mat(6, 9, CV_8UC3, cv::Scalar(1, 2, 3)), encoded);
    png = std::make_shared<const std::vector<unsigned char>>(encoded);
    auto shown = client->Get("/api/snapshot.png");
    ASSERT_TRUE(shown);
    EXPECT_EQ(shown->status, 200);
    EXPECT_EQ(shown->get_header_value("Content-Type"), "image/png");
    EXPECT_EQ(shown->get_header_value("Cache-Control"), "no-store");
    EXPECT_EQ(shown->body, std::string(encoded.begin(), encoded.end()));
}

// The calibration status from the loop, the history read from the station
// file and its backups on the web thread.
TEST_F(HmiServerTest, TheCalibrationHistoryListsTheStationFileAndItsBackups)
{
    hgtest::writeFile(dir / "station.yaml",
                      "camera: {calibration: {method: rail, rms_px: 0.12, date: 20261203T080000Z}}\n");
    hgtest::writeFile(dir / "station.yaml.bak-20261201T070000Z",
                      "camera: {calibration: {method: rail, rms_px: 0.3}}\n");
    start([&](station::DaemonConfig& c) { c.stationFile = dir / "station.yaml"; });
    const auto answer = getJson("/api/calibration");
    EXPECT_EQ(answer.at("did"), "calibration");
    const auto& history = answer.at("history");
    ASSERT_EQ(history.size(), 2u);
    EXPECT_EQ(history[0].at("file"), "station.yaml");
    EXPECT_DOUBLE_EQ(history[0].at("camera").at("rms_px").get<double>(), 0.12);
    EXPECT_EQ(history[1].at("file"), "station.yaml.bak-20261201T070000Z");
    EXPECT_DOUBLE_EQ(history[1].at("camera").at("rms_px").get<double>(), 0.3);
    EXPECT_TRUE(history[1].at("fixture").is_null());
}

TEST_F(HmiServerTest, AClientBeyondItsRateIsToldToWaitAndServedAgainLater)
{
    start([](station::DaemonConfig& c) {
        c.http.burst = 5;
        c.http.requestsPerSecond = 2;
    });
    for (int i = 0; i < 5; ++i) getJson("/api/results?limit=1");
    auto refused = client->Get("/api/results?limit=1");
    ASSERT_TRUE(refused);
    EXPECT_EQ(refused->status, 429);
    EXPECT_EQ(refused->get_header_value("Retry-After"), "1");
    clock.advance(1000ms); // two tokens back
    getJson("/api/results?limit=1");
    getJson("/api/results?limit=1");
    auto again = client->Get("/api/results?limit=1");
    ASSERT_TRUE(again);
    EXPECT_EQ(again->status, 429);
}

TEST_F(HmiServerTest, SignInAttemptsAreLimitedPerAddress)
{
    start();
    int refused = 0;
    for (int i = 0; i < 6; ++i) {
        auto res = client->Post("/api/login", R"({"password": "guess"})", "application/json");
        ASSERT_TRUE(res);
        if (res->status == 429) ++refused;
    }
    EXPECT_EQ(refused, 1); // five at once, the sixth waits 12 s
    clock.advance(12s);
    auto res = client->Post("/api/login", R"({"password": "line-7 secret"})", "application/json");
    ASSERT_TRUE(res);
    EXPECT_EQ(res->status, 200);
}

TEST(HmiAuth, PasswordsAreCheckedAgainstCryptHashesOnly)
{
    const auto hash = hgtest::sha512CryptOf("s3cret");
    EXPECT_TRUE(validPasswordHash(hash));
    EXPECT_TRUE(verifyPassword("s3cret", hash));
    EXPECT_FALSE(verifyPassword("s3cret ", hash));
    EXPECT_FALSE(verifyPassword("", hash));
    EXPECT_FALSE(validPasswordHash("s3cret"));        // a plain password is no hash
    EXPECT_FALSE(validPasswordHash("$6$"));           // nor a prefix alone
    EXPECT_FALSE(verifyPassword("s3cret", "s3cret")); // and never compared as one
}

} // namespace
} // namespace hg::daemon
