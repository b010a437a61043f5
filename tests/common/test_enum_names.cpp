// The enum↔name mechanism (common/enum_names.h): names, parsing, the lists for
// messages, and the checks that make a table that forgets an enumerator, lists
// one twice or out of order fail to compile — exercised here on the predicates
// the static_asserts evaluate, since a test cannot compile a failure.
#include <gtest/gtest.h>

#include "hullgauge/common/enum_names.h"

namespace shapes {

using hg::EnumName;

enum class Shape { Circle, Square, Triangle };
constexpr auto nameTable(Shape)
{
    using enum Shape;
    return std::to_array<EnumName<Shape>>({{Circle, "circle"}, {Square, "square"}, {Triangle, "triangle"}});
}

/// Values with gaps and an unsigned underlying type, as register values are.
enum class Code : unsigned char { None = 0, Low = 10, High = 44 };
constexpr auto nameTable(Code)
{
    using enum Code;
    return std::to_array<EnumName<Code>>({{None, "none"}, {Low, "low"}, {High, "high"}});
}

enum class Forgotten { A, B, C };
constexpr auto nameTable(Forgotten)
{
    using enum Forgotten;
    return std::to_array<EnumName<Forgotten>>({{A, "a"}, {B, "b"}});
}

enum class Unordered { A, B, C };
constexpr auto nameTable(Unordered)
{
    using enum Unordered;
    return std::to_array<EnumName<Unordered>>({{A, "a"}, {C, "c"}, {B, "b"}});
}

enum class Twice { A, B };
constexpr auto nameTable(Twice)
{
    using enum Twice;
    return std::to_array<EnumName<Twice>>({{A, "a"}, {B, "a"}});
}

} // namespace shapes

namespace {

enum class Local { One, Two };
constexpr auto nameTable(Local)
{
    using enum Local;
    return std::to_array<hg::EnumName<Local>>({{One, "one"}, {Two, "two"}});
}

using shapes::Code;
using shapes::Shape;
namespace detail = hg::enum_names_detail;

TEST(EnumNames, NameAndParseEveryValue)
{
    static_assert(hg::enumName(Shape::Square) == "square");
    static_assert(hg::parseEnum<Shape>("triangle") == Shape::Triangle);
    for (std::string_view n : hg::enumNames<Shape>) EXPECT_EQ(hg::enumName(*hg::parseEnum<Shape>(n)), n);
    EXPECT_EQ(hg::enumName(Code::High), "high");
    EXPECT_EQ(hg::parseEnum<Code>("low"), Code::Low);
    EXPECT_EQ(hg::enumName(Local::Two), "two");
}

TEST(EnumNames, UnknownTextAndValues)
{
    EXPECT_FALSE(hg::parseEnum<Shape>("Circle")); // names are exact
    EXPECT_FALSE(hg::parseEnum<Shape>(""));
    EXPECT_EQ(hg::enumName(static_cast<Code>(11)), "?");
}

TEST(EnumNames, ListsForMessages)
{
    EXPECT_EQ(hg::enumNameList<Shape>(), "circle, square, triangle");
    EXPECT_EQ(hg::enumNameList<Shape>(", ", " or "), "circle, square or triangle");
    EXPECT_EQ(hg::enumNameList<Local>(", ", " or "), "one or two");
    EXPECT_EQ(hg::enumNames<Code>.size(), 3u);
}

TEST(EnumNames, CompletenessIsCheckedAtCompileTime)
{
    // What checked<E>() asserts, on tables that would not compile if used.
    static_assert(detail::enumeratorCount<Shape>() == 3);
    static_assert(detail::enumeratorCount<Code>() == 3);
    static_assert(detail::enumeratorCount<Local>() == 2);
    static_assert(detail::enumeratorCount<shapes::Forgotten>() != detail::table<shapes::Forgotten>.size());
    static_assert(!detail::wellFormed<shapes::Unordered>());
    static_assert(!detail::wellFormed<shapes::Twice>());
    static_assert(detail::wellFormed<Shape>() && detail::wellFormed<Code>());
    SUCCEED();
}

} // namespace
