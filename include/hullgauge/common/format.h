// The one way numbers are written into messages and reports: as a stream
// writes them with `precision` significant digits (6 by default: 0.125,
// 1e+300, 2448), so every message names a value the same way.
#pragma once

#include <string>

namespace hg {

std::string formatNumber(double v, int precision = 6);

} // namespace hg
