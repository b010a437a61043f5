// `hullgauge audit` run as a program (docs/audit.md, "Reading and export"):
// the trail as text (oldest first), CSV and JSON (newest first) against
// hand-written expectations, every filter, --out, and the refusals naming
// what was wrong.
#include "hgtest/paths.h"
#include "hullgauge/store/audit_log.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <fstream>
#include <sstream>

namespace {

/// 2026-05-28T20:26:40Z (`date -u -d @1780000000`).
constexpr std::int64_t kT0 = 1'780'000'000'000;

std::string contents(const std::filesystem::path& file)
{
    std::ifstream in(file, std::ios::binary);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

struct Trail {
    hgtest::TempDir dir;
    std::filesystem::path file = dir / "audit.sqlite";

    /// 1 anna (administrator) program.release, +0 s, with before and after;
    /// 2 olga (operator) program.landmark.change refused, +60 s, a detail with a comma;
    /// 3 unix:root user.add, +120 s; 4 hullgauged file.changed, +180 s.
    Trail()
    {
        hg::store::AuditLog log(file);
        hg::store::AuditEntry e{0,
                                kT0,
                                "anna",
                                "administrator",
                                "hmi 127.0.0.1",
                                "program.release",
                                "block",
                                "done",
                                "version 2",
                                "revision: 1",
                                "revision: 2\nreleased: true"};
        log.record(e);
        log.record({0, kT0 + 60'000, "olga", "operator", "hmi 127.0.0.1", "program.landmark.change", "block", "refused",
                    "needs an engineer, or administrator", "", ""});
        log.record({0, kT0 + 120'000, "unix:root", "", "tool", "user.add", "pia", "done", "", "", "role: operator"});
        log.record({0, kT0 + 180'000, "hullgauged", "", "daemon", "file.changed", "/etc/station.yaml", "done",
                    "station file, changed; found at reload", "a: \"1\"", "a: \"2\""});
    }

    hgtest::RunResult run(const std::string& args) const
    {
        return hgtest::run((hgtest::binaryDir() / "bin" / "hullgauge").string() + " audit --audit " + file.string() +
                           " " + args);
    }
    /// The ids a JSON export lists, in its order.
    std::vector<int> ids(const std::string& args) const
    {
        const auto r = run("--format json " + args);
        EXPECT_EQ(r.status, 0) << args << ": " << r.err;
        std::vector<int> out;
        const auto parsed = nlohmann::json::parse(r.out);
        for (const auto& e : parsed.at("entries")) out.push_back(e.at("id").get<int>());
        return out;
    }
};

TEST(AuditCli, TextIsOneLinePerEntryOldestFirst)
{
    Trail t;
    const auto r = t.run("");
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(r.out, "2026-05-28T20:26:40.000Z  anna (administrator)  hmi 127.0.0.1  program.release  block  done  "
                     "version 2  [before/after: --format csv or json]\n"
                     "2026-05-28T20:27:40.000Z  olga (operator)  hmi 127.0.0.1  program.landmark.change  block  "
                     "refused  needs an engineer, or administrator\n"
                     "2026-05-28T20:28:40.000Z  unix:root  tool  user.add  pia  done  [before/after: --format csv "
                     "or json]\n"
                     "2026-05-28T20:29:40.000Z  hullgauged  daemon  file.changed  /etc/station.yaml  done  station "
                     "file, changed; found at reload  [before/after: --format csv or json]\n");
}

TEST(AuditCli, CsvAndJsonNewestFirstWithBeforeAndAfter)
{
    Trail t;
    auto r = t.run("--format csv --until 2026-05-28T20:28");
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(r.out, "id,time,who,role,source,action,object,outcome,detail,before,after\r\n"
                     "2,2026-05-28T20:27:40.000Z,olga,operator,hmi 127.0.0.1,program.landmark.change,block,refused,"
                     "\"needs an engineer, or administrator\",,\r\n"
                     "1,2026-05-28T20:26:40.000Z,anna,administrator,hmi 127.0.0.1,program.release,block,done,"
                     "version 2,revision: 1,\"revision: 2\nreleased: true\"\r\n");

    r = t.run("--format json --who hullgauged");
    ASSERT_EQ(r.status, 0) << r.err;
    const auto entries = nlohmann::json::parse(r.out).at("entries");
    ASSERT_EQ(entries.size(), 1u);
    EXPECT_EQ(entries[0], (nlohmann::json{{"id", 4},
                                          {"at_unix_ms", kT0 + 180'000},
                                          {"time", "2026-05-28T20:29:40.000Z"},
                                          {"who", "hullgauged"},
                                          {"role", ""},
                                          {"source", "daemon"},
                                          {"action", "file.changed"},
                                          {"object", "/etc/station.yaml"},
                                          {"outcome", "done"},
                                          {"detail", "station file, changed; found at reload"},
                                          {"before", "a: \"1\""},
                                          {"after", "a: \"2\""}}));
}

TEST(AuditCli, SelectsByEveryFilter)
{
    Trail t;
    using Ids = std::vector<int>;
    EXPECT_EQ(t.ids(""), (Ids{4, 3, 2, 1}));
    EXPECT_EQ(t.ids("--since 2026-05-28T20:27:40"), (Ids{4, 3, 2}));
    EXPECT_EQ(t.ids("--until 2026-05-28T20:27:40"), (Ids{1}));
    EXPECT_EQ(t.ids("--since '2026-05-28 20:27' --until 2026-05-28T20:29:40Z"), (Ids{3, 2}));
    EXPECT_EQ(t.ids("--who anna"), (Ids{1}));
    EXPECT_EQ(t.ids("--who unix:root"), (Ids{3}));
    EXPECT_EQ(t.ids("--action program."), (Ids{2, 1}));
    EXPECT_EQ(t.ids("--action program.landmark"), (Ids{2}));
    EXPECT_EQ(t.ids("--action program_"), (Ids{}));
    EXPECT_EQ(t.ids("--outcome refused"), (Ids{2}));
    EXPECT_EQ(t.ids("--outcome done --action program."), (Ids{1}));
    EXPECT_EQ(t.ids("--outcome failed"), (Ids{}));
}

TEST(AuditCli, OutWritesTheFileInsteadOfStandardOutput)
{
    Trail t;
    const auto out = t.dir / "export" / "audit.csv";
    std::filesystem::create_directories(out.parent_path());
    auto r = t.run("--format csv --who olga --out " + out.string());
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(r.out, "");
    EXPECT_EQ(contents(out), "id,time,who,role,source,action,object,outcome,detail,before,after\r\n"
                             "2,2026-05-28T20:27:40.000Z,olga,operator,hmi 127.0.0.1,program.landmark.change,block,"
                             "refused,\"needs an engineer, or administrator\",,\r\n");
    // Replaced whole by the next export.
    r = t.run("--format text --who nobody --out " + out.string());
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(contents(out), "");
}

TEST(AuditCli, RefusesBadInputNamingIt)
{
    Trail t;
    const struct {
        std::string args, named;
    } cases[] = {{"--format xml", "--format"},
                 {"--outcome maybe", "--outcome"},
                 {"--since 2026-02-30", "--since"},
                 {"--until tomorrow", "--until"}};
    for (const auto& c : cases) {
        const auto r = t.run(c.args);
        EXPECT_EQ(r.status, 2) << c.args << ": " << r.err;
        EXPECT_NE(r.err.find(c.named), std::string::npos) << c.args << ": " << r.err;
        EXPECT_EQ(r.out, "") << c.args;
    }
}

TEST(AuditCli, AFileThatIsNoAuditTrailIsBadInputNamingIt)
{
    hgtest::TempDir dir;
    const auto hullgauge = (hgtest::binaryDir() / "bin" / "hullgauge").string();
    const auto store = dir / "results.db";
    ASSERT_EQ(hgtest::run("sqlite3 " + store.string() + " 'CREATE TABLE inspections (id INTEGER)'").status, 0);
    const auto text = hgtest::writeFile(dir / "notes.txt", "not a database, just some text of a length\n");
    const auto missing = dir / "none.sqlite";
    for (const auto& file : {store, text, missing}) {
        const auto r = hgtest::run(hullgauge + " audit --audit " + file.string());
        // The file is the user's (--audit): like `hullgauge export --store`, a wrong one is bad input.
        EXPECT_EQ(r.status, 2) << file << ": " << r.err;
        EXPECT_NE(r.err.find(file.string()), std::string::npos) << r.err;
        EXPECT_EQ(r.out, "");
    }
    EXPECT_NE(hgtest::run(hullgauge + " audit --audit " + store.string()).err.find("not an audit trail"),
              std::string::npos);
    EXPECT_FALSE(std::filesystem::exists(missing)) << "a read-only open created the trail";
    EXPECT_EQ(hgtest::run("sqlite3 " + store.string() + " 'SELECT name FROM sqlite_master'").out, "inspections\n");
}

} // namespace
