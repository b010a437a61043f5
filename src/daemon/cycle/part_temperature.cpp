#include "cycle/part_temperature.h"

#include "hullgauge/common/log.h"
#include "hullgauge/store/result_reader.h"

#include <cerrno>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <spdlog/fmt/fmt.h>
#include <system_error>

namespace hg::daemon {
namespace {

namespace fs = std::filesystem;

/// A sensor file holds one number: more than this many bytes is something else.
constexpr std::size_t kMaxFileBytes = 4096;
/// The plausible temperatures of a part on a line (°C); beyond them the file is misread.
constexpr double kLowestC = -100.0;
constexpr double kHighestC = 200.0;

/// Up to 40 characters of `text` for a message, anything unprintable as '?'.
std::string shown(std::string_view text)
{
    std::string s(text.substr(0, 40));
    for (char& c : s)
        if (static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) > 0x7E) c = '?';
    return text.size() > 40 ? s + "…" : s;
}

std::int64_t unixMsOf(fs::file_time_type written)
{
    const auto sys = std::chrono::file_clock::to_sys(written);
    return std::chrono::duration_cast<std::chrono::milliseconds>(sys.time_since_epoch()).count();
}

} // namespace

Result<double> parseTemperatureText(std::string_view text, double scale)
{
    constexpr std::string_view blanks = " \t\r\n";
    const auto first = text.find_first_not_of(blanks);
    if (first == std::string_view::npos) return Status::failure("empty: no number in it");
    const std::string_view number = text.substr(first, text.find_last_not_of(blanks) - first + 1);
    std::string_view digits = number;
    // from_chars takes a minus sign, not a plus.
    if (digits.front() == '+') digits.remove_prefix(1);
    double value = 0.0;
    const char* end = digits.data() + digits.size();
    const auto [stop, error] = std::from_chars(digits.data(), end, value);
    if (error != std::errc() || stop != end) return Status::failure("not one number: '" + shown(number) + "'");
    if (!std::isfinite(value)) return Status::failure("not a finite number: '" + shown(number) + "'");
    const double c = value * scale;
    if (c < kLowestC || c > kHighestC)
        return Status::failure(
            fmt::format("'{}' is {:g} °C, outside {:g}…{:g} °C{}", shown(number), c, kLowestC, kHighestC,
                        scale == 1.0 ? " (a file in millidegrees needs temperature.scale: 0.001)" : ""));
    return c;
}

Result<double> readTemperatureFile(const station::TemperatureConfig& config, const Clock& clock)
{
    const std::string name = "temperature file " + config.file.string();
    std::error_code ec;
    const auto written = fs::last_write_time(config.file, ec);
    if (ec) return Status::failure(name + ": cannot be read: " + ec.message());
    // The time stamp is the file's wall time: compared with the station's wall time (docs/daemon.md).
    if (config.maxAge && clock.wallMs() - unixMsOf(written) > config.maxAge->count())
        return Status::failure(fmt::format("{}: stale: last written {}, longer ago than temperature.max_age_s ({:g} s)",
                                           name, store::formatUtc(unixMsOf(written)),
                                           static_cast<double>(config.maxAge->count()) / 1000.0));
    std::ifstream in(config.file, std::ios::binary);
    if (!in) return Status::failure(name + ": cannot be read: " + std::generic_category().message(errno));
    std::string text(kMaxFileBytes + 1, '\0');
    in.read(text.data(), static_cast<std::streamsize>(text.size()));
    if (in.bad()) return Status::failure(name + ": cannot be read: " + std::generic_category().message(errno));
    text.resize(static_cast<std::size_t>(in.gcount()));
    if (text.size() > kMaxFileBytes)
        return Status::failure(fmt::format("{}: longer than {} bytes: not one number", name, kMaxFileBytes));
    Result<double> c = parseTemperatureText(text, config.scale);
    if (!c.ok()) return Status::failure(name + ": " + c.message());
    return c;
}

std::optional<double> PartTemperature::atTrigger(const std::optional<station::TemperatureConfig>& config,
                                                 std::optional<double> plcC)
{
    if (!config) return std::nullopt;
    // The PLC says "no reading" with 0x8000 on purpose (docs/plc.md): nothing to warn of.
    if (config->source == station::TemperatureSource::Plc) return plcC;
    auto log = hg::log::category("inspect");
    const Result<double> c = readTemperatureFile(*config, *clock_);
    if (c.ok()) {
        if (!lastProblem_.empty()) log->info("temperature readings from {} again", config->file.string());
        lastProblem_.clear();
        return c.value();
    }
    if (c.message() != lastProblem_)
        log->warn("{}: parts are judged without a temperature (not referred to 20 °C, recorded without one) "
                  "until it is read again",
                  c.message());
    lastProblem_ = c.message();
    return std::nullopt;
}

} // namespace hg::daemon
