#include <gtest/gtest.h>

#include "hullgauge/common/error.h"

#include <stdexcept>
#include <type_traits>

namespace hg {

TEST(InputError, NamesFileLineAndField)
{
    InputError e("part.yaml", "landmarks[2].position", "expected a sequence of 3 numbers", 17);
    EXPECT_STREQ(e.what(), "part.yaml:17: landmarks[2].position: expected a sequence of 3 numbers");
    EXPECT_EQ(e.file(), "part.yaml");
    EXPECT_EQ(e.line(), 17);
}

TEST(InputError, WithoutLineOrFile)
{
    EXPECT_STREQ(InputError("m.stl", "", "file is empty").what(), "m.stl: file is empty");
    EXPECT_STREQ(InputError("", "--depth", "must be 1..20").what(), "--depth: must be 1..20");
}

TEST(ArgumentError, IsAnInvalidArgumentCarryingItsMessage)
{
    const std::string message = "render window 100x10+1200+0 is not within the 1224x1024 sensor";
    try {
        throw ArgumentError(message);
    } catch (const std::invalid_argument& e) {
        EXPECT_EQ(e.what(), message);
        EXPECT_NE(dynamic_cast<const ArgumentError*>(&e), nullptr);
    }
    EXPECT_THROW(throw ArgumentError("x"), std::invalid_argument);
}

TEST(ArgumentError, IsNeitherBadInputNorAFault)
{
    // A catch of InputError (exit 2) or FaultError (exit 3) must not take a broken precondition for either.
    EXPECT_FALSE((std::is_base_of_v<InputError, ArgumentError>));
    EXPECT_FALSE((std::is_base_of_v<FaultError, ArgumentError>));
    EXPECT_FALSE((std::is_base_of_v<std::runtime_error, ArgumentError>));
}

} // namespace hg
