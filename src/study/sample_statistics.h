// The sample mean and standard deviation the gauge studies (docs/study.md)
// and the SPC charts (docs/spc.md) share; private to src/study.
#pragma once

#include <cmath>
#include <cstddef>
#include <span>

namespace hg::study {

/// The mean, summed relative to the first value: n equal values give that value
/// exactly (and a spread of exactly 0 below). `v` must not be empty.
inline double mean(std::span<const double> v)
{
    double sum = 0.0;
    for (double x : v) sum += x - v.front();
    return v.front() + sum / static_cast<double>(v.size());
}

/// Sample standard deviation (n − 1), two passes relative to the first value;
/// `m` is mean(v). `v` must hold at least 2 values.
inline double sampleStddev(std::span<const double> v, double m)
{
    const double offset = m - v.front();
    double ss = 0.0;
    for (double x : v) ss += (x - v.front() - offset) * (x - v.front() - offset);
    return std::sqrt(ss / static_cast<double>(v.size() - 1));
}

} // namespace hg::study
