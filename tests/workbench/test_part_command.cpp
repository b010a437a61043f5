// `hullgauge part` end to end on the simulated line's stepped block
// (config/sim): added, three landmarks placed where its part program has
// them, suggested, planned, a view rendered, verified on the twin without
// release, released, refused a release once the draft moved on, verified and
// released again, the two versions compared (the riser moved by 2.5 mm, by
// hand), version 1 rolled back as version 3 whose program is version 1's but
// for its record, and the versions listed. Two seats and the release multiple
// only, as tests/commission/test_commission_command.cpp, so it runs in seconds.
#include "hgtest/paths.h"
#include "hullgauge/model/part_program.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>

#include <fstream>
#include <sstream>

namespace hg::cli {
namespace {

namespace fs = std::filesystem;

std::string readText(const fs::path& file)
{
    std::ifstream in(file, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

fs::path sim(const std::string& name)
{
    return hgtest::sourceDir() / "config" / "sim" / name;
}

struct PartCommand : ::testing::Test {
    hgtest::TempDir dir;

    hgtest::RunResult part(const std::string& args)
    {
        return hgtest::run((hgtest::binaryDir() / "bin" / "hullgauge").string() + " part " + args + " --workspace " +
                           (dir / "parts").string());
    }
    std::string station() const { return " --station " + sim("station.yaml").string(); }
    std::string commission() const
    {
        return "commission stepped-block" + station() + " --seats 2 --seat-shift 0.3 --seat-rotation 0.3 --defects 2";
    }
    fs::path folder() const { return dir / "parts" / "stepped-block"; }
    /// A program as YAML with its release record left out.
    YAML::Node withoutRecord(const fs::path& file) const
    {
        YAML::Node n = YAML::LoadFile(file.string());
        n.remove("release");
        return n;
    }
};

std::string emitted(const YAML::Node& n)
{
    YAML::Emitter e;
    e << n;
    return e.c_str();
}

TEST_F(PartCommand, AddPlaceCommissionReleaseCompareAndRollBack)
{
    hgtest::RunResult r = part("add --cad " + sim("stepped-block.stl").string() + " --tolerance 0.4 --by tester");
    ASSERT_EQ(r.status, 0) << r.err;
    r = part("landmark add stepped-block --at -15,0,30.2 --id tall-top --revision 1 --json");
    ASSERT_EQ(r.status, 0) << r.err;
    const nlohmann::json placed = nlohmann::json::parse(r.out);
    EXPECT_EQ(placed["on"], "face");
    EXPECT_NEAR(placed["moved_mm"].get<double>(), 0.2, 1e-9);
    ASSERT_EQ(part("landmark add stepped-block --at 0,0,22.5 --id riser --revision 2").status, 0);
    ASSERT_EQ(part("landmark add stepped-block --at 15,0,15 --id step-top --revision 3").status, 0);

    r = part("suggest stepped-block --count 4 --twin-seats 0" + station());
    ASSERT_EQ(r.status, 0) << r.err;
    const nlohmann::json suggestions = nlohmann::json::parse(readText(folder() / "suggestions.json"));
    EXPECT_GE(suggestions["candidates"].size(), 4u);
    r = part("plan stepped-block" + station());
    ASSERT_EQ(r.status, 0) << r.err;
    r = part("view stepped-block 1 --out " + (dir / "v1.png").string() + station());
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(readText(dir / "v1.png").substr(1, 3), "PNG");

    r = part("release stepped-block --plc-program 7 --revision 4" + station());
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("has not been verified on the twin"), std::string::npos) << r.err;

    r = part(commission() + " --progress");
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_NE(r.out.find(R"({"phase":"nominal","done":2,"total":2})"), std::string::npos) << r.out;
    EXPECT_FALSE(fs::exists(folder() / "stepped-block.yaml")); // verified, never released
    r = part("release stepped-block --plc-program 7 --taken-programs 1,7 --revision 4" + station());
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("PLC program 7 is already a program of the daemon's programs: table"), std::string::npos)
        << r.err;
    r = part("release stepped-block --plc-program 7 --revision 4 --by tester" + station());
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(model::loadPartProgram(folder() / "stepped-block.yaml").release->version, 1);

    // The riser moved 2.5 mm down its face: the verification is of the revision before.
    ASSERT_EQ(part("landmark set stepped-block riser --at 0,0,20 --revision 4").status, 0);
    r = part("release stepped-block --revision 5" + station());
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(
        r.err.find("the last verification is of revision 4 of the draft of stepped-block, which is at revision 5"),
        std::string::npos)
        << r.err;
    ASSERT_EQ(part(commission()).status, 0);
    r = part("release stepped-block --revision 5" + station());
    ASSERT_EQ(r.status, 0) << r.err;

    r = part("diff stepped-block 1 2 --json");
    ASSERT_EQ(r.status, 0) << r.err;
    const nlohmann::json diff = nlohmann::json::parse(r.out);
    ASSERT_EQ(diff["landmarks"]["changed"].size(), 1u) << r.out;
    EXPECT_EQ(diff["landmarks"]["changed"][0]["id"], "riser");
    EXPECT_NEAR(diff["landmarks"]["changed"][0]["moved_mm"].get<double>(), 2.5, 1e-6);
    EXPECT_NEAR(diff["landmarks"]["changed"][0]["normal_turned_deg"].get<double>(), 0.0, 1e-9);
    EXPECT_TRUE(diff["landmarks"]["added"].empty());
    EXPECT_EQ(part("diff stepped-block 2 draft").status, 0);

    r = part("rollback stepped-block 1 --by tester");
    ASSERT_EQ(r.status, 0) << r.err;
    const model::PartProgram v3 = model::loadPartProgram(folder() / "stepped-block.yaml");
    EXPECT_EQ(v3.release->version, 3);
    EXPECT_EQ(v3.release->rolledBackFrom, 1);
    const fs::path releases = folder() / "releases";
    EXPECT_EQ(emitted(withoutRecord(releases / "stepped-block.v3" / "stepped-block.yaml")),
              emitted(withoutRecord(releases / "stepped-block.v1" / "stepped-block.yaml")));
    EXPECT_EQ(v3.release->verificationSha256,
              model::loadPartProgram(releases / "stepped-block.v1" / "stepped-block.yaml").release->verificationSha256);
    EXPECT_EQ(readText(folder() / "stepped-block-views.yaml"),
              readText(releases / "stepped-block.v1" / "stepped-block-views.yaml"));

    r = part("versions stepped-block --json");
    ASSERT_EQ(r.status, 0) << r.err;
    const nlohmann::json versions = nlohmann::json::parse(r.out)["versions"];
    ASSERT_EQ(versions.size(), 3u);
    EXPECT_FALSE(versions[0]["in_force"].get<bool>());
    EXPECT_TRUE(versions[2]["in_force"].get<bool>());
    EXPECT_EQ(versions[2]["rolled_back_from"], 1);
    EXPECT_EQ(versions[0]["released_by"], "tester");
    std::istringstream history(readText(folder() / "history.jsonl"));
    std::vector<nlohmann::json> lines;
    for (std::string line; std::getline(history, line);) lines.push_back(nlohmann::json::parse(line));
    ASSERT_EQ(lines.size(), 3u);
    EXPECT_EQ(lines[2]["action"], "rollback");
}

TEST_F(PartCommand, ARefusedModelExitsTwoAndLeavesNoFolder)
{
    const fs::path open = hgtest::sourceDir() / "tests" / "data" / "cad" / "block-tjunction-open.stl";
    const hgtest::RunResult r = part("add --cad " + open.string() + " --name open");
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find(open.string() + ": mesh: "), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir / "parts" / "open"));
}

} // namespace
} // namespace hg::cli
