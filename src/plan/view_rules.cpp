#include "hullgauge/plan/view_rules.h"

#include "hullgauge/inspect/measures.h"
#include "hullgauge/inspect/voxel_test.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <sstream>

namespace hg::plan {

namespace {

constexpr double kSqrt2 = 1.41421356237309504880;

// True when p lies inside the convex, counter-clockwise (in pixel
// coordinates, either orientation accepted) polygon.
bool insideConvex(const std::vector<geometry::Vec2>& poly, const geometry::Vec2& p)
{
    int sign = 0;
    for (std::size_t i = 0; i < poly.size(); ++i) {
        const auto& a = poly[i];
        const auto& b = poly[(i + 1) % poly.size()];
        const double cross = (b.x() - a.x()) * (p.y() - a.y()) - (b.y() - a.y()) * (p.x() - a.x());
        if (cross == 0.0) continue;
        const int s = cross > 0.0 ? 1 : -1;
        if (sign == 0)
            sign = s;
        else if (s != sign)
            return false;
    }
    return true;
}

std::array<Vec3, 8> corners(const Eigen::AlignedBox3d& box)
{
    std::array<Vec3, 8> c;
    for (int i = 0; i < 8; ++i)
        c[static_cast<std::size_t>(i)] = box.corner(static_cast<Eigen::AlignedBox3d::CornerType>(i));
    return c;
}

/// True when the line of sight crosses `voxel` inside the part: the sample
/// then belongs to the object share of the voxel's own footprint (a voxel
/// straddling the surface is part object), and meeting the part is expected
/// wherever along the line it is met — on a grazing view of a long face the
/// line enters the face far before the landmark. Judged at the middle of the
/// line's chord through the voxel (slab intersection).
bool throughOwnMaterial(const Eigen::AlignedBox3d& voxel, const Vec3& origin, const Vec3& direction,
                        const model::Solid& solid)
{
    double t0 = 0.0, t1 = std::numeric_limits<double>::infinity();
    for (int a = 0; a < 3; ++a) {
        if (std::abs(direction[a]) < 1e-15) {
            if (origin[a] < voxel.min()[a] || origin[a] > voxel.max()[a]) return false;
            continue;
        }
        double ta = (voxel.min()[a] - origin[a]) / direction[a];
        double tb = (voxel.max()[a] - origin[a]) / direction[a];
        if (ta > tb) std::swap(ta, tb);
        t0 = std::max(t0, ta);
        t1 = std::min(t1, tb);
    }
    if (t1 <= t0) return false;
    return solid.contains(origin + 0.5 * (t0 + t1) * direction);
}

} // namespace

std::string RuleCheck::failure() const
{
    std::ostringstream s;
    if (!inFrame)
        s << "the landmark's neighbourhood is not wholly in the image";
    else if (!rule2) {
        s << "Rule 2: the line of sight meets " << enumName(obstruction);
        if (blockingTriangle)
            s << " (triangle " << *blockingTriangle << " at " << blockingPoint.x() << ", " << blockingPoint.y() << ", "
              << blockingPoint.z() << ")";
    } else if (!rule1)
        s << "Rule 1: only " << static_cast<int>(std::round(100.0 * backgroundFraction))
          << " % of the void neighbour's projection is background (50 % needed)";
    else if (!inDepthOfField)
        s << "Rule 4: depth " << depthMm << " mm outside the depth of field";
    else if (!inTelecentricField)
        s << "Rule 4: " << offAxisMm << " mm from the optical axis, outside the lens's telecentric field";
    else if (!rule3)
        s << "Rule 3: predicted MED " << predictedMedMm << " mm (eq. 5.3.6-3) or range MED " << rangeMedMm
          << " mm (eq. 4.4.4-19) too coarse";
    return s.str();
}

double predictedMedMm(double focalPx, double distanceMm, double thetaRad)
{
    const double c = std::cos(thetaRad);
    const double s = std::sin(thetaRad);
    if (c - s <= 0.0) return std::numeric_limits<double>::infinity();
    return 2.0 * kSqrt2 * distanceMm * c / (2.0 * focalPx * (c - s) + 1.0);
}

double telecentricMedMm(double mmPerPx, double thetaRad)
{
    const double c = std::cos(thetaRad);
    const double s = std::sin(thetaRad);
    if (c - s <= 0.0) return std::numeric_limits<double>::infinity();
    return kSqrt2 * mmPerPx * c / (c - s);
}

namespace {

/// The largest θ with medAt(θ) <= medMm: the MED grows monotonically with θ
/// on [0, π/4) and diverges at π/4.
template <typename MedAt> double largestAngleWithin(MedAt medAt, double medMm)
{
    if (medAt(0.0) > medMm) return 0.0;
    double lo = 0.0;
    double hi = 0.25 * 3.14159265358979323846;
    for (int i = 0; i < 60; ++i) {
        const double mid = 0.5 * (lo + hi);
        (medAt(mid) <= medMm ? lo : hi) = mid;
    }
    return lo;
}

} // namespace

double maxViewAngleRad(double focalPx, double distanceMm, double medMm)
{
    return largestAngleWithin([&](double theta) { return predictedMedMm(focalPx, distanceMm, theta); }, medMm);
}

double maxTelecentricViewAngleRad(double mmPerPx, double medMm)
{
    return largestAngleWithin([&](double theta) { return telecentricMedMm(mmPerPx, theta); }, medMm);
}

ViewRules::ViewRules(const model::Solid& solid, const geometry::Station& station, double voxelSizeMm,
                     RuleOptions options)
    : solid_(solid), station_(station), voxelSize_(voxelSizeMm), options_(options)
{
    options_.samplesPerSide = std::max(2, options_.samplesPerSide);
    if (options_.floorRadiusMm) {
        floorRadius_ = *options_.floorRadiusMm;
    } else {
        for (const auto& v : solid.mesh().vertices) floorRadius_ = std::max(floorRadius_, std::hypot(v.x(), v.y()));
    }
    ownRadius_ = options_.ownSurfaceRadiusMm.value_or(3.0 * voxelSizeMm);
}

Blocker ViewRules::lineOfSight(const Vec3& origin, const Vec3& direction, std::optional<model::RayHit>* hit) const
{
    const double floorZ = station_.floorZMm;
    if (origin.z() < floorZ) return Blocker::CameraBelowFloor;
    auto partHit = solid_.firstHit(origin, direction);
    // The floor and the fixture under it: the region z < floor_z within
    // floorRadius_ of the turntable axis (the part frame's z axis). The line
    // of sight meets it where its stretch below the floor plane overlaps its
    // stretch inside that cylinder.
    constexpr double kInf = std::numeric_limits<double>::infinity();
    double floorDistance = kInf;
    double below0 = kInf, below1 = kInf; // stretch with z < floor_z
    if (direction.z() < 0.0) {
        below0 = std::max(0.0, (floorZ - origin.z()) / direction.z());
    } else if (origin.z() < floorZ) { // cannot happen (checked above); kept for clarity
        below0 = 0.0;
        below1 = direction.z() > 0.0 ? (floorZ - origin.z()) / direction.z() : kInf;
    }
    if (std::isfinite(below0)) {
        const double a = direction.x() * direction.x() + direction.y() * direction.y();
        const double b = 2.0 * (origin.x() * direction.x() + origin.y() * direction.y());
        const double c = origin.x() * origin.x() + origin.y() * origin.y() - floorRadius_ * floorRadius_;
        double in0 = kInf, in1 = -kInf; // stretch within the cylinder
        if (a < 1e-18) {
            if (c <= 0.0) {
                in0 = 0.0;
                in1 = kInf;
            }
        } else {
            const double disc = b * b - 4.0 * a * c;
            if (disc >= 0.0) {
                in0 = (-b - std::sqrt(disc)) / (2.0 * a);
                in1 = (-b + std::sqrt(disc)) / (2.0 * a);
            }
        }
        const double lo = std::max(below0, in0);
        const double hi = std::min(below1, in1);
        if (lo <= hi && hi >= 0.0) floorDistance = std::max(lo, 0.0);
    }
    if (partHit && partHit->distance <= floorDistance) {
        if (hit) *hit = partHit;
        return Blocker::Part;
    }
    if (std::isfinite(floorDistance)) return Blocker::Floor;
    return Blocker::None;
}

RuleCheck ViewRules::check(const LandmarkTarget& target, const FixturePose& pose) const
{
    return check(target, station_.cameraAt(pose));
}

RuleCheck ViewRules::check(const LandmarkTarget& target, const geometry::CameraModel& camera) const
{
    return evaluate(&target, target.witnessVoxel, camera, true);
}

bool ViewRules::provenVoid(const Eigen::AlignedBox3d& voxel, const geometry::CameraModel& camera) const
{
    auto r = evaluate(nullptr, voxel, camera, true);
    return r.inFrame && r.rule1;
}

RuleCheck ViewRules::evaluate(const LandmarkTarget* target, const Eigen::AlignedBox3d& voxel,
                              const geometry::CameraModel& camera, bool stopAtDecision) const
{
    RuleCheck r;

    // Rules 3 and 4 need only the landmark's position: evaluate them first (cheap).
    if (target) {
        r.distanceMm = camera.rangeTo(target->position);
        r.depthMm = camera.depthOf(target->position);
        const double cosTheta = std::clamp(camera.lineOfSight(target->position).dot(camera.opticalAxis()), -1.0, 1.0);
        r.viewAngleDeg = geometry::radToDeg(std::acos(cosTheta));
        // The inspection engine's measures of this view (inspect/measures.h):
        // eq. 4.4.5-11 is eq. 5.3.6-3 solved for the MED, and eq. 4.4.4-19 is
        // the resolution the engine demands of an observing view (MED <= ΔV).
        const auto disc = inspect::viewDiscrimination(camera, target->position);
        r.predictedMedMm = disc.medAngleMm;
        r.rangeMedMm = disc.medRangeMm;
        r.rule3 = r.predictedMedMm <= target->toleranceMm + 1e-12 &&
                  (!options_.requireVoxelResolution || r.rangeMedMm <= voxelSize_ + 1e-12);
        // Rule 4 is the lens's sharp volume: the depth of field, and for a
        // telecentric lens the field it is telecentric over (docs/telecentric.md).
        r.offAxisMm = camera.cameraFromPart().apply(target->position).head<2>().norm();
        r.inDepthOfField = !station_.depthOfFieldMm || station_.depthOfFieldMm->contains(r.depthMm, 1e-9);
        r.inTelecentricField = !station_.telecentricFieldMm || 2.0 * r.offAxisMm <= *station_.telecentricFieldMm + 1e-9;
        r.rule4 = r.inDepthOfField && r.inTelecentricField;
    } else {
        r.rule3 = r.rule4 = true;
    }

    // The footprint: hull of the 8 projected corners, inside the image.
    std::vector<geometry::Vec2> projected;
    projected.reserve(8);
    for (const auto& c : corners(voxel)) {
        auto p = camera.project(c);
        if (!p) return r;
        projected.push_back(*p);
    }
    const auto hull = inspect::convexHull(projected);
    if (hull.size() < 3) return r;
    const double margin = options_.imageMarginPx;
    const auto size = camera.imageSize();
    geometry::Vec2 lo = hull.front(), hi = hull.front();
    for (const auto& p : hull) {
        lo = lo.cwiseMin(p);
        hi = hi.cwiseMax(p);
    }
    if (lo.x() < -0.5 + margin || lo.y() < -0.5 + margin || hi.x() > size.width - 0.5 - margin ||
        hi.y() > size.height - 0.5 - margin)
        return r;
    r.inFrame = true;
    // Rules 1 and 2 are judged even where Rule 4 fails: a landmark seen
    // against background only outside the lens's sharp volume is refused for
    // that reason, not taken for a concavity (planner.cpp, WitnessSearch).

    // Sample points: cell centres of a grid over the hull's bounding box that
    // fall inside the hull; a thin footprint gets a finer grid so that at
    // least n²/2 samples land inside.
    std::vector<geometry::Vec2> samples;
    const int n = options_.samplesPerSide;
    for (int res = n; res <= 8 * n; res *= 2) {
        samples.clear();
        for (int i = 0; i < res; ++i)
            for (int j = 0; j < res; ++j) {
                const geometry::Vec2 p(lo.x() + (hi.x() - lo.x()) * (i + 0.5) / res,
                                       lo.y() + (hi.y() - lo.y()) * (j + 0.5) / res);
                if (insideConvex(hull, p)) samples.push_back(p);
            }
        if (static_cast<int>(samples.size()) * 2 >= n * n) break;
    }
    if (samples.empty()) return r;
    // Visit samples from the middle outwards so an early stop has seen the footprint's core.
    const geometry::Vec2 mid = 0.5 * (lo + hi);
    std::sort(samples.begin(), samples.end(),
              [&](const auto& a, const auto& b) { return (a - mid).squaredNorm() < (b - mid).squaredNorm(); });

    const std::size_t total = samples.size();
    std::size_t background = 0;
    std::size_t blocked = 0;
    bool obstructed = false;
    for (const auto& px : samples) {
        const auto ray = camera.backProject(px);
        std::optional<model::RayHit> hit;
        Blocker b = lineOfSight(ray.origin, ray.direction.normalized(), &hit);
        if (b == Blocker::Part && target &&
            ((hit->point - target->position).norm() <= ownRadius_ ||
             throughOwnMaterial(voxel, ray.origin, ray.direction.normalized(), solid_)))
            b = Blocker::OwnSurface;
        if (b == Blocker::None) {
            ++background;
        } else {
            ++blocked;
            if (target && b != Blocker::OwnSurface && !obstructed) {
                obstructed = true;
                r.obstruction = b;
                if (b == Blocker::Part) {
                    r.blockingTriangle = hit->triangle;
                    r.blockingPoint = hit->point;
                }
            }
        }
        if (stopAtDecision) {
            if (obstructed) break;                  // Rule 2 failed
            if (2 * blocked > total) break;         // Rule 1 cannot reach 50 %
            if (!target && 2 * background >= total) // void proven; no Rule 2 to check
                break;
        }
    }
    r.backgroundFraction = static_cast<double>(background) / static_cast<double>(total);
    r.rule1 = 2 * background >= total;
    r.rule2 = !obstructed;
    return r;
}

} // namespace hg::plan
