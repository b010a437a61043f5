#include "hullgauge/common/status.h"

#include <array>

namespace hg {

std::string_view toString(StatusCode code)
{
    constexpr std::array<std::string_view, 8> names{"ok",        "timeout",     "fault",     "communication error",
                                                    "i/o error", "not allowed", "bad frame", "error"};
    return names[static_cast<std::size_t>(code)];
}

} // namespace hg
