// The workbench's HTTP API (docs/workbench.md) over real HTTP on 127.0.0.1:
// uploads checked by the part program's loader, landmarks put on the surface
// (checked against the analytic stepped block of the simulated line: x in
// [-30, 30], y in [-20, 20], 30 mm tall for x < 0, 15 mm for x > 0), the
// revision rule for two engineers, and the jobs run as `hullgauge part`
// processes of this build: commissioning, release (the daemon asked to
// reload), versions, diff and rollback. The daemon's main loop is played by a
// thread that answers the mailbox.
#include "command_mailbox.h"
#include "hgtest/manual_clock.h"
#include "hgtest/password_hash.h"
#include "hgtest/paths.h"
#include "hmi/hmi_server.h"

#include <arpa/inet.h>
#include <fstream>
#include <gtest/gtest.h>
#include <httplib.h>
#include <netinet/in.h>
#include <poll.h>
#include <sstream>
#include <sys/socket.h>
#include <thread>
#include <unistd.h>

namespace hg::daemon {
namespace {

using nlohmann::json;
using namespace std::chrono_literals;
namespace fs = std::filesystem;

std::string bytesOf(const fs::path& file)
{
    std::ifstream in(file, std::ios::binary);
    std::ostringstream out;
    out << in.rdbuf();
    return out.str();
}

/// The main loop as the workbench sees it: answers every command, counts the reloads.
class ReloadCountingLoop {
  public:
    explicit ReloadCountingLoop(CommandMailbox& mailbox) : mailbox_(mailbox), thread_([this] { run(); }) {}
    ~ReloadCountingLoop()
    {
        stop_ = true;
        thread_.join();
    }
    int reloads() const { return reloads_; }

  private:
    void run()
    {
        while (!stop_) {
            pollfd fd{mailbox_.fd(), POLLIN, 0};
            if (poll(&fd, 1, 20) > 0)
                mailbox_.serve([this](const json& request) {
                    if (request.at("command") == "reload") ++reloads_;
                    return json{{"ok", true}, {"reloading", true}};
                });
        }
    }
    CommandMailbox& mailbox_;
    std::atomic<bool> stop_{false};
    std::atomic<int> reloads_{0};
    std::thread thread_;
};

class PartsApi : public ::testing::Test {
  protected:
    void SetUp() override
    {
        auto cfg = std::make_shared<station::DaemonConfig>();
        const fs::path sim = hgtest::sourceDir() / "config" / "sim";
        cfg->stationFile = sim / "station.yaml";
        cfg->station = geometry::loadStation(cfg->stationFile);
        cfg->results.database = dir / "results.db";
        cfg->results.imageDir = dir / "images";
        cfg->http.enabled = true;
        cfg->http.port = 0;
        cfg->http.assets = hgtest::sourceDir() / "share" / "hmi";
        cfg->http.passwordHash = hgtest::sha512CryptOf("bench secret");
        cfg->http.burst = 1000;
        cfg->workbench.folder = dir / "parts";
        cfg->workbench.cli = hgtest::binaryDir() / "bin" / "hullgauge";
        cfg->workbench.maxUploadBytes = 4u << 20;
        fs::create_directories(cfg->workbench.folder);
        station::PartProgramRef one;
        one.number = 1;
        one.partFile = sim / "stepped-block.yaml";
        cfg->programs.emplace(1, one);
        server = std::make_unique<HmiServer>(cfg, mailbox, clock);
        loop = std::make_unique<ReloadCountingLoop>(mailbox);
        client = std::make_unique<httplib::Client>("127.0.0.1", server->port());
        client->set_read_timeout(120, 0);
        block = bytesOf(sim / "stepped-block.stl");
    }

