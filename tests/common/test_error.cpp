#include <gtest/gtest.h>

#include "hullgauge/common/error.h"

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

} // namespace hg
