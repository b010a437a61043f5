#include "hullgauge/common/format.h"

#include <sstream>

namespace hg {

std::string formatNumber(double v, int precision)
{
    std::ostringstream s;
    s.precision(precision);
    s << v;
    return s.str();
}

} // namespace hg
