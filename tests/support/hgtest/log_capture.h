// Captures one log category (include/hullgauge/common/log.h) while alive, for
// tests that check what a component says.
#pragma once

#include <algorithm>
#include <memory>
#include <string>
#include <string_view>

#include <spdlog/sinks/ringbuffer_sink.h>

#include "hullgauge/common/log.h"

namespace hgtest {

class LogCapture {
  public:
    explicit LogCapture(std::string_view category, std::size_t lines = 64)
        : logger_(hg::log::category(category)), sink_(std::make_shared<spdlog::sinks::ringbuffer_sink_mt>(lines))
    {
        logger_->sinks().push_back(sink_);
    }
    ~LogCapture()
    {
        auto& sinks = logger_->sinks();
        sinks.erase(std::remove(sinks.begin(), sinks.end(), sink_), sinks.end());
    }
    LogCapture(const LogCapture&) = delete;
    LogCapture& operator=(const LogCapture&) = delete;

    /// Every line captured, formatted.
    std::string text() const
    {
        std::string all;
        for (const auto& line : sink_->last_formatted()) all += line;
        return all;
    }
    /// Lines at `level` that contain `fragment`.
    int count(spdlog::level::level_enum level, std::string_view fragment) const
    {
        int n = 0;
        for (const auto& m : sink_->last_raw())
            if (m.level == level &&
                std::string_view(m.payload.data(), m.payload.size()).find(fragment) != std::string_view::npos)
                ++n;
        return n;
    }

  private:
    std::shared_ptr<spdlog::logger> logger_;
    std::shared_ptr<spdlog::sinks::ringbuffer_sink_mt> sink_;
};

} // namespace hgtest
