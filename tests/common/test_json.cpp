// The strict JSON reader: duplicate keys, numbers past double range, syntax
// errors and absurd nesting are bad input naming file, key and line.
#include "hullgauge/common/error.h"
#include "hullgauge/common/json.h"

#include <gtest/gtest.h>
#include <string>

namespace {

hg::InputError parseError(const std::string& text)
{
    try {
        (void)hg::parseJson(text, "request");
    } catch (const hg::InputError& e) {
        return e;
    }
    ADD_FAILURE() << "no InputError for: " << text;
    return hg::InputError("", "", "");
}

TEST(Json, ParsesWhatIsWellFormed)
{
    auto j = hg::parseJson(R"({"views": [{"id": "v0", "t": [0, 0, 300]}, {"id": "v1"}], "n": 1.5})", "m.json");
    EXPECT_EQ(j["views"][1]["id"], "v1");
    EXPECT_DOUBLE_EQ(j["n"].get<double>(), 1.5);
}

TEST(Json, DuplicateKeyIsRefusedNotLastWins)
{
    auto e = parseError("{\"command\": \"status\",\n \"command\": \"abort\"}");
    EXPECT_EQ(e.field(), "command");
    EXPECT_EQ(e.line().value_or(0), 2);
    EXPECT_NE(e.problem().find("duplicate key 'command'"), std::string::npos) << e.problem();
}

TEST(Json, DuplicateKeyDeepInsideNamesItsPathAndLine)
{
    const std::string text = "{\"views\": [\n"
                             "  {\"id\": \"v0\", \"image\": \"a.png\"},\n"
                             "  {\"id\": \"v1\",\n"
                             "   \"image\": \"b.png\", \"image\": \"c.png\"}]}";
    auto e = parseError(text);
    EXPECT_EQ(e.field(), "views[1].image");
    EXPECT_EQ(e.line().value_or(0), 4);
}

TEST(Json, SameKeyInSiblingObjectsIsFine)
{
    auto j = hg::parseJson(R"([{"id": 1}, {"id": 2}, {"a": {"id": 3}}])", "x");
    EXPECT_EQ(j[2]["a"]["id"], 3);
}

TEST(Json, NumberPastDoubleRangeIsBadInput)
{
    auto e = parseError("{\"t\": [0, 0, 1e400]}");
    EXPECT_NE(e.problem().find("1e400"), std::string::npos) << e.problem();
}

TEST(Json, SyntaxErrorNamesTheLine)
{
    auto e = parseError("{\"a\": 1,\n \"b\": 2,\n \"c\" 3}");
    EXPECT_EQ(e.line().value_or(0), 3);
    EXPECT_EQ(e.file(), "request");
}

TEST(Json, AbsurdNestingIsRefused)
{
    auto e = parseError(std::string(100, '[') + std::string(100, ']'));
    EXPECT_NE(e.problem().find("deeper than 64"), std::string::npos) << e.problem();
}

TEST(Json, TextThatIsNotUtf8IsWrittenWithReplacementCharacters)
{
    // "Bohrung ø" typed in Latin-1 (ø = 0xF8) and a lone continuation byte.
    const nlohmann::json value = {{"name", std::string("Bohrung \xF8")}, {"q", std::string("a\x80z")}};
    EXPECT_THROW((void)value.dump(), nlohmann::json::type_error); // what the library does on its own
    EXPECT_EQ(hg::dumpJson(value), "{\"name\":\"Bohrung \xEF\xBF\xBD\",\"q\":\"a\xEF\xBF\xBDz\"}");
    EXPECT_EQ(hg::dumpJson({{"ok", "ø"}}), "{\"ok\":\"ø\"}");
}

} // namespace