    struct Engineer {
        std::string cookie, csrf;
    };
    Engineer signIn(const std::string& name)
    {
        auto res =
            client->Post("/api/login", json{{"password", "bench secret"}, {"name", name}}.dump(), "application/json");
        EXPECT_TRUE(res && res->status == 200) << (res ? res->body : "no answer");
        const auto cookie = res->get_header_value("Set-Cookie");
        return {cookie.substr(0, cookie.find(';')), json::parse(res->body).at("csrf").get<std::string>()};
    }
    httplib::Result post(const Engineer& who, const std::string& path, const json& body)
    {
        return client->Post(path.c_str(), {{"Cookie", who.cookie}, {"X-CSRF-Token", who.csrf}}, body.dump(),
                            "application/json");
    }
    httplib::Result upload(const Engineer& who, const std::string& query, const std::string& bytes)
    {
        return client->Post(("/api/parts?" + query).c_str(), {{"Cookie", who.cookie}, {"X-CSRF-Token", who.csrf}},
                            bytes, "application/octet-stream");
    }
    json get(const std::string& path, int expected = 200)
    {
        auto res = client->Get(path.c_str());
        EXPECT_TRUE(res) << path;
        if (!res) return {};
        EXPECT_EQ(res->status, expected) << path << ": " << res->body;
        return json::parse(res->body, nullptr, false);
    }
    /// Adds the stepped block as `name`; its part JSON.
    json addBlock(const Engineer& who, const std::string& name = "block")
    {
        auto res = upload(who, "name=" + name + "&file=stepped-block.stl", block);
        EXPECT_TRUE(res && res->status == 201) << (res ? res->body : "no answer");
        return res ? json::parse(res->body) : json();
    }
    /// Polls the part's job until it has ended (bounded: a job that never ends fails the test).
    json jobEnded(const std::string& part)
    {
        for (int i = 0; i < 3000; ++i) {
            const auto job = get("/api/parts/" + part + "/job");
            if (!job.is_null() && job.value("state", "") != "running") return job;
            std::this_thread::sleep_for(100ms);
        }
        ADD_FAILURE() << "the job of " << part << " did not end within 300 s";
        return {};
    }

