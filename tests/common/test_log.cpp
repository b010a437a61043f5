#include <gtest/gtest.h>

#include "hullgauge/common/error.h"
#include "hullgauge/common/log.h"

namespace hg {

TEST(Log, LevelsPerCategory)
{
    log::configure("warn,camera=trace");
    EXPECT_EQ(log::category("camera")->level(), spdlog::level::trace);
    EXPECT_EQ(log::category("plc")->level(), spdlog::level::warn);
    log::configure("plc=debug");
    EXPECT_EQ(log::category("plc")->level(), spdlog::level::debug);
    EXPECT_EQ(log::category("camera")->level(), spdlog::level::trace);
    log::configure("info");
}

TEST(Log, UnknownLevelIsInputError)
{
    EXPECT_THROW(log::configure("camera=loud"), InputError);
    EXPECT_NO_THROW(log::configure("off"));
    log::configure("info");
}

} // namespace hg
