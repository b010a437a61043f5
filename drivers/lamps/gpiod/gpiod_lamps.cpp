// Lamps on GPIO lines through libgpiod's v1.6 C API (Debian 12). Every libgpiod
// call of the product is in this file.
//
// Lines are found by name (gpiod_chip_find_line on `lamps.chip`, or
// gpiod_line_find over every chip when no chip is given) or by offset on
// `lamps.chip`, and requested as outputs with the ACTIVE_LOW flag where the
// configuration says so, so that "1" always means "lamp lit".
#include <gpiod.h>

#include <cerrno>
#include <cstring>
#include <vector>

#include "../backends.h"
#include "hullgauge/common/log.h"

namespace hg::drivers {
namespace {

std::string errnoText(int err)
{
    return std::strerror(err);
}

class GpiodLamps final : public Lamps {
  public:
    GpiodLamps(LampsConfig config, Clock& clock) : Lamps(std::move(config), clock) {}
    ~GpiodLamps() override
    {
        shutdown();
        release();
    }

    std::string_view backend() const override { return "gpiod"; }

  protected:
    Status openLines() override
    {
        const LampsConfig& c = config();
        if (!c.chip.empty()) {
            // Accepts a name (gpiochip0), a path (/dev/gpiochip0), a label or a number.
            chip_ = gpiod_chip_open_lookup(c.chip.c_str());
            if (!chip_)
                return Status::failure(StatusCode::IoError,
                                       c.key + ".chip: cannot open GPIO chip '" + c.chip + "': " + errnoText(errno));
        }
        for (std::size_t i = 0; i < lines_.size(); ++i) {
            const LampLine& want = c.lines[i];
            gpiod_line* line = nullptr;
            if (want.offset) {
                line = gpiod_chip_get_line(chip_, *want.offset);
                if (!line)
                    return Status::failure(StatusCode::IoError,
                                           want.key + ": GPIO chip '" + c.chip + "' has no line at offset " +
                                               std::to_string(*want.offset) + " (it has " +
                                               std::to_string(gpiod_chip_num_lines(chip_)) + " lines)");
            } else if (chip_) {
                line = gpiod_chip_find_line(chip_, want.name->c_str());
                if (!line)
                    return Status::failure(StatusCode::IoError, want.key + ": GPIO chip '" + c.chip +
                                                                    "' has no line named '" + *want.name + "'");
            } else {
                line = gpiod_line_find(want.name->c_str());
                if (!line)
                    return Status::failure(StatusCode::IoError,
                                           want.key + ": no GPIO chip has a line named '" + *want.name + "'" +
                                               (errno != ENOENT ? " (" + errnoText(errno) + ")" : std::string()));
                ownsChip_[i] = true;
            }
            lines_[i] = line;
            int flags = want.activeLow ? GPIOD_LINE_REQUEST_FLAG_ACTIVE_LOW : 0;
            if (gpiod_line_request_output_flags(line, c.consumer.c_str(), flags, 0) != 0) {
                int err = errno;
                const char* holder = gpiod_line_consumer(line);
                return Status::failure(StatusCode::IoError,
                                       want.key + ": cannot request " + want.describe() + " as an output: " +
                                           errnoText(err) + (holder ? std::string(" (held by '") + holder + "')" : ""));
            }
            requested_[i] = true;
        }
        return Status::success();
    }

    void closeLines() override { release(); }

    Status writeOutputs(const std::array<bool, 3>& lit) override
    {
        for (std::size_t i = 0; i < lines_.size(); ++i) {
            if (!requested_[i]) continue;
            if (gpiod_line_set_value(lines_[i], lit[i] ? 1 : 0) != 0)
                return Status::failure(StatusCode::IoError, config().lines[i].key + ": cannot set " +
                                                                config().lines[i].describe() + ": " + errnoText(errno));
        }
        return Status::success();
    }

  private:
    void release()
    {
        for (std::size_t i = 0; i < lines_.size(); ++i) {
            if (lines_[i] && requested_[i]) gpiod_line_release(lines_[i]);
            // A line found by gpiod_line_find() came with its own chip handle.
            if (lines_[i] && ownsChip_[i]) gpiod_line_close_chip(lines_[i]);
            lines_[i] = nullptr;
            requested_[i] = false;
            ownsChip_[i] = false;
        }
        if (chip_) gpiod_chip_close(chip_);
        chip_ = nullptr;
    }

    gpiod_chip* chip_ = nullptr;
    std::array<gpiod_line*, 3> lines_{};
    std::array<bool, 3> requested_{};
    std::array<bool, 3> ownsChip_{};
};

} // namespace

std::unique_ptr<Lamps> makeGpiodLamps(LampsConfig config, Clock& clock)
{
    return std::make_unique<GpiodLamps>(std::move(config), clock);
}

} // namespace hg::drivers