    hgtest::TempDir dir;
    hgtest::ManualClock clock;
    CommandMailbox mailbox;
    std::unique_ptr<HmiServer> server;
    std::unique_ptr<ReloadCountingLoop> loop;
    std::unique_ptr<httplib::Client> client;
    std::string block;
};

TEST_F(PartsApi, AnUploadedModelIsAPartWithItsDisplayMeshes)
{
    const auto anna = signIn("anna");
    const auto part = addBlock(anna);
    EXPECT_EQ(part["name"], "block");
    EXPECT_EQ(part["revision"], 1);
    EXPECT_EQ(part["changed_by"], "anna");
    EXPECT_EQ(part["draft"]["landmarks"].size(), 0u);
    const auto& bounds = part["cad"]["bounds_mm"];
    EXPECT_NEAR(bounds[0][0].get<double>(), -30.0, 1e-9);
    EXPECT_NEAR(bounds[1][2].get<double>(), 30.0, 1e-9);
    const std::size_t triangles = part["cad"]["triangles"].get<std::size_t>();
    EXPECT_GT(triangles, 0u);

    const auto listed = get("/api/parts");
    ASSERT_EQ(listed["parts"].size(), 1u);
    EXPECT_EQ(listed["parts"][0]["name"], "block");

    // A binary STL: an 80-byte header, a count, 50 bytes a triangle.
    auto mesh = client->Get("/api/parts/block/model.stl");
    ASSERT_TRUE(mesh);
    ASSERT_EQ(mesh->status, 200);
    ASSERT_GE(mesh->body.size(), 84u);
    std::uint32_t count = 0;
    std::memcpy(&count, mesh->body.data() + 80, 4);
    EXPECT_EQ(count, triangles);
    EXPECT_EQ(mesh->body.size(), 84u + 50u * count);
    auto lod = client->Get("/api/parts/block/model.stl?lod=1");
    ASSERT_TRUE(lod);
    EXPECT_EQ(lod->status, 200);
    // Validated (docs/hmi.md, "Files and caching"): the mesh the browser holds is not sent again.
    const auto etag = mesh->get_header_value("ETag");
    ASSERT_FALSE(etag.empty());
    auto held = client->Get("/api/parts/block/model.stl", {{"If-None-Match", etag}});
    ASSERT_TRUE(held);
    EXPECT_EQ(held->status, 304);
    EXPECT_TRUE(held->body.empty());
    // The nest play drawn by the page: the draft's alignment limits, the part program's defaults.
    EXPECT_EQ(part["draft"]["alignment"]["max_shift_mm"], 1.0);
    EXPECT_EQ(part["draft"]["alignment"]["max_rotation_deg"], 1.0);
    EXPECT_EQ(get("/api/parts/nothere", 404).value("error", "").empty(), false);
}

TEST_F(PartsApi, RefusedUploadsLeaveNothingBehind)
{
    auto anonymous = client->Post("/api/parts?name=x&file=x.stl", block, "application/octet-stream");
    ASSERT_TRUE(anonymous);
    EXPECT_EQ(anonymous->status, 401);
    const auto anna = signIn("anna");
    auto noToken =
        client->Post("/api/parts?name=x&file=x.stl", {{"Cookie", anna.cookie}}, block, "application/octet-stream");
    ASSERT_TRUE(noToken);
    EXPECT_EQ(noToken->status, 403);

    auto notAMesh = upload(anna, "name=junk&file=junk.stl", "solid junk\nthis is not a facet\nendsolid\n");
    ASSERT_TRUE(notAMesh);
    EXPECT_EQ(notAMesh->status, 400) << notAMesh->body;
    EXPECT_NE(json::parse(notAMesh->body)["error"].get<std::string>().find("junk.stl"), std::string::npos)
        << notAMesh->body;

    auto badDepth = upload(anna, "name=deep&file=stepped-block.stl&depth=16", block);
    ASSERT_TRUE(badDepth);
    EXPECT_EQ(badDepth->status, 400) << badDepth->body;
    EXPECT_NE(badDepth->body.find("depth: '16'"), std::string::npos) << badDepth->body;

    addBlock(anna);
    auto twice = upload(anna, "name=block&file=stepped-block.stl", block);
    ASSERT_TRUE(twice);
    EXPECT_EQ(twice->status, 409) << twice->body;

    // 2 GB announced: refused at the head, before a byte of the body is read.
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(static_cast<std::uint16_t>(server->port()));
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ASSERT_EQ(::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
    const std::string head =
        "POST /api/parts?name=big&file=big.stl HTTP/1.1\r\nHost: 127.0.0.1\r\nCookie: " + anna.cookie +
        "\r\nX-CSRF-Token: " + anna.csrf +
        "\r\nContent-Type: application/octet-stream\r\nContent-Length: 2147483648\r\n\r\n";
    ASSERT_EQ(::send(fd, head.data(), head.size(), 0), static_cast<ssize_t>(head.size()));
    std::string answer;
    char buffer[4096];
    for (ssize_t n; (n = ::recv(fd, buffer, sizeof buffer, 0)) > 0;) answer.append(buffer, static_cast<std::size_t>(n));
    ::close(fd);
    EXPECT_EQ(answer.rfind("HTTP/1.1 413", 0), 0u) << answer;
    EXPECT_NE(answer.find("workbench.max_upload_bytes"), std::string::npos) << answer;

    // Only the part that was accepted: no folder, temporary or not, of a refused one.
    std::vector<std::string> entries;
    for (const auto& e : fs::directory_iterator(dir / "parts"))
        if (e.path().filename().string().front() != '.') entries.push_back(e.path().filename().string());
    EXPECT_EQ(entries, std::vector<std::string>{"block"});
}

TEST_F(PartsApi, AClickNearAFaceLandsOnItWithTheFaceNormal)
{
    const auto anna = signIn("anna");
    addBlock(anna);
    // 0.3 mm above the tall top (z = 30): on the face, normal +z, moved 0.3 mm.
    auto res = post(anna, "/api/parts/block/landmarks", {{"revision", 1}, {"position", {-15.0, 2.0, 30.3}}});
    ASSERT_TRUE(res);
    ASSERT_EQ(res->status, 200) << res->body;
    auto part = json::parse(res->body);
    EXPECT_EQ(part["revision"], 2);
    EXPECT_EQ(part["placed"]["on"], "face");
    EXPECT_NEAR(part["placed"]["moved_mm"].get<double>(), 0.3, 1e-6);
    const auto& l = part["draft"]["landmarks"][0];
    EXPECT_NEAR(l["position"][0].get<double>(), -15.0, 1e-6);
    EXPECT_NEAR(l["position"][1].get<double>(), 2.0, 1e-6);
    EXPECT_NEAR(l["position"][2].get<double>(), 30.0, 1e-6);
    EXPECT_NEAR(l["normal"][2].get<double>(), 1.0, 1e-9);

    // 20 mm above the part: refused naming the distance, the draft as it was.
    const auto before = bytesOf(dir / "parts" / "block" / "block.draft.yaml");
    res = post(anna, "/api/parts/block/landmarks", {{"revision", 2}, {"position", {-15.0, 0.0, 50.0}}});
    ASSERT_TRUE(res);
    EXPECT_EQ(res->status, 400) << res->body;
    EXPECT_NE(res->body.find("20.000 mm from the part's surface"), std::string::npos) << res->body;
    EXPECT_EQ(bytesOf(dir / "parts" / "block" / "block.draft.yaml"), before);
    EXPECT_EQ(get("/api/parts/block")["revision"], 2);
}

TEST_F(PartsApi, AChangeMadeOnAnOlderRevisionIsRefusedNamingWhoChangedIt)
{
    const auto anna = signIn("anna");
    const auto ben = signIn("ben");
    addBlock(anna);
    ASSERT_EQ(post(anna, "/api/parts/block/landmarks", {{"revision", 1}, {"position", {-15.0, 0.0, 30.0}}})->status,
              200);
    const auto before = bytesOf(dir / "parts" / "block" / "block.draft.yaml");
    // Ben's page still shows revision 1.
    auto res = post(ben, "/api/parts/block/landmarks", {{"revision", 1}, {"position", {15.0, 0.0, 15.0}}});
    ASSERT_TRUE(res);
    EXPECT_EQ(res->status, 409) << res->body;
    EXPECT_NE(res->body.find("revision 2"), std::string::npos) << res->body;
    EXPECT_NE(res->body.find("anna"), std::string::npos) << res->body;
    EXPECT_EQ(bytesOf(dir / "parts" / "block" / "block.draft.yaml"), before);
}

// Four seats of the simulated line's nest (config/sim/hullgauged.yaml), not the default play of 80 %
// of the program's limits (1 mm and 1°).
const json kLinePlay = {{"seats", 4}, {"seat_shift_mm", 0.3}, {"seat_rotation_deg", 0.3}};

TEST_F(PartsApi, CommissionedReleasedComparedAndRolledBack)
{
    const auto anna = signIn("anna");
    addBlock(anna);
    int revision = 1;
    // The simulated line's ten landmarks (config/sim/stepped-block.yaml): planned in five views, the
    // seat is measured on all of them (three on the top alone plan two, which do not measure it).
    const std::vector<json> line{{-15.0, 0.0, 30.0}, {-28.0, 0.0, 30.0}, {-30.0, 0.0, 27.0}, {-30.0, 5.0, 8.0},
                                 {0.0, 0.0, 22.5},   {15.0, 0.0, 15.0},  {30.0, -5.0, 7.5},  {-15.0, -20.0, 15.0},
                                 {15.0, 20.0, 7.5},  {20.0, 12.0, 15.0}};
    for (const json& at : line) {
        auto res =
            post(anna, "/api/parts/block/landmarks", {{"revision", revision}, {"position", at}, {"tolerance_mm", 0.4}});
        ASSERT_TRUE(res && res->status == 200) << (res ? res->body : "no answer");
        revision = json::parse(res->body)["revision"].get<int>();
    }
    // Not verified yet: nothing to release.
    auto early = post(anna, "/api/parts/block/release", {{"revision", revision}, {"plc_program", 7}});
    ASSERT_TRUE(early);
    EXPECT_EQ(early->status, 409) << early->body;

    // A play out of range is refused before anything starts.
    for (const json& bad :
         {json{{"seat_shift_mm", 0}}, json{{"seat_rotation_deg", "0.3"}}, json{{"seat_shift_mm", 11}}}) {
        const auto refused = post(anna, "/api/parts/block/commission", bad);
        ASSERT_TRUE(refused);
        EXPECT_EQ(refused->status, 400) << bad.dump();
        EXPECT_NE(refused->body.find(bad.begin().key() + ": a number in (0, 10]"), std::string::npos) << refused->body;
    }
    auto started = post(anna, "/api/parts/block/commission", kLinePlay);
    ASSERT_TRUE(started);
    ASSERT_EQ(started->status, 202) << started->body;
    auto second = post(anna, "/api/parts/block/commission", json::object());
    ASSERT_TRUE(second);
    EXPECT_EQ(second->status, 409) << second->body; // one job per part
    auto job = jobEnded("block");
    ASSERT_EQ(job["state"], "finished") << job.dump();
    EXPECT_EQ(job["started_by"], "anna");
    EXPECT_EQ(get("/api/parts/block/verification")["landmarks"].size(), line.size());

    // Program 1 is the station's own table's.
    auto taken = post(anna, "/api/parts/block/release", {{"revision", revision}, {"plc_program", 1}});
    ASSERT_TRUE(taken);
    EXPECT_EQ(taken->status, 409) << taken->body;
    auto released = post(anna, "/api/parts/block/release", {{"revision", revision}, {"plc_program", 7}});
    ASSERT_TRUE(released);
    ASSERT_EQ(released->status, 200) << released->body;
    auto part = json::parse(released->body);
    EXPECT_EQ(part["released"]["version"], 1);
    EXPECT_EQ(part["released"]["plc_program"], 7);
    EXPECT_EQ(part["released"]["released_by"], "anna");
    EXPECT_EQ(loop->reloads(), 1);

    // Version 2 with a wider tolerance at the second landmark, then back to version 1.
    const auto riser = part["draft"]["landmarks"][1]["id"].get<std::string>();
    auto widened = post(anna, "/api/parts/block/landmarks/" + riser, {{"revision", revision}, {"tolerance_mm", 0.5}});
    ASSERT_TRUE(widened && widened->status == 200) << (widened ? widened->body : "no answer");
    revision = json::parse(widened->body)["revision"].get<int>();
    ASSERT_EQ(post(anna, "/api/parts/block/commission", kLinePlay)->status, 202);
    ASSERT_EQ(jobEnded("block")["state"], "finished");
    ASSERT_EQ(post(anna, "/api/parts/block/release", {{"revision", revision}, {"plc_program", 7}})->status, 200);
    const auto diff = get("/api/parts/block/diff?from=1&to=2");
    EXPECT_NE(diff.dump().find(riser), std::string::npos) << diff.dump();
    EXPECT_NE(diff.dump().find("0.5"), std::string::npos) << diff.dump();

    auto rolled = post(anna, "/api/parts/block/rollback", {{"version", 1}});
    ASSERT_TRUE(rolled);
    ASSERT_EQ(rolled->status, 200) << rolled->body;
    const auto versions = get("/api/parts/block/versions")["versions"];
    ASSERT_EQ(versions.size(), 3u);
    bool third = false;
    for (const auto& v : versions)
        if (v["version"] == 3) {
            third = true;
            EXPECT_EQ(v["rolled_back_from"], 1);
            EXPECT_TRUE(v["in_force"].get<bool>());
        }
    EXPECT_TRUE(third);
    EXPECT_EQ(loop->reloads(), 3);
}

TEST_F(PartsApi, ACancelledCommissioningLeavesThePreviousVerification)
{
    const auto anna = signIn("anna");
    addBlock(anna);
    ASSERT_EQ(post(anna, "/api/parts/block/landmarks", {{"revision", 1}, {"position", {-15.0, 0.0, 30.0}}})->status,
              200);
    auto started = post(anna, "/api/parts/block/commission", {{"seats", 200}});
    ASSERT_TRUE(started && started->status == 202) << (started ? started->body : "no answer");
    auto cancel = post(anna, "/api/parts/block/job/cancel", json::object());
    ASSERT_TRUE(cancel);
    EXPECT_EQ(cancel->status, 200) << cancel->body;
    const auto job = jobEnded("block");
    EXPECT_EQ(job["state"], "cancelled") << job.dump();
    EXPECT_FALSE(fs::exists(dir / "parts" / "block" / "verification.json"));
    EXPECT_TRUE(get("/api/parts/block")["verified"].is_null());
}

} // namespace
} // namespace hg::daemon
