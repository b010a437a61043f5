#include "hullgauge/plan/pose_space.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>

namespace hg::plan {

namespace {

constexpr double kPi = 3.14159265358979323846;

// Solutions in [lo, hi] (degrees) of a cos t + b sin t = c, t in degrees.
// Exact: with r = hypot(a, b) and φ = atan2(b, a), t = φ ± acos(c / r). A
// vanishing (a, b) means the condition does not depend on t: every t solves
// it when c vanishes too, signalled by `allValues`.
std::vector<double> solveTrig(double a, double b, double c, double lo, double hi, double scale, bool& allValues)
{
    allValues = false;
    std::vector<double> out;
    const double r = std::hypot(a, b);
    // `scale` is the size of the coordinates involved; below 1e-9 of it the
    // coefficients are rounding noise.
    if (r <= 1e-9 * scale) {
        allValues = std::abs(c) <= 1e-9 * scale;
        return out;
    }
    if (std::abs(c) > r) return out;
    const double phi = std::atan2(b, a);
    const double delta = std::acos(std::clamp(c / r, -1.0, 1.0));
    for (double t : {phi + delta, phi - delta}) {
        const double deg = t * 180.0 / kPi;
        for (int k = -2; k <= 2; ++k) {
            const double v = deg + 360.0 * k;
            if (v >= lo - 1e-9 && v <= hi + 1e-9) out.push_back(std::clamp(v, lo, hi));
        }
    }
    return out;
}

void addUnique(std::vector<FixturePose>& poses, const FixturePose& p)
{
    for (const auto& q : poses)
        if (std::abs(q.rotationDeg - p.rotationDeg) < 1e-9 && std::abs(q.declinationDeg - p.declinationDeg) < 1e-9 &&
            std::abs(q.railMm - p.railMm) < 1e-9)
            return;
    poses.push_back(p);
}

} // namespace

std::vector<double> gridValues(double lo, double hi, double step)
{
    std::vector<double> v;
    if (hi < lo) return v;
    if (step <= 0.0 || hi - lo < 1e-12) return {lo};
    const auto n = static_cast<long>(std::floor((hi - lo) / step + 1e-9));
    double last = lo;
    for (long i = 0; i <= n; ++i) {
        last = lo + static_cast<double>(i) * step;
        v.push_back(last);
    }
    if (hi - last > 1e-9) v.push_back(hi);
    return v;
}

std::vector<FixturePose> gridPoses(const FixtureKinematics& fixture, const PoseGrid& grid)
{
    std::vector<FixturePose> poses;
    if (fixture.type == FixtureType::Rail) {
        for (double s : gridValues(fixture.railRangeMm.min, fixture.railRangeMm.max, grid.railStepMm))
            poses.push_back({0.0, 0.0, s});
        return poses;
    }
    const auto& rr = fixture.rotationRangeDeg;
    // A full turn's two ends are the same pose: keep one.
    const bool fullTurn = rr.max - rr.min >= 360.0 - 1e-9;
    auto rotations = gridValues(rr.min, rr.max, grid.rotationStepDeg);
    if (fullTurn && rotations.size() > 1 && std::abs(rotations.back() - rotations.front() - 360.0) < 1e-9)
        rotations.pop_back();
    for (double d :
         gridValues(fixture.declinationRangeDeg.min, fixture.declinationRangeDeg.max, grid.declinationStepDeg))
        for (double r : rotations) poses.push_back({r, d, 0.0});
    return poses;
}

std::vector<FixturePose> grazingPoses(const FixtureKinematics& fixture, const Vec3& point, const Vec3& normal,
                                      const PoseGrid& grid)
{
    const Vec3 n = normal.normalized();
    // The line of sight grazes the tangent plane where n·g(pose) = target:
    // g the camera centre and target n·point for a pinhole; for a telecentric
    // camera g its optical axis and target 0 (docs/telecentric.md). Either g
    // is affine in the rail and A cos t + B sin t + E in either angle.
    const bool parallel = fixture.cameraProjection == geometry::Projection::Telecentric;
    const double target = parallel ? 0.0 : n.dot(point);
    auto sightAt = [&](const FixturePose& pose) {
        const geometry::SightLines s = fixture.sightLinesAt(pose);
        return parallel ? s.axis : s.centre;
    };
    std::vector<FixturePose> poses;
    const double scale = parallel ? 1.0 : std::max({1.0, fixture.cameraCentreInPart({}).norm(), point.norm()});

    if (fixture.type == FixtureType::Rail) {
        // n·g(s) is affine in s.
        const double f0 = n.dot(sightAt({0.0, 0.0, 0.0}));
        const double f1 = n.dot(sightAt({0.0, 0.0, 1.0}));
        if (std::abs(f1 - f0) <= 1e-12 * scale) {
            if (std::abs(f0 - target) <= 1e-9 * scale)
                for (double s : gridValues(fixture.railRangeMm.min, fixture.railRangeMm.max, grid.railStepMm))
                    poses.push_back({0.0, 0.0, s});
            return poses;
        }
        const double s = (target - f0) / (f1 - f0);
        if (fixture.railRangeMm.contains(s))
            poses.push_back({0.0, 0.0, std::clamp(s, fixture.railRangeMm.min, fixture.railRangeMm.max)});
        return poses;
    }

    // f(t) = n·g is A cos t + B sin t + E in either angle with the other fixed;
    // three evaluations give A, B, E exactly (whatever the axes' conventions).
    auto coefficients = [&](auto&& centreAt) {
        const double f0 = n.dot(centreAt(0.0));
        const double f90 = n.dot(centreAt(90.0));
        const double f180 = n.dot(centreAt(180.0));
        const double e = 0.5 * (f0 + f180);
        return std::array<double, 3>{0.5 * (f0 - f180), f90 - e, e};
    };

    const auto& rr = fixture.rotationRangeDeg;
    const auto& dr = fixture.declinationRangeDeg;
    const auto declinations = gridValues(dr.min, dr.max, grid.declinationStepDeg);
    const auto rotations = gridValues(rr.min, rr.max, grid.rotationStepDeg);
    auto solveAt = declinations;
    for (double d : grid.extraDeclinationsDeg)
        if (dr.contains(d)) solveAt.push_back(d);
    for (double d : solveAt) {
        auto [a, b, e] = coefficients([&](double r) { return sightAt({r, d, 0.0}); });
        bool all = false;
        for (double r : solveTrig(a, b, target - e, rr.min, rr.max, scale, all)) addUnique(poses, {r, d, 0.0});
        if (all)
            for (double r : rotations) addUnique(poses, {r, d, 0.0});
    }
    for (double r : rotations) {
        auto [a, b, e] = coefficients([&](double d) { return sightAt({r, d, 0.0}); });
        bool all = false;
        for (double d : solveTrig(a, b, target - e, dr.min, dr.max, scale, all)) addUnique(poses, {r, d, 0.0});
        if (all)
            for (double d : declinations) addUnique(poses, {r, d, 0.0});
    }
    return poses;
}

double travelDistance(const FixturePose& a, const FixturePose& b, FixtureType type)
{
    if (type == FixtureType::Rail) return std::abs(a.railMm - b.railMm);
    return std::max(std::abs(a.rotationDeg - b.rotationDeg), std::abs(a.declinationDeg - b.declinationDeg));
}

namespace {

/// Least-cost path from node 0 (the start) through every other node of
/// `cost` (symmetric, cost[i][j] the move between nodes i and j); returns
/// the nodes after the start, each less one: the pose indices. Exact over
/// all orders for up to 8 poses (at most 40320), nearest neighbour then 2-opt
/// (reversing a stretch) until no improvement beyond.
std::vector<std::size_t> shortestPath(const std::vector<std::vector<double>>& cost)
{
    const std::size_t n = cost.size() - 1;
    std::vector<std::size_t> order(n);
    std::iota(order.begin(), order.end(), 0);
    if (n < 2) return order;
    auto length = [&](const std::vector<std::size_t>& o) {
        double sum = cost[0][o[0] + 1];
        for (std::size_t i = 1; i < o.size(); ++i) sum += cost[o[i - 1] + 1][o[i] + 1];
        return sum;
    };
    if (n <= 8) {
        auto best = order;
        double bestLength = length(order);
        while (std::next_permutation(order.begin(), order.end())) {
            const double l = length(order);
            if (l < bestLength - 1e-12) {
                bestLength = l;
                best = order;
            }
        }
        return best;
    }
    std::vector<bool> used(n, false);
    order.clear();
    std::size_t at = 0; // node index
    for (std::size_t k = 0; k < n; ++k) {
        std::size_t best = n;
        double bestCost = std::numeric_limits<double>::infinity();
        for (std::size_t i = 0; i < n; ++i)
            if (!used[i] && cost[at][i + 1] < bestCost) {
                bestCost = cost[at][i + 1];
                best = i;
            }
        used[best] = true;
        order.push_back(best);
        at = best + 1;
    }
    double current = length(order);
    for (bool improved = true; improved;) {
        improved = false;
        for (std::size_t i = 0; i + 1 < n; ++i)
            for (std::size_t j = i + 1; j < n; ++j) {
                std::reverse(order.begin() + static_cast<long>(i), order.begin() + static_cast<long>(j) + 1);
                const double l = length(order);
                if (l < current - 1e-9) {
                    current = l;
                    improved = true;
                } else {
                    std::reverse(order.begin() + static_cast<long>(i), order.begin() + static_cast<long>(j) + 1);
                }
            }
    }
    return order;
}

/// The cost of every move between the start (node 0) and the poses (nodes 1..n).
template <typename Cost>
std::vector<std::vector<double>> costMatrix(const std::vector<FixturePose>& poses, const FixturePose& start, Cost move)
{
    std::vector<FixturePose> nodes{start};
    nodes.insert(nodes.end(), poses.begin(), poses.end());
    std::vector<std::vector<double>> cost(nodes.size(), std::vector<double>(nodes.size(), 0.0));
    for (std::size_t i = 0; i < nodes.size(); ++i)
        for (std::size_t j = 0; j < nodes.size(); ++j)
            if (i != j) cost[i][j] = move(nodes[i], nodes[j]);
    return cost;
}

} // namespace

std::vector<std::size_t> orderForTravel(const std::vector<FixturePose>& poses, FixtureType type,
                                        const FixturePose& start)
{
    return shortestPath(costMatrix(
        poses, start, [type](const FixturePose& a, const FixturePose& b) { return travelDistance(a, b, type); }));
}

std::vector<std::size_t> orderForTime(const std::vector<FixturePose>& poses, const geometry::FixtureMotion& motion,
                                      const FixturePose& start)
{
    return shortestPath(costMatrix(
        poses, start, [&motion](const FixturePose& a, const FixturePose& b) { return motion.moveSeconds(a, b); }));
}

FixturePose homePose(const FixtureKinematics& fixture)
{
    FixturePose p;
    if (fixture.type == FixtureType::Rail)
        p.railMm = std::clamp(0.0, fixture.railRangeMm.min, fixture.railRangeMm.max);
    else {
        p.rotationDeg = std::clamp(0.0, fixture.rotationRangeDeg.min, fixture.rotationRangeDeg.max);
        p.declinationDeg = std::clamp(0.0, fixture.declinationRangeDeg.min, fixture.declinationRangeDeg.max);
    }
    return p;
}

} // namespace hg::plan
