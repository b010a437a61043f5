// The part's temperature at a trigger (docs/mastering.md, "Temperature"): the
// PLC's latched reading passed on, a sensor file's number read and scaled, and
// every way a file fails — missing, not one number, implausible, stale on the
// hand-moved clock — a missing reading with one journal warning naming the
// file and what was wrong, never a throw.
#include "cycle/part_temperature.h"
#include "hgtest/log_capture.h"
#include "hgtest/manual_clock.h"
#include "hgtest/paths.h"

#include <gtest/gtest.h>

namespace hg::daemon {
namespace {

using namespace std::chrono_literals;
namespace fs = std::filesystem;

/// What parseTemperatureText says of `text` when it refuses it ("" when it takes it).
std::string refusal(std::string_view text, double scale = 1.0)
{
    const Result<double> c = parseTemperatureText(text, scale);
    return c.ok() ? std::string() : c.message();
}

TEST(PartTemperature, AFilesNumberIsReadInDegreesOrScaledFromMillidegrees)
{
    EXPECT_EQ(parseTemperatureText("21.5\n", 1.0).value(), 21.5);
    EXPECT_EQ(parseTemperatureText("  +23.25 \r\n", 1.0).value(), 23.25);
    EXPECT_EQ(parseTemperatureText("-5", 1.0).value(), -5.0);
    // A hwmon export: 23125 millidegrees.
    EXPECT_NEAR(parseTemperatureText("23125\n", 0.001).value(), 23.125, 1e-12);

    EXPECT_NE(refusal("").find("empty"), std::string::npos);
    EXPECT_NE(refusal(" \n").find("empty"), std::string::npos);
    EXPECT_NE(refusal("warm\n").find("not one number: 'warm'"), std::string::npos) << refusal("warm\n");
    EXPECT_NE(refusal("21.5 22.0").find("not one number: '21.5 22.0'"), std::string::npos);
    EXPECT_NE(refusal("21,5").find("not one number: '21,5'"), std::string::npos);
    EXPECT_NE(refusal("t=21500").find("not one number"), std::string::npos);
    EXPECT_NE(refusal("nan").find("not a finite number"), std::string::npos);
    EXPECT_NE(refusal("1e999").find("not one number"), std::string::npos);
    // Millidegrees read as degrees: 23125 °C, and the message says what to write.
    const std::string milli = refusal("23125\n");
    EXPECT_NE(milli.find("23125 °C, outside -100…200 °C"), std::string::npos) << milli;
    EXPECT_NE(milli.find("temperature.scale: 0.001"), std::string::npos) << milli;
}

TEST(PartTemperature, ThePlcSourcePassesTheLatchedReadingAndNoSectionGivesNone)
{
    hgtest::ManualClock clock;
    PartTemperature temperature(clock);
    EXPECT_FALSE(temperature.atTrigger(std::nullopt, 21.5));
    const station::TemperatureConfig plc;
    EXPECT_EQ(temperature.atTrigger(plc, 21.5), std::optional<double>(21.5));
    EXPECT_FALSE(temperature.atTrigger(plc, std::nullopt));
}

class SensorFile : public ::testing::Test {
  protected:
    SensorFile()
    {
        config_.source = station::TemperatureSource::File;
        config_.file = dir_ / "temp1_input";
        config_.scale = 0.001;
        config_.maxAge = 60s;
    }
    /// Writes `text` as last written `ago` before the clock's wall time.
    void write(const std::string& text, std::chrono::milliseconds ago = 0ms)
    {
        hgtest::writeFile(config_.file, text);
        fs::last_write_time(config_.file, std::chrono::file_clock::from_sys(clock_.wallNow() - ago));
    }
    std::optional<double> read() { return temperature_.atTrigger(config_, 99.0); }
    int warnings(std::string_view fragment) const { return log_.count(spdlog::level::warn, fragment); }

    hgtest::TempDir dir_;
    hgtest::ManualClock clock_;
    station::TemperatureConfig config_;
    hgtest::LogCapture log_{"inspect"};
    PartTemperature temperature_{clock_};
};

TEST_F(SensorFile, AMissingFileIsNoReadingWarnedOnceNamingIt)
{
    const std::string file = config_.file.string();
    EXPECT_FALSE(read());
    EXPECT_FALSE(read());
    EXPECT_EQ(warnings("temperature file " + file + ": cannot be read: No such file or directory"), 1) << log_.text();
    // Back: read (the PLC's value is not the file's), and the journal says so.
    write("21375\n");
    EXPECT_NEAR(read().value(), 21.375, 1e-12);
    EXPECT_EQ(log_.count(spdlog::level::info, "temperature readings from " + file + " again"), 1) << log_.text();
}

TEST_F(SensorFile, AFileThatIsNotOneNumberIsNoReadingWarnedNamingTheFileAndWhatWasWrong)
{
    write("t=21375\n");
    EXPECT_FALSE(read());
    EXPECT_EQ(warnings("temperature file " + config_.file.string() + ": not one number: 't=21375'"), 1) << log_.text();
    // Another problem is warned of in its turn.
    write("");
    EXPECT_FALSE(read());
    EXPECT_EQ(warnings(": empty"), 1) << log_.text();
    write(std::string(5000, '2'));
    EXPECT_FALSE(read());
    EXPECT_EQ(warnings("longer than 4096 bytes"), 1) << log_.text();
}

// max_age_s 60: written 60 s before the trigger it is read; a millisecond
// later it is stale (warned once however many parts come); written again, read.
TEST_F(SensorFile, AFileOlderThanItsMaximumAgeIsStaleUntilWrittenAgain)
{
    write("20500\n", 59'999ms);
    EXPECT_NEAR(read().value(), 20.5, 1e-12);
    clock_.advance(1ms);
    EXPECT_NEAR(read().value(), 20.5, 1e-12);
    clock_.advance(1ms);
    EXPECT_FALSE(read());
    clock_.advance(10min);
    EXPECT_FALSE(read());
    EXPECT_EQ(warnings("temperature file " + config_.file.string() + ": stale: last written 2026-03-02T07:59:00"), 1)
        << log_.text();
    EXPECT_EQ(warnings("longer ago than temperature.max_age_s (60 s)"), 1) << log_.text();
    write("20750\n");
    EXPECT_NEAR(read().value(), 20.75, 1e-12);
    // Without max_age_s a file is never stale (a hwmon file keeps its time stamp).
    config_.maxAge.reset();
    clock_.advance(24h);
    EXPECT_NEAR(read().value(), 20.75, 1e-12);
}

} // namespace
} // namespace hg::daemon
