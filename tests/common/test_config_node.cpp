// The YAML loader every configuration file goes through: a key given twice in
// one map is bad input naming the key and both lines, never "the first wins".
#include "hullgauge/common/config_node.h"
#include "hullgauge/common/error.h"

#include <gtest/gtest.h>
#include <string>

namespace {

hg::InputError parseError(const std::string& text)
{
    try {
        (void)hg::ConfigNode::parse(text, "part.yaml");
    } catch (const hg::InputError& e) {
        return e;
    }
    ADD_FAILURE() << "no InputError for:\n" << text;
    return hg::InputError("", "", "");
}

TEST(ConfigNode, DuplicateTopLevelKeyNamesKeyAndBothLines)
{
    auto e = parseError("part: a\noctree:\n  depth: 8\npart: b\n");
    EXPECT_EQ(e.field(), "part");
    ASSERT_TRUE(e.line().has_value());
    EXPECT_EQ(*e.line(), 4);
    EXPECT_NE(e.problem().find("duplicate key 'part'"), std::string::npos) << e.problem();
    EXPECT_NE(e.problem().find("line 1"), std::string::npos) << e.problem();
}

TEST(ConfigNode, DuplicateNestedKeyNamesItsPath)
{
    // depth 8 then depth 3: yaml-cpp alone would answer 8 for octree.depth.
    auto e = parseError("part: a\noctree:\n  depth: 8\n  adjacency_depth: 3\n  depth: 3\n");
    EXPECT_EQ(e.field(), "octree.depth");
    EXPECT_EQ(e.line().value_or(0), 5);
}

TEST(ConfigNode, DuplicateKeyInsideASequenceEntryNamesTheIndex)
{
    auto e = parseError("landmarks:\n  - id: a\n    tolerance_mm: 0.1\n  - id: b\n    id: c\n");
    EXPECT_EQ(e.field(), "landmarks[1].id");
    EXPECT_EQ(e.line().value_or(0), 5);
}

TEST(ConfigNode, FlowMapDuplicateIsRefused)
{
    auto e = parseError("pose: {rotation_deg: 10, rotation_deg: 20}\n");
    EXPECT_EQ(e.field(), "pose.rotation_deg");
}

// Found by the station harness (docs/fuzzing.md): a `? ` before a key made
// the map under it a key (a complex key), and listing the keys escaped as
// yaml-cpp's conversion error, ending the program.
TEST(ConfigNode, KeyThatIsAMapOrASequenceIsRefusedAtItsLine)
{
    auto e = parseError("fixture:\n  speeds:\n    rotation: {max_speed: 3600}\n    ? declination: {max_speed: 1800}\n");
    EXPECT_EQ(e.field(), "fixture.speeds");
    EXPECT_EQ(e.line().value_or(0), 4);
    EXPECT_NE(e.problem().find("a key must be a name, found a map"), std::string::npos) << e.problem();
    e = parseError("[a, b]: 1\n");
    EXPECT_EQ(e.field(), "(document)");
    EXPECT_EQ(e.line().value_or(0), 1);
    EXPECT_NE(e.problem().find("a key must be a name, found a sequence"), std::string::npos) << e.problem();
}

TEST(ConfigNode, SameKeyInSiblingMapsIsFine)
{
    auto n = hg::ConfigNode::parse("a: {x: 1}\nb: {x: 2}\nc: [{id: 1}, {id: 2}]\n", "ok.yaml");
    EXPECT_EQ(n["a"]["x"].asInt(), 1);
    EXPECT_EQ(n["b"]["x"].asInt(), 2);
}

TEST(ConfigNode, AliasBombIsRefusedNotWalkedForever)
{
    // Nine levels of ten aliases each expand to 10^9 nodes.
    std::string text = "l0: &l0 [x, x, x, x, x, x, x, x, x, x]\n";
    for (int i = 1; i <= 9; ++i) {
        std::string prev = "*l" + std::to_string(i - 1);
        text += "l" + std::to_string(i) + ": &l" + std::to_string(i) + " [" + prev;
        for (int k = 1; k < 10; ++k) text += ", " + prev;
        text += "]\n";
    }
    auto e = parseError(text);
    EXPECT_NE(e.problem().find("too large"), std::string::npos) << e.problem();
}

// A second document after `---` was once silently ignored, with whatever the
// engineer wrote there; it is refused at its line. An empty one is no text lost.
TEST(ConfigNode, ASecondDocumentIsRefusedAtItsLine)
{
    const hg::InputError e = parseError("part: block\noctree: {depth: 6}\n---\nlandmarks: []\n");
    EXPECT_EQ(e.line(), std::optional<int>(4));
    EXPECT_NE(e.problem().find("a second YAML document begins here"), std::string::npos) << e.problem();
    EXPECT_EQ(hg::ConfigNode::parse("part: block\n---\n", "p.yaml")["part"].asString(), "block");
    EXPECT_EQ(hg::ConfigNode::parse("part: block\n...\n", "p.yaml")["part"].asString(), "block");
}

// Found by fuzzing: yaml-cpp's parser reports "," as one empty document after another without
// end; reading every document hung. The walk is bounded by the stream's document markers.
TEST(ConfigNode, ALoneCommaIsAnEmptyFileNotAnEndlessStream)
{
    const hg::InputError e = parseError(",");
    EXPECT_EQ(e.problem(), "file is empty");
    EXPECT_EQ(hg::ConfigNode::parse("part: block\n---\n---\n...\n", "p.yaml")["part"].asString(), "block");
}

TEST(ConfigNode, DeviceNodesAndFoldersAreRefusedWithoutReading)
{
    // /dev/zero once grew a reader without bound; it is not a configuration file.
    for (const char* path : {"/dev/zero", "/dev/null", "/"}) {
        try {
            (void)hg::ConfigNode::loadFile(path);
            ADD_FAILURE() << path << " was read";
        } catch (const hg::InputError& e) {
            EXPECT_EQ(e.problem(), "not a regular file") << path;
            EXPECT_EQ(e.file(), path);
        }
    }
}

TEST(ConfigNode, MissingFileNamesIt)
{
    try {
        (void)hg::ConfigNode::loadFile("/nonexistent/station.yaml");
        ADD_FAILURE() << "no error";
    } catch (const hg::InputError& e) {
        EXPECT_EQ(e.problem(), "cannot open file");
    }
}

} // namespace
