// `hullgauge export` on a result store written here with sqlite3 in the
// daemon's layout (docs/daemon.md, "Results"): the selection and its order, and
// the refusals — exit 2 naming what was wrong, the --out file not touched.
#include "hgtest/paths.h"

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

namespace {

std::string hullgauge()
{
    return (hgtest::binaryDir() / "bin" / "hullgauge").string();
}

std::string contents(const std::filesystem::path& file)
{
    std::ifstream in(file, std::ios::binary);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

/// Four cycles, inserted newest first so the ids (the order) are not the times':
/// id 1 program 2 at +3 min, id 2 program 1 master at +2 min, id 3 program 1 at
/// +1 min, id 4 program 1 at +0 (2026-05-28T20:26:40Z).
std::filesystem::path makeStore(const hgtest::TempDir& dir)
{
    std::string sql = "CREATE TABLE inspections (id INTEGER PRIMARY KEY AUTOINCREMENT, started_unix_ms INTEGER NOT "
                      "NULL, serial TEXT NOT NULL, program INTEGER NOT NULL, part TEXT NOT NULL, verdict TEXT NOT "
                      "NULL, landmarks_json TEXT NOT NULL, purpose TEXT NOT NULL DEFAULT 'production');\n";
    const char* landmarks = R"([{"id":"a","status":"ok","error_mm":0.0625,"tolerance_mm":0.1,"deviation_mm":0.01}])";
    const struct {
        long long ms;
        const char* serial;
        int program;
        const char* purpose;
    } rows[] = {{1'780'000'180'000, "D", 2, "production"},
                {1'780'000'120'000, "C", 1, "master"},
                {1'780'000'060'000, "B", 1, "production"},
                {1'780'000'000'000, "A", 1, "production"}};
    for (const auto& r : rows)
        sql += "INSERT INTO inspections (started_unix_ms, serial, program, part, verdict, landmarks_json, purpose) "
               "VALUES (" +
               std::to_string(r.ms) + ", '" + r.serial + "', " + std::to_string(r.program) + ", 'block', 'pass', '" +
               landmarks + "', '" + r.purpose + "');\n";
    const auto script = hgtest::writeFile(dir / "rows.sql", sql);
    const auto db = dir / "results.db";
    EXPECT_EQ(hgtest::run("sqlite3 " + db.string() + " < " + script.string()).status, 0);
    return db;
}

/// The serial column of a CSV export without quoted fields.
std::vector<std::string> serials(const std::string& csv)
{
    std::vector<std::string> out;
    std::istringstream in(csv);
    std::string line;
    std::getline(in, line); // header
    while (std::getline(in, line)) {
        std::istringstream cells(line);
        std::string cell;
        for (int i = 0; i < 3; ++i) std::getline(cells, cell, ',');
        out.push_back(cell);
    }
    return out;
}

TEST(ExportCli, WritesTheSelectionOldestFirst)
{
    hgtest::TempDir dir;
    const auto db = makeStore(dir);
    const auto out = dir / "all.csv";
    auto r = hgtest::run(hullgauge() + " export --store " + db.string() + " --format csv --out " + out.string());
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(serials(contents(out)), (std::vector<std::string>{"D", "C", "B", "A"})); // stored order
    r = hgtest::run(hullgauge() + " export --store " + db.string() +
                    " --format csv --program 1 --purpose production --since 2026-05-28T20:27 --out " + out.string());
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(serials(contents(out)), (std::vector<std::string>{"B"}));
    r = hgtest::run(hullgauge() + " export --store " + db.string() +
                    " --format aqdef --until 2026-05-28T20:27:40 --out " + out.string());
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(contents(out).rfind("K0100 1\r\nK1001/1 1\r\n", 0), 0u) << contents(out);
}

TEST(ExportCli, RefusesBadInputNamingItAndWritesNothing)
{
    hgtest::TempDir dir;
    const auto db = makeStore(dir);
    const auto out = dir / "x.dfq";
    const auto base = hullgauge() + " export --store " + db.string() + " --out " + out.string();
    struct Case {
        std::string args;
        std::vector<std::string> named;
    } cases[] = {{" --format xml", {"--format", "'xml'"}},
                 {" --format csv --since 2026-02-30", {"--since", "2026-02-30"}},
                 {" --format csv --until tomorrow", {"--until", "tomorrow"}},
                 {" --format csv --purpose scrap", {"--purpose", "scrap"}}};
    for (const auto& c : cases) {
        const auto r = hgtest::run(base + c.args);
        EXPECT_EQ(r.status, 2) << c.args << ": " << r.err;
        for (const auto& n : c.named) EXPECT_NE(r.err.find(n), std::string::npos) << c.args << ": " << r.err;
        EXPECT_FALSE(std::filesystem::exists(out)) << c.args;
    }
    auto r = hgtest::run(hullgauge() + " export --store " + (dir / "none.db").string() + " --format csv --out " +
                         out.string());
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("no database at " + (dir / "none.db").string()), std::string::npos) << r.err;
    EXPECT_FALSE(std::filesystem::exists(out));
    r = hgtest::run(hullgauge() + " export --store " + db.string() + " --format csv --out " +
                    (dir / "no" / "x.csv").string());
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("--out"), std::string::npos) << r.err;

    // A refused export leaves an earlier file as it was.
    hgtest::writeFile(out, "earlier");
    r = hgtest::run(base + " --format csv --since 2026-13-01");
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(contents(out), "earlier");
}

} // namespace
