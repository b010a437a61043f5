// Roles and the audit trail on the web HMI (docs/audit.md) over real HTTP on
// 127.0.0.1: each person signs in with their own account, a request their role
// does not allow is a 403 naming who may, nothing changes, and the attempt is
// in the trail; the administrator's accounts API; the trail read as JSON and
// CSV. The daemon's main loop is played by a thread answering the mailbox.
#include "hgtest/manual_clock.h"
#include "hgtest/password_hash.h"
#include "hgtest/paths.h"
#include "hmi/fake_loop.h"
#include "hmi/hmi_server.h"
#include "hullgauge/store/accounts.h"
#include "hullgauge/store/audit_log.h"

#include <gtest/gtest.h>
#include <httplib.h>

namespace hg::daemon {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using store::Role;

struct Signed {
    std::string cookie, csrf;
    httplib::Headers headers() const { return {{"Cookie", cookie}, {"X-CSRF-Token", csrf}}; }
};

class AccessTest : public ::testing::Test {
  protected:
    void SetUp() override
    {
        auto cfg = std::make_shared<station::DaemonConfig>();
        cfg->results.database = dir / "results.db";
        cfg->results.imageDir = dir / "images";
        cfg->http.enabled = true;
        cfg->http.port = 0;
        cfg->http.assets = hgtest::sourceDir() / "share" / "hmi";
        cfg->http.burst = 1000;
        cfg->http.passwordHash = hgtest::sha512CryptOf("shared secret");
        cfg->workbench.folder = dir / "parts";
        fs::create_directories(cfg->workbench.folder);
        const store::AccountsFile accounts(dir / "users.yaml");
        accounts.add({"anna", Role::Administrator, hgtest::sha512CryptOf("anna's password")});
        accounts.add({"erik", Role::Engineer, hgtest::sha512CryptOf("erik's password")});
        accounts.add({"olga", Role::Operator, hgtest::sha512CryptOf("olga's password")});
        server = std::make_unique<HmiServer>(cfg, mailbox, clock);
        loop = std::make_unique<FakeLoop>(mailbox);
        client = std::make_unique<httplib::Client>("127.0.0.1", server->port());
        client->set_read_timeout(10, 0);
    }
    Signed signIn(const std::string& name, const std::string& password)
    {
        const json body{{"name", name}, {"password", password}};
        auto res = client->Post("/api/login", body.dump(), "application/json");
        EXPECT_TRUE(res && res->status == 200) << name << ": " << (res ? res->body : "no answer");
        if (!res || res->status != 200) return {};
        const auto cookie = res->get_header_value("Set-Cookie");
        return {cookie.substr(0, cookie.find(';')), json::parse(res->body).at("csrf").get<std::string>()};
    }
    httplib::Result post(const Signed& who, const std::string& path, const json& body)
    {
        return client->Post(path, who.headers(), body.dump(), "application/json");
    }
    /// The trail as the daemon wrote it, read through its own connection.
    std::vector<store::AuditEntry> trail(store::AuditQuery q = {})
    {
        return store::AuditLog(dir / "audit.sqlite", true).select(q);
    }

