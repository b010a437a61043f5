#include "hullgauge/inspect/measures.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace hg::inspect {

ViewDiscrimination viewDiscrimination(const geometry::CameraModel& camera, const Eigen::Vector3d& landmark)
{
    ViewDiscrimination v;
    v.distanceMm = camera.rangeTo(landmark);
    const double cosTheta = std::clamp(camera.lineOfSight(landmark).dot(camera.opticalAxis()), -1.0, 1.0);
    v.thetaDeg = geometry::radToDeg(std::acos(cosTheta));
    const auto px = camera.project(landmark);
    const cv::Size size = camera.imageSize();
    v.observes = px && px->x() >= -0.5 && px->y() >= -0.5 && px->x() < size.width - 0.5 && px->y() < size.height - 0.5;
    // m: the coarser pixel side at the landmark (mm); invF = 1/f, which a
    // telecentric camera's parallel lines of sight take to zero.
    const auto& K = camera.intrinsics().K;
    const double f = std::min(K(0, 0), K(1, 1));
    const double m = camera.isTelecentric() ? 1.0 / f : v.distanceMm / f;
    const double invF = camera.isTelecentric() ? 0.0 : 1.0 / f;
    v.medRangeMm = std::sqrt(2.0) * m / (1.5 + invF);
    const double sinTheta = std::sqrt(std::max(0.0, 1.0 - cosTheta * cosTheta));
    const double denom = 2.0 * (cosTheta - sinTheta) + invF;
    v.medAngleMm = (cosTheta > sinTheta && denom > 0.0) ? 2.0 * std::sqrt(2.0) * m * cosTheta / denom
                                                        : std::numeric_limits<double>::infinity();
    return v;
}

Bracket distanceBracket(const LandmarkEstimate& a, const LandmarkEstimate& b)
{
    // |u + s·na − t·nb| over the box (s, t) in [a.sLow, a.sHigh] x [b.sLow, b.sHigh]:
    // convex, so the maximum is at a corner and the minimum of its square (a
    // convex quadratic) is the unconstrained minimum if inside, else on an edge.
    const Eigen::Vector3d u = a.position - b.position;
    auto dist = [&](double s, double t) { return (u + s * a.normal - t * b.normal).norm(); };
    const double s0 = a.sLow, s1 = a.sHigh, t0 = b.sLow, t1 = b.sHigh;
    Bracket r;
    r.max = std::max({dist(s0, t0), dist(s0, t1), dist(s1, t0), dist(s1, t1)});
    auto bestS = [&](double t) { // argmin over s of |u − t nb + s na|
        const double na2 = a.normal.squaredNorm();
        return std::clamp(-(u - t * b.normal).dot(a.normal) / na2, s0, s1);
    };
    auto bestT = [&](double s) {
        const double nb2 = b.normal.squaredNorm();
        return std::clamp((u + s * a.normal).dot(b.normal) / nb2, t0, t1);
    };
    double best = std::min({dist(bestS(t0), t0), dist(bestS(t1), t1), dist(s0, bestT(s0)), dist(s1, bestT(s1))});
    // Interior stationary point of the quadratic, when the directions are not parallel.
    const double A = a.normal.dot(a.normal), B = -a.normal.dot(b.normal), C = b.normal.dot(b.normal);
    const double det = A * C - B * B;
    if (det > 1e-12) {
        const double gs = u.dot(a.normal), gt = -u.dot(b.normal);
        const double s = (-C * gs + B * gt) / det, t = (B * gs - A * gt) / det;
        if (s >= s0 && s <= s1 && t >= t0 && t <= t1) best = std::min(best, dist(s, t));
    }
    r.min = best;
    return r;
}

Bracket perimeterBracket(const std::vector<LandmarkEstimate>& ring)
{
    Bracket r;
    for (std::size_t i = 0; i < ring.size(); ++i) {
        const Bracket e = distanceBracket(ring[i], ring[(i + 1) % ring.size()]);
        r.min += e.min;
        r.max += e.max;
    }
    return r;
}

namespace {

struct Interval {
    double lo, hi;
    Interval operator+(const Interval& o) const { return {lo + o.lo, hi + o.hi}; }
    Interval operator-(const Interval& o) const { return {lo - o.hi, hi - o.lo}; }
    Interval operator*(const Interval& o) const
    {
        const double a = lo * o.lo, b = lo * o.hi, c = hi * o.lo, d = hi * o.hi;
        return {std::min({a, b, c, d}), std::max({a, b, c, d})};
    }
};

} // namespace

Bracket areaBracket(const std::vector<LandmarkEstimate>& ring)
{
    const std::size_t n = ring.size();
    if (n < 3) return {};
    // Plane of the nominal polygon: Newell's normal, centroid origin.
    Eigen::Vector3d normal = Eigen::Vector3d::Zero(), centroid = Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < n; ++i) {
        const Eigen::Vector3d& p = ring[i].position;
        const Eigen::Vector3d& q = ring[(i + 1) % n].position;
        normal += Eigen::Vector3d((p.y() - q.y()) * (p.z() + q.z()), (p.z() - q.z()) * (p.x() + q.x()),
                                  (p.x() - q.x()) * (p.y() + q.y()));
        centroid += p / static_cast<double>(n);
    }
    if (normal.norm() <= 0.0) return {};
    normal.normalize();
    const Eigen::Vector3d e1 = normal.unitOrthogonal(), e2 = normal.cross(e1);
    std::vector<Eigen::Vector2d> p0(n), d(n);
    for (std::size_t i = 0; i < n; ++i) {
        const Eigen::Vector3d r = ring[i].position - centroid;
        p0[i] = {r.dot(e1), r.dot(e2)};
        d[i] = {ring[i].normal.dot(e1), ring[i].normal.dot(e2)};
    }
    // The signed shoelace area is positive for the nominal orientation (Newell).
    auto area = [&](const std::vector<double>& s) {
        double a = 0.0;
        for (std::size_t i = 0; i < n; ++i) {
            const std::size_t j = (i + 1) % n;
            const Eigen::Vector2d qi = p0[i] + s[i] * d[i], qj = p0[j] + s[j] * d[j];
            a += qi.x() * qj.y() - qj.x() * qi.y();
        }
        return 0.5 * a;
    };
    Bracket r{std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()};
    if (n <= 16) {
        std::vector<double> s(n);
        for (std::uint32_t mask = 0; mask < (1u << n); ++mask) {
            for (std::size_t i = 0; i < n; ++i) s[i] = (mask >> i & 1u) ? ring[i].sHigh : ring[i].sLow;
            const double a = area(s);
            r.min = std::min(r.min, a);
            r.max = std::max(r.max, a);
        }
        return r;
    }
    Interval total{0.0, 0.0};
    for (std::size_t i = 0; i < n; ++i) {
        const std::size_t j = (i + 1) % n;
        auto coord = [&](std::size_t k, int axis) {
            const double a = p0[k][axis] + ring[k].sLow * d[k][axis], b = p0[k][axis] + ring[k].sHigh * d[k][axis];
            return Interval{std::min(a, b), std::max(a, b)};
        };
        total = total + (coord(i, 0) * coord(j, 1) - coord(j, 0) * coord(i, 1));
    }
    return {0.5 * total.lo, 0.5 * total.hi};
}

} // namespace hg::inspect
