// The station's shifts (docs/daemon.md, `shifts`): the list parsed and refused
// with precise errors, and which shift a moment falls in and when it began —
// across midnight and across a change to summer time — with the zone given
// as a function, never the machine's.
#include "daemon_config.h"
#include "hgtest/paths.h"
#include "hgtest/station.h"
#include "hullgauge/common/config_node.h"
#include "hullgauge/common/error.h"
#include "hullgauge/store/result_reader.h"
#include "shifts.h"

#include <gtest/gtest.h>

namespace hg::station {
namespace {

std::vector<Shift> parsed(const std::string& yaml)
{
    return parseShifts(ConfigNode::parse(yaml, "hullgauged.yaml")["shifts"]);
}

std::string refusal(const std::string& yaml)
{
    try {
        parsed(yaml);
    } catch (const InputError& e) {
        return e.what();
    }
    return "(accepted)";
}

const std::vector<Shift> kThree{{"early", 6 * 60}, {"late", 14 * 60}, {"night", 22 * 60}};

TEST(Shifts, AListInTheOrderOfTheDayParses)
{
    EXPECT_EQ(parsed("shifts: [{name: early, start: \"06:00\"}, {name: late, start: \"14:00\"},\n"
                     "         {name: night, start: \"22:00\"}]\n"),
              kThree);
    EXPECT_EQ(defaultShifts(), (std::vector<Shift>{{"day", 0}}));
    EXPECT_EQ(parseTimeOfDay("00:00"), 0);
    EXPECT_EQ(parseTimeOfDay("23:59"), 23 * 60 + 59);
    for (const char* bad : {"24:00", "6:00", "06:60", "06.00", "06:00:00", "", "ab:cd"})
        EXPECT_EQ(parseTimeOfDay(bad), -1) << bad;
}

TEST(Shifts, BadListsAreRefusedSayingWhatAndWhere)
{
    EXPECT_EQ(refusal("shifts: [{name: early, start: \"6:00\"}]\n"),
              "hullgauged.yaml:1: shifts[0].start: '6:00' is not a time of day HH:MM from 00:00 to 23:59 (the "
              "station's local time)");
    EXPECT_EQ(refusal("shifts: [{name: early, start: \"25:00\"}]\n"),
              "hullgauged.yaml:1: shifts[0].start: '25:00' is not a time of day HH:MM from 00:00 to 23:59 (the "
              "station's local time)");
    EXPECT_EQ(refusal("shifts:\n  - {name: early, start: \"06:00\"}\n  - {name: early, start: \"14:00\"}\n"),
              "hullgauged.yaml:3: shifts[1].name: shift name 'early' given twice (first at shifts[0])");
    EXPECT_EQ(refusal("shifts:\n  - {name: late, start: \"14:00\"}\n  - {name: early, start: \"06:00\"}\n"),
              "hullgauged.yaml:3: shifts[1].start: shift 'early' starts at 06:00, not after the shift before it "
              "('late' at 14:00): list the shifts in the order of the day, from the earliest start");
    EXPECT_NE(refusal("shifts:\n  - {name: a, start: \"06:00\"}\n  - {name: b, start: \"06:00\"}\n")
                  .find("shift 'b' starts at 06:00, not after the shift before it ('a' at 06:00)"),
              std::string::npos);
    EXPECT_NE(refusal("shifts: []\n").find("shifts: expected a list of shifts"), std::string::npos);
    EXPECT_NE(refusal("shifts: [{name: early}]\n").find("start"), std::string::npos);
    EXPECT_NE(refusal("shifts: [{name: early, start: \"06:00\", end: \"14:00\"}]\n").find("end"), std::string::npos);
}

TEST(Shifts, TheDaemonConfigurationTakesTheListOrTheDefault)
{
    hgtest::TempDir dir;
    hgtest::writeFile(dir / "station.yaml", hgtest::stationYaml({.sections = "lamps: {backend: sim}\n"}));
    hgtest::writeFile(dir / "block.yaml", "part: block\nmesh: block.stl\nlandmarks:\n"
                                          "  - {id: c1, position: [0, 0, 10], tolerance_mm: 0.2}\n");
    hgtest::writeFile(dir / "views.yaml", "- {rotation_deg: 0, declination_deg: 30}\n");
    const std::string base = "station: station.yaml\nprograms:\n  1: {part: block.yaml, views: views.yaml}\n"
                             "results: {database: results.db, images: images}\n";
    EXPECT_EQ(loadDaemonConfig(hgtest::writeFile(dir / "a.yaml", base)).shifts, defaultShifts());
    const auto cfg = loadDaemonConfig(hgtest::writeFile(
        dir / "b.yaml", base + "shifts: [{name: early, start: \"06:00\"}, {name: late, start: \"14:00\"}, "
                               "{name: night, start: \"22:00\"}]\n"));
    EXPECT_EQ(cfg.shifts, kThree);
    try {
        loadDaemonConfig(hgtest::writeFile(dir / "c.yaml", base + "shifts: [{name: x, start: \"7:30\"}]\n"));
        ADD_FAILURE() << "a bad start was accepted";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("c.yaml:5: shifts[0].start: '7:30' is not a time of day"),
                  std::string::npos)
            << e.what();
    }
}

TEST(Shifts, ALocalTimeFallsInTheShiftThatStartedLastAcrossMidnight)
{
    EXPECT_EQ(shiftAt(kThree, 6 * 60), 0u);
    EXPECT_EQ(shiftAt(kThree, 13 * 60 + 59), 0u);
    EXPECT_EQ(shiftAt(kThree, 14 * 60), 1u);
    EXPECT_EQ(shiftAt(kThree, 22 * 60), 2u);
    EXPECT_EQ(shiftAt(kThree, 23 * 60 + 59), 2u);
    EXPECT_EQ(shiftAt(kThree, 0), 2u); // after midnight the night shift goes on
    EXPECT_EQ(shiftAt(kThree, 5 * 60 + 59), 2u);
    EXPECT_EQ(shiftAt(defaultShifts(), 0), 0u);
    EXPECT_EQ(shiftAt(defaultShifts(), 1439), 0u);
}

std::int64_t utc(const char* text)
{
    return store::parseUtc(text, "test");
}

TEST(Shifts, TheCurrentShiftBeganInLocalTimeOfItsZone)
{
    const UtcOffset plusOne = [](std::int64_t) { return std::int64_t{3600}; };
    const UtcOffset minusFive = [](std::int64_t) { return std::int64_t{-5 * 3600}; };
    // 09:00 at UTC+1: early, since 06:00 local.
    auto w = currentShift(kThree, utc("2026-03-02T08:00:00"), plusOne);
    EXPECT_EQ(w.index, 0u);
    EXPECT_EQ(w.startUnixMs, utc("2026-03-02T05:00:00"));
    // 03:00 local on the 3rd at UTC+1: the night shift that began at 22:00 local on the 2nd.
    w = currentShift(kThree, utc("2026-03-03T02:00:00"), plusOne);
    EXPECT_EQ(w.index, 2u);
    EXPECT_EQ(w.startUnixMs, utc("2026-03-02T21:00:00"));
    // 23:30 local on the 2nd at UTC-5 is already the 3rd in UTC; the night began at 03:00Z on the 3rd.
    w = currentShift(kThree, utc("2026-03-03T04:30:00"), minusFive);
    EXPECT_EQ(w.index, 2u);
    EXPECT_EQ(w.startUnixMs, utc("2026-03-03T03:00:00"));
    // The first second of a shift belongs to it, the last of the one before to that one.
    EXPECT_EQ(currentShift(kThree, utc("2026-03-02T13:00:00"), plusOne).index, 1u);
    EXPECT_EQ(currentShift(kThree, utc("2026-03-02T13:00:00") - 1, plusOne).index, 0u);
    // One shift "day" from midnight.
    w = currentShift(defaultShifts(), utc("2026-03-02T00:30:00"), plusOne);
    EXPECT_EQ(w.startUnixMs, utc("2026-03-01T23:00:00"));
}

TEST(Shifts, ANightShiftOverTheChangeToSummerTimeBeganAtItsOwnOffset)
{
    // Central Europe: UTC+1 until 2026-03-29T01:00Z, UTC+2 from then on.
    const std::int64_t change = utc("2026-03-29T01:00:00") / 1000;
    const UtcOffset berlin = [change](std::int64_t t) { return t < change ? std::int64_t{3600} : 7200; };
    // 05:00 local (summer time) on the 29th: the night shift began at 22:00 local (winter time) on the 28th.
    const auto w = currentShift(kThree, utc("2026-03-29T03:00:00"), berlin);
    EXPECT_EQ(w.index, 2u);
    EXPECT_EQ(w.startUnixMs, utc("2026-03-28T21:00:00"));
}

} // namespace
} // namespace hg::station