    hgtest::TempDir dir;
    hgtest::ManualClock clock;
    CommandMailbox mailbox;
    std::unique_ptr<HmiServer> server;
    std::unique_ptr<FakeLoop> loop;
    std::unique_ptr<httplib::Client> client;
};

TEST_F(AccessTest, AnOperatorCannotChangeAProgramOrCalibrateAndEachRefusalIsInTheTrail)
{
    const auto olga = signIn("olga", "olga's password");
    auto release = post(olga, "/api/parts/bracket/release", {{"revision", 3}, {"plc_program", 2}});
    ASSERT_TRUE(release);
    EXPECT_EQ(release->status, 403);
    EXPECT_EQ(json::parse(release->body).at("error"),
              "operator 'olga' may not change part programs: that needs an engineer or administrator");
    auto landmark = post(olga, "/api/parts/bracket/landmarks", {{"revision", 3}, {"position", {0, 0, 0}}});
    ASSERT_TRUE(landmark);
    EXPECT_EQ(landmark->status, 403);
    auto calibrate = post(olga, "/api/maintenance",
                          {{"command", "calibrate"}, {"pattern", "chessboard:8x5:15"}, {"poses", "/tmp/grid.yaml"}});
    ASSERT_TRUE(calibrate);
    EXPECT_EQ(calibrate->status, 403);
    EXPECT_EQ(json::parse(calibrate->body).at("error"),
              "operator 'olga' may not calibrate the station: that needs an engineer or administrator");
    auto purpose = post(olga, "/api/maintenance", {{"command", "purpose"}, {"purpose", "master"}});
    ASSERT_TRUE(purpose);
    EXPECT_EQ(purpose->status, 403);
    // Nothing reached the daemon's loop.
    for (const auto& c : loop->commands()) EXPECT_EQ(c.at("command"), "status") << c.dump();

    store::AuditQuery refused;
    refused.outcome = "refused";
    const auto entries = trail(refused);
    ASSERT_EQ(entries.size(), 4u);
    // Newest first: purpose, calibration, landmark, release.
    EXPECT_EQ(entries[0].action, "setting.purpose");
    EXPECT_EQ(entries[1].action, "calibration.run");
    EXPECT_EQ(entries[2].action, "program.landmark.add");
    EXPECT_EQ(entries[3].action, "program.release");
    EXPECT_EQ(entries[3].object, "bracket");
    for (const auto& e : entries) {
        EXPECT_EQ(e.who, "olga");
        EXPECT_EQ(e.role, "operator");
        EXPECT_EQ(e.source, "hmi 127.0.0.1");
        EXPECT_NE(e.detail.find("may not"), std::string::npos) << e.detail;
        EXPECT_EQ(e.atMs, clock.wallMs());
    }

    // The operator reads the trail, their own refusals in it.
    auto read = client->Get("/api/audit?outcome=refused", httplib::Headers{{"Cookie", olga.cookie}});
    ASSERT_TRUE(read);
    ASSERT_EQ(read->status, 200) << read->body;
    const auto rows = json::parse(read->body).at("entries");
    ASSERT_EQ(rows.size(), 4u);
    EXPECT_EQ(rows[3].at("action"), "program.release");
    EXPECT_EQ(rows[3].at("who"), "olga");
    // Not signed in: no trail.
    auto anonymous = client->Get("/api/audit");
    ASSERT_TRUE(anonymous);
    EXPECT_EQ(anonymous->status, 401);
}

TEST_F(AccessTest, AnEngineerCalibratesAndTheLoopIsToldWhoAsked)
{
    const auto erik = signIn("erik", "erik's password");
    auto calibrate = post(erik, "/api/maintenance",
                          {{"command", "calibrate"}, {"pattern", "chessboard:8x5:15"}, {"poses", "/tmp/grid.yaml"}});
    ASSERT_TRUE(calibrate);
    EXPECT_EQ(calibrate->status, 200) << calibrate->body;
    const auto handed = loop->commands().back();
    EXPECT_EQ(handed.at("command"), "calibrate");
    EXPECT_EQ(handed.at("caller"), json({{"who", "erik"}, {"role", "engineer"}, {"source", "hmi 127.0.0.1"}}));
    // The HMI's calibration writes the daemon's own station file, never one the request names.
    auto elsewhere = post(
        erik, "/api/maintenance",
        {{"command", "calibrate"}, {"pattern", "chessboard:8x5:15"}, {"poses", "/tmp/g.yaml"}, {"out", "/etc/passwd"}});
    ASSERT_TRUE(elsewhere);
    EXPECT_EQ(elsewhere->status, 400);
    // Applying the configuration is an administrator's.
    auto reload = post(erik, "/api/maintenance", {{"command", "reload"}});
    ASSERT_TRUE(reload);
    EXPECT_EQ(reload->status, 403);
    EXPECT_EQ(json::parse(reload->body).at("error"),
              "engineer 'erik' may not change settings: that needs an administrator");
    const auto anna = signIn("anna", "anna's password");
    auto applied = post(anna, "/api/maintenance", {{"command", "reload"}});
    ASSERT_TRUE(applied);
    EXPECT_EQ(applied->status, 200) << applied->body;
}

TEST_F(AccessTest, TheAdministratorManagesAccountsAndEachChangeIsRecordedWithoutAPassword)
{
    const auto anna = signIn("anna", "anna's password");
    auto added = post(anna, "/api/users", {{"name", "paul"}, {"role", "operator"}, {"password", "paul's first"}});
    ASSERT_TRUE(added);
    EXPECT_EQ(added->status, 201) << added->body;
    const auto paul = signIn("paul", "paul's first");
    auto session = client->Get("/api/session", httplib::Headers{{"Cookie", paul.cookie}});
    ASSERT_TRUE(session);
    const auto s = json::parse(session->body);
    EXPECT_EQ(s.at("role"), "operator");
    EXPECT_EQ(s.at("may").at("programs"), false);
    EXPECT_EQ(s.at("may").at("read"), true);

    // A role changed applies to the open session at its next request.
    auto promoted = post(anna, "/api/users/paul", {{"role", "engineer"}});
    ASSERT_TRUE(promoted);
    EXPECT_EQ(promoted->status, 200) << promoted->body;
    auto purpose = post(paul, "/api/maintenance", {{"command", "purpose"}, {"purpose", "study"}});
    ASSERT_TRUE(purpose);
    EXPECT_EQ(purpose->status, 200) << purpose->body;
    // Only an administrator manages accounts.
    auto selfPromotion = post(paul, "/api/users/paul", {{"role", "administrator"}});
    ASSERT_TRUE(selfPromotion);
    EXPECT_EQ(selfPromotion->status, 403);
    auto list = client->Get("/api/users", httplib::Headers{{"Cookie", paul.cookie}});
    ASSERT_TRUE(list);
    EXPECT_EQ(list->status, 403);
    // A new password: the old one no longer signs in.
    auto reset = post(anna, "/api/users/paul", {{"password", "paul's second"}});
    ASSERT_TRUE(reset);
    EXPECT_EQ(reset->status, 200);
    auto old =
        client->Post("/api/login", json{{"name", "paul"}, {"password", "paul's first"}}.dump(), "application/json");
    ASSERT_TRUE(old);
    EXPECT_EQ(old->status, 401);
    // A password shorter than 8 characters is refused, naming the rule.
    auto tooShort = post(anna, "/api/users", {{"name", "ines"}, {"role", "operator"}, {"password", "short"}});
    ASSERT_TRUE(tooShort);
    EXPECT_EQ(tooShort->status, 400);
    EXPECT_NE(tooShort->body.find("at least 8 characters"), std::string::npos) << tooShort->body;
    // Removed: the session ends.
    auto removed = post(anna, "/api/users/paul/remove", json::object());
    ASSERT_TRUE(removed);
    EXPECT_EQ(removed->status, 200);
    auto gone = post(paul, "/api/maintenance", {{"command", "purpose"}, {"purpose", "production"}});
    ASSERT_TRUE(gone);
    EXPECT_EQ(gone->status, 401);
    EXPECT_NE(gone->body.find("no longer exists"), std::string::npos) << gone->body;
    // The last administrator stays.
    auto last = post(anna, "/api/users/anna/remove", json::object());
    ASSERT_TRUE(last);
    EXPECT_EQ(last->status, 400);
    EXPECT_NE(last->body.find("last administrator"), std::string::npos) << last->body;

    store::AuditQuery users;
    users.actionPrefix = "user.";
    users.outcome = "done";
    std::vector<std::string> actions;
    const auto entries = trail(users);
    for (auto it = entries.rbegin(); it != entries.rend(); ++it) actions.push_back(it->action + " " + it->object);
    EXPECT_EQ(actions,
              (std::vector<std::string>{"user.add paul", "user.role paul", "user.password paul", "user.remove paul"}));
    EXPECT_EQ(entries[2].before, "role: operator");
    EXPECT_EQ(entries[2].after, "role: engineer");
    // No password, nor its hash, anywhere in the trail.
    const auto hash = store::AccountsFile(dir / "users.yaml").find("anna")->passwordHash;
    for (const auto& e : trail())
        for (const auto* text : {&e.detail, &e.before, &e.after})
            for (const auto& secret :
                 std::vector<std::string>{"paul's first", "paul's second", "anna's password", hash})
                EXPECT_EQ(text->find(secret), std::string::npos) << e.action << ": " << *text;
}

// The right is judged before the request's body: an engineer's malformed or nameless account request
// is refused as theirs to make (403, recorded), not answered as a bad body (400) that would tell them
// what the administrator's form expects.
TEST_F(AccessTest, AnAccountRequestWithoutTheRightIsRefusedWhateverItsBody)
{
    const auto erik = signIn("erik", "erik's password");
    auto nameless = client->Post("/api/users", erik.headers(), "{\"role\": \"administrator\"}", "application/json");
    ASSERT_TRUE(nameless);
    EXPECT_EQ(nameless->status, 403) << nameless->body;
    auto malformed = client->Post("/api/users", erik.headers(), "{not json", "application/json");
    ASSERT_TRUE(malformed);
    EXPECT_EQ(malformed->status, 403) << malformed->body;
    auto change = client->Post("/api/users/olga", erik.headers(), "[1, 2]", "application/json");
    ASSERT_TRUE(change);
    EXPECT_EQ(change->status, 403) << change->body;

    store::AuditQuery refused;
    refused.outcome = "refused";
    const auto entries = trail(refused);
    ASSERT_EQ(entries.size(), 3u);
    EXPECT_EQ(entries[0].action, "user.change");
    EXPECT_EQ(entries[0].object, "olga");
    EXPECT_EQ(entries[1].action, "user.add");
    EXPECT_EQ(entries[1].object, "");
    for (const auto& e : entries) EXPECT_EQ(e.who, "erik");
    // The administrator's malformed request is a bad body, said so.
    const auto anna = signIn("anna", "anna's password");
    auto bad = client->Post("/api/users", anna.headers(), "{\"role\": \"operator\"}", "application/json");
    ASSERT_TRUE(bad);
    EXPECT_EQ(bad->status, 400) << bad->body;
}

TEST_F(AccessTest, TheSharedPasswordSignsInAnEngineerButNeverAsAnAccount)
{
    // An account's name with the shared password: refused, and recorded so.
    auto impostor =
        client->Post("/api/login", json{{"name", "anna"}, {"password", "shared secret"}}.dump(), "application/json");
    ASSERT_TRUE(impostor);
    EXPECT_EQ(impostor->status, 401);
    const auto shared = signIn("night shift", "shared secret");
    auto purpose = post(shared, "/api/maintenance", {{"command", "purpose"}, {"purpose", "master"}});
    ASSERT_TRUE(purpose);
    EXPECT_EQ(purpose->status, 200) << purpose->body;
    auto users = post(shared, "/api/users", {{"name", "x1"}, {"role", "operator"}, {"password", "12345678"}});
    ASSERT_TRUE(users);
    EXPECT_EQ(users->status, 403);

    store::AuditQuery signIns;
    signIns.actionPrefix = "sign-in";
    const auto entries = trail(signIns);
    ASSERT_EQ(entries.size(), 2u);
    EXPECT_EQ(entries[1].who, "anna");
    EXPECT_EQ(entries[1].outcome, "refused");
    EXPECT_EQ(entries[1].detail, "wrong password");
    EXPECT_EQ(entries[0].who, "night shift");
    EXPECT_EQ(entries[0].role, "engineer");
    EXPECT_EQ(entries[0].detail, "shared maintenance password");
}

TEST_F(AccessTest, TheTrailDownloadsAsCsvWithItsFieldsQuoted)
{
    const auto anna = signIn("anna", "anna's password");
    auto added = post(anna, "/api/users", {{"name", "o.k-1"}, {"role", "operator"}, {"password", "12345678"}});
    ASSERT_TRUE(added);
    ASSERT_EQ(added->status, 201);
    // A comma or a quote is no part of an account's name.
    auto badName = post(anna, "/api/users", {{"name", "a,\"b\""}, {"role", "operator"}, {"password", "12345678"}});
    ASSERT_TRUE(badName);
    EXPECT_EQ(badName->status, 400);
    auto csv = client->Get("/api/audit?format=csv&action=user.", httplib::Headers{{"Cookie", anna.cookie}});
    ASSERT_TRUE(csv);
    ASSERT_EQ(csv->status, 200) << csv->body;
    EXPECT_EQ(csv->get_header_value("Content-Type"), "text/csv; charset=utf-8");
    EXPECT_NE(csv->get_header_value("Content-Disposition").find("attachment"), std::string::npos);
    // Header, then the one entry: its after text "role: operator", no quotes needed.
    const std::string header = "id,time,who,role,source,action,object,outcome,detail,before,after\r\n";
    ASSERT_EQ(csv->body.rfind(header, 0), 0u) << csv->body;
    const auto row = csv->body.substr(header.size());
    EXPECT_NE(row.find(",anna,administrator,hmi 127.0.0.1,user.add,o.k-1,done,,,role: operator\r\n"), std::string::npos)
        << row;
    // A refused filter is a 400 naming it.
    auto badOutcome = client->Get("/api/audit?outcome=maybe", httplib::Headers{{"Cookie", anna.cookie}});
    ASSERT_TRUE(badOutcome);
    EXPECT_EQ(badOutcome->status, 400);
    EXPECT_NE(badOutcome->body.find("outcome"), std::string::npos);
}

} // namespace
} // namespace hg::daemon
