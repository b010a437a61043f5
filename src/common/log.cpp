#include "hullgauge/common/log.h"

#include <cstdlib>
#include <map>
#include <mutex>
#include <string>

#include <spdlog/sinks/stdout_color_sinks.h>

#include "hullgauge/common/error.h"

namespace hg::log {
namespace {

struct Registry {
    std::mutex mutex;
    spdlog::level::level_enum defaultLevel = spdlog::level::info;
    std::map<std::string, spdlog::level::level_enum, std::less<>> levels;
    spdlog::sink_ptr sink = std::make_shared<spdlog::sinks::stderr_color_sink_mt>();
    std::map<std::string, std::shared_ptr<spdlog::logger>, std::less<>> loggers;
    bool envApplied = false;
    std::string pattern = "%Y-%m-%d %H:%M:%S.%e %^%-5l%$ [%n] %v";
};

Registry& registry()
{
    static Registry r;
    return r;
}

spdlog::level::level_enum parseLevel(std::string_view spec, std::string_view name)
{
    auto level = spdlog::level::from_str(std::string(name));
    // from_str answers "off" for anything it does not know; only accept "off" when asked for.
    if (level == spdlog::level::off && name != "off")
        throw InputError("", "log level",
                         "unknown level '" + std::string(name) + "' in '" + std::string(spec) +
                             "' (trace, debug, info, warn, error, critical, off)");
    return level;
}

void applyLocked(Registry& r, std::string_view spec)
{
    std::size_t pos = 0;
    while (pos <= spec.size()) {
        auto comma = spec.find(',', pos);
        auto item = spec.substr(pos, comma == std::string_view::npos ? std::string_view::npos : comma - pos);
        if (!item.empty()) {
            auto eq = item.find('=');
            if (eq == std::string_view::npos) {
                r.defaultLevel = parseLevel(spec, item);
            } else {
                r.levels[std::string(item.substr(0, eq))] = parseLevel(spec, item.substr(eq + 1));
            }
        }
        if (comma == std::string_view::npos) break;
        pos = comma + 1;
    }
    for (auto& [name, logger] : r.loggers) {
        auto it = r.levels.find(name);
        logger->set_level(it != r.levels.end() ? it->second : r.defaultLevel);
    }
}

} // namespace

std::shared_ptr<spdlog::logger> category(std::string_view name)
{
    auto& r = registry();
    std::lock_guard lock(r.mutex);
    if (!r.envApplied) {
        r.envApplied = true;
        if (const char* env = std::getenv("HULLGAUGE_LOG")) {
            try {
                applyLocked(r, env);
            } catch (const InputError&) {
                // A bad environment variable must not stop the station; keep the defaults.
            }
        }
    }
    if (auto it = r.loggers.find(name); it != r.loggers.end()) return it->second;
    auto logger = std::make_shared<spdlog::logger>(std::string(name), r.sink);
    auto lv = r.levels.find(name);
    logger->set_level(lv != r.levels.end() ? lv->second : r.defaultLevel);
    logger->set_pattern(r.pattern);
    r.loggers.emplace(std::string(name), logger);
    return logger;
}

void configure(std::string_view spec)
{
    auto& r = registry();
    std::lock_guard lock(r.mutex);
    r.envApplied = true;
    applyLocked(r, spec);
}

void useJournal()
{
    // Under systemd stderr goes to the journal already; drop the timestamp,
    // which the journal records itself.
    auto& r = registry();
    std::lock_guard lock(r.mutex);
    r.pattern = "%-5l [%n] %v";
    for (auto& [name, logger] : r.loggers) logger->set_pattern(r.pattern);
}

} // namespace hg::log
