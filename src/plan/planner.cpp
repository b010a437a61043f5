#include "hullgauge/plan/planner.h"

#include "hullgauge/common/clock.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/format.h"
#include "hullgauge/common/log.h"
#include "hullgauge/plan/view_pattern.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>
#include <optional>
#include <set>
#include <sstream>
#include <tuple>

namespace hg::plan {

namespace {

std::string fmt(double v, int precision = 3)
{
    std::ostringstream s;
    s.precision(precision);
    s << std::fixed << v;
    std::string out = s.str();
    // 12.500 -> 12.5, 30.000 -> 30
    if (out.find('.') != std::string::npos) {
        while (!out.empty() && out.back() == '0') out.pop_back();
        if (!out.empty() && out.back() == '.') out.pop_back();
    }
    return out == "-0" ? "0" : out;
}

std::string fmtPoint(const Vec3& p)
{
    std::ostringstream s;
    s << '(' << fmt(p.x()) << ", " << fmt(p.y()) << ", " << fmt(p.z()) << ')';
    return s.str();
}

std::string fmtPose(const FixturePose& p, FixtureType type)
{
    if (type == FixtureType::Rail) return "rail " + fmt(p.railMm) + " mm";
    return "rotation " + fmt(p.rotationDeg) + "°, declination " + fmt(p.declinationDeg) + "°";
}

/// Angle (degrees) between the line of sight to `x` and the tangent plane at
/// x: from the camera's centre, or along a telecentric camera's axis.
double tangentAngleDeg(const geometry::SightLines& sight, const Vec3& x, const Vec3& n)
{
    return geometry::radToDeg(std::asin(std::clamp(n.dot(sight.towards(x)), -1.0, 1.0)));
}

/// Pose key for deduplication (micro-degrees / micro-millimetres).
std::tuple<long long, long long, long long> poseKey(const FixturePose& p)
{
    return {std::llround(p.rotationDeg * 1e6), std::llround(p.declinationDeg * 1e6), std::llround(p.railMm * 1e6)};
}

/// The inspection-map label of a voxel (5.3.3): the exact classification
/// decides wholly inside / outside boxes at once, the 50 % volume test the rest.
bool objectVoxel(const model::Solid& solid, const Eigen::AlignedBox3d& box)
{
    switch (solid.classify(box)) {
    case model::Occupancy::Inside:
        return true;
    case model::Occupancy::Outside:
        return false;
    case model::Occupancy::Boundary:
        break;
    }
    return solid.isObjectVoxel(box);
}

/// The 26-neighbour voxels of `centre` out to Chebyshev distance `layers`.
std::vector<Eigen::Vector3i> neighbourhood(const Eigen::Vector3i& centre, int layers)
{
    std::vector<Eigen::Vector3i> out;
    for (int dx = -layers; dx <= layers; ++dx)
        for (int dy = -layers; dy <= layers; ++dy)
            for (int dz = -layers; dz <= layers; ++dz)
                if (dx != 0 || dy != 0 || dz != 0) out.push_back(centre + Eigen::Vector3i(dx, dy, dz));
    return out;
}

/// The void 26-neighbour of the landmark voxel lying most nearly along the
/// outward normal: the voxel whose proof of void bounds the surface at the
/// landmark (3.3.2 type four nodes).
std::optional<Eigen::Vector3i> findWitnessVoxel(const model::Solid& solid, const inspect::VoxelFrame& frame,
                                                const Eigen::Vector3i& voxel, const Vec3& x, const Vec3& n)
{
    std::optional<Eigen::Vector3i> best;
    double bestScore = -2.0;
    for (const auto& v : neighbourhood(voxel, 1)) {
        const auto box = frame.box(frame.depth, v);
        const Vec3 d = box.center() - x;
        const double score = n.dot(d.normalized());
        if (score <= bestScore || score <= 0.0) continue;
        if (objectVoxel(solid, box)) continue;
        bestScore = score;
        best = v;
    }
    return best;
}

/// Everything the planner keeps about one landmark.
struct Analysed {
    LandmarkAnalysis a;
    LandmarkTarget target;
    bool usable = false;                 // has a witness voxel and tolerance >= ΔV
    std::vector<FixturePose> candidates; // reachable poses tried (grazing, designer, band grid)
    std::vector<RuleCheck> checks;
};

class Analyser {
  public:
    Analyser(const PlanProblem& problem, const PlanOptions& options)
        : problem_(problem), options_(options), station_(*problem.station),
          rules_(*problem.solid, *problem.station, problem.frame.voxelSize(), options.rules), poseGrid_(options.grid)
    {
        // A face square to the turntable axis is grazed at one declination for
        // every rotation; solving every other landmark's grazing rotations at
        // that declination too puts the crossing of the two curves — a pose
        // that can serve both — among the candidates.
        const auto& fixture = station_.fixture;
        if (fixture.type == FixtureType::RotationDeclination)
            for (const auto& lm : problem.landmarks) {
                if (lm.normal.normalized().cross(fixture.rotationAxis.normalized()).norm() > 1e-9) continue;
                PoseGrid single = options.grid;
                single.rotationStepDeg = 360.0;
                for (const auto& p : grazingPoses(fixture, lm.position, lm.normal, single))
                    poseGrid_.extraDeclinationsDeg.push_back(p.declinationDeg);
            }
        std::sort(poseGrid_.extraDeclinationsDeg.begin(), poseGrid_.extraDeclinationsDeg.end());
        poseGrid_.extraDeclinationsDeg.erase(std::unique(poseGrid_.extraDeclinationsDeg.begin(),
                                                         poseGrid_.extraDeclinationsDeg.end(),
                                                         [](double a, double b) { return std::abs(a - b) < 1e-9; }),
                                             poseGrid_.extraDeclinationsDeg.end());
        grid_ = gridPoses(station_.fixture, options_.grid);
        for (const auto& p : grid_) gridSights_.push_back(station_.fixture.sightLinesAt(p));
    }

    const ViewRules& rules() const { return rules_; }

    /// Poses to try for a landmark: its grazing poses and the grid poses whose
    /// line of sight lies within the band of its tangent plane.
    std::vector<FixturePose> candidatesFor(const geometry::FixtureKinematics& fixture, const Vec3& x, const Vec3& n,
                                           bool withGrid) const
    {
        auto poses = grazingPoses(fixture, x, n, poseGrid_);
        if (withGrid)
            for (std::size_t i = 0; i < grid_.size(); ++i)
                if (std::abs(tangentAngleDeg(gridSights_[i], x, n)) <= options_.bandDeg) poses.push_back(grid_[i]);
        return poses;
    }

    Analysed analyse(const PlanLandmark& lm) const
    {
        Analysed r;
        auto& a = r.a;
        const auto& frame = problem_.frame;
        a.id = lm.id;
        a.position = lm.position;
        a.normal = lm.normal.normalized();
        a.toleranceMm = lm.toleranceMm;
        a.voxel = frame.landmarkVoxel(lm.position, a.normal, frame.depth);
        a.designerBestViews = !lm.bestViews.empty();
        a.witnessVoxel = findWitnessVoxel(*problem_.solid, frame, a.voxel, a.position, a.normal);
        if (!a.witnessVoxel) {
            a.verdict = LandmarkVerdict::NoVoidNeighbour;
            a.reason = "landmark " + lm.id + " at " + fmtPoint(lm.position) +
                       " has no void neighbour voxel at the inspection depth (ΔV = " + fmt(frame.voxelSize()) +
                       " mm): it is not on the part's boundary at this resolution; move it onto the surface or "
                       "refine octree.depth.";
            return r;
        }
        r.target = {a.position, a.normal, frame.box(frame.depth, *a.witnessVoxel), lm.toleranceMm};
        r.candidates = candidatePoses(lm, a);
        WitnessSearch search = searchWitnesses(r);
        warnFailingDesignerViews(lm, r);
        judge(lm, r, search);
        if (options_.reportUnseenVoids) a.unseenVoids = unseenVoids(r);
        return r;
    }

  private:
    /// What the rule checks of one landmark's candidates found (Rules 1, 2, 4).
    struct WitnessSearch {
        std::map<std::size_t, std::size_t> blockers;
        std::map<std::size_t, Vec3> blockerPoints;
        std::size_t dofOnly = 0;
        double nearestDepth = 0.0;
        std::size_t fieldOnly = 0; ///< in the depth of field, outside the telecentric field
        double nearestOffAxis = 0.0;
        double bestRangeMed = std::numeric_limits<double>::infinity();
        bool anyPasses = false;
    };

    /// Candidate poses: grazing, the band of the grid, the designer's reachable best views.
    std::vector<FixturePose> candidatePoses(const PlanLandmark& lm, LandmarkAnalysis& a) const
    {
        auto poses = candidatesFor(station_.fixture, a.position, a.normal, true);
        for (const auto& term : lm.bestViews)
            for (const auto& v : term) {
                if (!station_.fixture.reachable(v)) {
                    a.warnings.push_back("designer best view " + fmtPose(v, station_.fixture.type) +
                                         " lies outside the fixture's ranges and is ignored");
                    continue;
                }
                poses.push_back(v);
            }
        dedupe(poses);
        return poses;
    }

    /// Judges every candidate by the rules; the poses that see the witness
    /// voxel against background are the witnesses of weak convexity.
    WitnessSearch searchWitnesses(Analysed& r) const
    {
        auto& a = r.a;
        WitnessSearch w;
        a.bestMedMm = std::numeric_limits<double>::infinity();
        auto consider = [&](const FixturePose& p) {
            const auto chk = rules_.check(r.target, p);
            r.checks.push_back(chk);
            if (chk.sees()) {
                a.witnessPoses.push_back(p);
                a.witnessDirections.push_back(station_.fixture.sightLinesAt(p).towards(a.position));
                a.bestMedMm = std::min(a.bestMedMm, chk.predictedMedMm);
                w.bestRangeMed = std::min(w.bestRangeMed, chk.rangeMedMm);
                w.anyPasses = w.anyPasses || chk.passes();
            } else if (chk.inFrame && chk.rule1 && chk.rule2 && !chk.inDepthOfField) {
                if (w.dofOnly++ == 0) w.nearestDepth = chk.depthMm;
            } else if (chk.inFrame && chk.rule1 && chk.rule2 && !chk.inTelecentricField) {
                if (w.fieldOnly++ == 0) w.nearestOffAxis = chk.offAxisMm;
            } else if (chk.obstruction == Blocker::Part && chk.blockingTriangle) {
                ++w.blockers[*chk.blockingTriangle];
                w.blockerPoints[*chk.blockingTriangle] = chk.blockingPoint;
            }
        };
        for (const auto& p : r.candidates) consider(p);
        // Weak convexity is relative to the whole reachable pose set (Definition
        // 2): when no pose near the tangent plane sees the void neighbour, every
        // other grid pose is tried before the landmark is declared not
        // inspectable (a void voxel at an edge or corner can be seen from well
        // outside the band). Only such landmarks pay for the full search.
        if (a.witnessPoses.empty()) {
            std::set<std::tuple<long long, long long, long long>> tried;
            for (const auto& p : r.candidates) tried.insert(poseKey(p));
            for (const auto& p : grid_)
                if (tried.insert(poseKey(p)).second) {
                    r.candidates.push_back(p);
                    consider(p);
                }
        }
        return w;
    }

    /// Designer best views that do not pass the rules are kept (the designer
    /// vouched for them) but reported.
    void warnFailingDesignerViews(const PlanLandmark& lm, Analysed& r) const
    {
        for (const auto& term : lm.bestViews)
            for (const auto& v : term)
                if (station_.fixture.reachable(v)) {
                    const auto chk = rules_.check(r.target, v);
                    if (!chk.passes())
                        r.a.warnings.push_back("designer best view " + fmtPose(v, station_.fixture.type) +
                                               " fails: " + chk.failure());
                }
    }

    /// The verdict of a landmark with a witness voxel (eq. 5.3.6-1, Definition
    /// 2, Rule 4, eq. 5.3.6-3 / 4.4.4-19, in that order).
    void judge(const PlanLandmark& lm, Analysed& r, WitnessSearch& w) const
    {
        auto& a = r.a;
        const auto& frame = problem_.frame;
        const double dv = frame.voxelSize();
        r.usable = false;
        if (lm.toleranceMm < dv) {
            const int more = static_cast<int>(std::ceil(std::log2(dv / lm.toleranceMm) - 1e-12));
            a.verdict = LandmarkVerdict::VoxelTooCoarse;
            a.reason = "landmark " + lm.id + ": tolerance " + fmt(lm.toleranceMm) +
                       " mm is below the inspection voxel ΔV = " + fmt(dv) +
                       " mm (eq. 5.3.6-1: ΔV <= MED); raise octree.depth to at least " +
                       std::to_string(frame.depth + more) + " or loosen the tolerance.";
        } else if (a.witnessPoses.empty() && w.dofOnly > 0) {
            const auto& dof = *station_.depthOfFieldMm;
            a.verdict = LandmarkVerdict::OutsideDepthOfField;
            a.reason = "landmark " + lm.id +
                       " is seen against background only at depths outside the depth of "
                       "field [" +
                       fmt(dof.min) + ", " + fmt(dof.max) + "] mm (e.g. at " + fmt(w.nearestDepth) +
                       " mm): refocus the camera or move the part (Rule 4).";
        } else if (a.witnessPoses.empty() && w.fieldOnly > 0) {
            a.verdict = LandmarkVerdict::OutsideTelecentricField;
            a.reason = "landmark " + lm.id + " is seen against background only outside the lens's telecentric field (" +
                       fmt(*station_.telecentricFieldMm) + " mm across; e.g. " + fmt(w.nearestOffAxis) +
                       " mm from the axis): move the part towards the optical axis or use a lens with a wider "
                       "field (Rule 4, docs/telecentric.md).";
        } else if (a.witnessPoses.empty()) {
            explainUnseen(r, w.blockers, w.blockerPoints);
        } else if (!w.anyPasses) {
            a.verdict = LandmarkVerdict::BelowStationMed;
            if (!std::isfinite(a.bestMedMm) || a.bestMedMm > lm.toleranceMm)
                a.reason = lm.drawingToleranceMm
                               ? "landmark " + lm.id + ": the voxel size ΔV = " + fmt(lm.toleranceMm) +
                                     " mm is below the finest discrimination this station reaches there "
                                     "(predicted MED " +
                                     fmt(a.bestMedMm) + " mm, eq. 5.3.6-3; the tolerance " +
                                     fmt(*lm.drawingToleranceMm) +
                                     " mm is decided to U by the sub-voxel deviation, the views must resolve the "
                                     "voxel); use a smaller octree.depth, or bring the camera closer / use a "
                                     "longer lens."
                               : "landmark " + lm.id + ": tolerance " + fmt(lm.toleranceMm) +
                                     " mm is below the finest discrimination this station reaches there (predicted "
                                     "MED " +
                                     fmt(a.bestMedMm) +
                                     " mm, eq. 5.3.6-3); loosen the tolerance, or bring the camera "
                                     "closer / use a longer lens.";
            else
                a.reason = "landmark " + lm.id + ": no view resolves the inspection voxel ΔV = " + fmt(dv) +
                           " mm there (best MED " + fmt(w.bestRangeMed) +
                           " mm, eq. 4.4.4-19); use a smaller octree.depth, or bring the camera closer / use a "
                           "longer lens.";
        } else {
            a.verdict = LandmarkVerdict::Inspectable;
            r.usable = true;
        }
    }

    static void dedupe(std::vector<FixturePose>& poses)
    {
        std::map<std::tuple<long long, long long, long long>, bool> seen;
        std::vector<FixturePose> out;
        for (const auto& p : poses)
            if (seen.emplace(poseKey(p), true).second) out.push_back(p);
        poses.swap(out);
    }

    /// Not seen from any reachable pose: would a wider fixture see it
    /// (OutOfFixtureRange), or does the part itself hide it (Concavity)?
    void explainUnseen(Analysed& r, std::map<std::size_t, std::size_t>& blockers,
                       std::map<std::size_t, Vec3>& blockerPoints) const
    {
        auto& a = r.a;
        const FixtureType type = station_.fixture.type;
        geometry::FixtureKinematics wide = station_.fixture;
        wide.rotationRangeDeg = {-180.0, 180.0};
        wide.declinationRangeDeg = {-90.0, 90.0};
        wide.railRangeMm = {-1e4, 1e4};
        geometry::Station wideStation = station_;
        wideStation.fixture = wide;
        for (const auto& p : grazingPoses(wide, a.position, a.normal, options_.grid)) {
            if (station_.fixture.reachable(p)) continue;
            const auto chk = rules_.check(r.target, wideStation.cameraAt(p));
            if (chk.sees())
                a.unreachableWitnesses.push_back(p);
            else if (chk.obstruction == Blocker::Part && chk.blockingTriangle) {
                ++blockers[*chk.blockingTriangle];
                blockerPoints[*chk.blockingTriangle] = chk.blockingPoint;
            }
        }
        if (!a.unreachableWitnesses.empty()) {
            const auto& f = station_.fixture;
            a.verdict = LandmarkVerdict::OutOfFixtureRange;
            std::string ranges = type == FixtureType::Rail
                                     ? "rail range [" + fmt(f.railRangeMm.min) + ", " + fmt(f.railRangeMm.max) + "] mm"
                                     : "rotation range [" + fmt(f.rotationRangeDeg.min) + ", " +
                                           fmt(f.rotationRangeDeg.max) + "]°, declination range [" +
                                           fmt(f.declinationRangeDeg.min) + ", " + fmt(f.declinationRangeDeg.max) +
                                           "]°";
            a.reason = "landmark " + a.id +
                       " is seen against background only from poses the fixture cannot "
                       "reach (e.g. " +
                       fmtPose(a.unreachableWitnesses.front(), type) + "; the " + ranges +
                       "): widen the fixture's range or mount the part turned so this face comes into reach.";
            return;
        }
        a.verdict = LandmarkVerdict::Concavity;
        std::ostringstream s;
        s << "landmark " << a.id << " at " << fmtPoint(a.position)
          << " lies in a concavity: no line of sight from any fixture pose passes its void neighbour on to "
             "background (Definition 2)";
        if (!blockers.empty()) {
            auto most = std::max_element(blockers.begin(), blockers.end(),
                                         [](const auto& x, const auto& y) { return x.second < y.second; });
            a.blockingTriangle = most->first;
            a.blockingPoint = blockerPoints[most->first];
            s << "; the part blocks it at triangle " << most->first << " near " << fmtPoint(*a.blockingPoint);
        }
        a.nearestInspectablePoint = nearestInspectable(a.position);
        if (a.nearestInspectablePoint)
            s << "; the nearest inspectable surface point is " << fmtPoint(*a.nearestInspectablePoint) << ", "
              << fmt((*a.nearestInspectablePoint - a.position).norm()) << " mm away";
        s << ". Move the landmark to a visible edge or inspect this feature another way.";
        a.reason = s.str();
    }

    /// The nearest surface point (triangle centroids, nearest first) seen from
    /// a reachable grazing pose.
    std::optional<Vec3> nearestInspectable(const Vec3& x) const
    {
        const auto& mesh = problem_.solid->mesh();
        std::vector<std::pair<double, std::size_t>> order;
        for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
            const auto& tri = mesh.triangles[t];
            const Vec3 c = (mesh.vertices[tri[0]] + mesh.vertices[tri[1]] + mesh.vertices[tri[2]]) / 3.0;
            order.emplace_back((c - x).norm(), t);
        }
        std::sort(order.begin(), order.end());
        const auto& frame = problem_.frame;
        std::size_t tried = 0;
        for (const auto& [dist, t] : order) {
            if (tried++ >= options_.nearestSearchLimit) break;
            const auto& tri = mesh.triangles[t];
            const Vec3 c = (mesh.vertices[tri[0]] + mesh.vertices[tri[1]] + mesh.vertices[tri[2]]) / 3.0;
            const Vec3 n = mesh.faceNormal(t);
            if (n.isZero()) continue;
            const auto voxel = frame.landmarkVoxel(c, n, frame.depth);
            auto witness = findWitnessVoxel(*problem_.solid, frame, voxel, c, n);
            if (!witness) continue;
            LandmarkTarget target{c, n, frame.box(frame.depth, *witness), 1e9};
            for (const auto& p : candidatesFor(station_.fixture, c, n, false))
                if (rules_.check(target, p).sees()) return c;
        }
        return std::nullopt;
    }

    /// Void type-four neighbours (out to pareLayers) that no tried pose proves void (3.3.8).
    std::vector<inspect::VoxelKey> unseenVoids(const Analysed& r) const
    {
        std::vector<inspect::VoxelKey> out;
        const auto& frame = problem_.frame;
        // Witnesses first: they prove most neighbours void at once.
        std::vector<geometry::CameraModel> cameras;
        for (const auto& p : r.a.witnessPoses) cameras.push_back(station_.cameraAt(p));
        for (std::size_t i = 0; i < r.candidates.size(); ++i)
            if (!r.checks[i].sees()) cameras.push_back(station_.cameraAt(r.candidates[i]));
        for (const auto& v : neighbourhood(r.a.voxel, std::max(1, options_.pareLayers))) {
            const auto box = frame.box(frame.depth, v);
            if (objectVoxel(*problem_.solid, box)) continue;
            bool seen = false;
            for (const auto& cam : cameras)
                if (rules_.provenVoid(box, cam)) {
                    seen = true;
                    break;
                }
            // Not seen from the landmark's poses: try the grazing poses of the
            // surface nearest to this voxel (a voxel beside another face of an
            // edge or corner is seen from that face's tangent plane).
            if (!seen) {
                const auto sp = problem_.solid->closestPoint(box.center());
                for (const auto& p : grazingPoses(station_.fixture, sp.point, sp.normal, options_.grid))
                    if (rules_.provenVoid(box, station_.cameraAt(p))) {
                        seen = true;
                        break;
                    }
            }
            if (!seen) out.push_back(inspect::makeKey(frame.depth, v));
        }
        std::sort(out.begin(), out.end());
        return out;
    }

    const PlanProblem& problem_;
    const PlanOptions& options_;
    const geometry::Station& station_;
    ViewRules rules_;
    PoseGrid poseGrid_;
    std::vector<FixturePose> grid_;
    std::vector<geometry::SightLines> gridSights_;
};

void validate(const PlanProblem& problem)
{
    if (!problem.solid || !problem.station)
        throw ArgumentError(std::string("plan: solid and station are required, found ") +
                            (problem.solid ? "a solid" : "no solid") + " and " +
                            (problem.station ? "a station" : "no station"));
    if (!(problem.frame.cubeSize > 0.0))
        throw ArgumentError("plan: frame.cubeSize must be positive, found " + formatNumber(problem.frame.cubeSize));
}

/// Final pose of a group (5.4.4, fig. 5.19): the pose of its variation list
/// with the least summed distance to the group's landmarks (for a telecentric
/// camera, from its plane of best focus: SightLines::distanceTo); among poses within
/// 0.1 % of that, the median orientation (rotation, then declination, or rail).
std::size_t finalPose(const PoseSet& variation, const std::vector<std::size_t>& landmarks,
                      const std::vector<geometry::SightLines>& sights, const std::vector<FixturePose>& poses,
                      const std::vector<Analysed>& analysed)
{
    std::vector<std::pair<double, int>> sums;
    double best = std::numeric_limits<double>::infinity();
    for (int p : variation) {
        double s = 0.0;
        for (std::size_t l : landmarks) s += sights[static_cast<std::size_t>(p)].distanceTo(analysed[l].a.position);
        sums.emplace_back(s, p);
        best = std::min(best, s);
    }
    if (sums.empty()) throw ArgumentError("plan: finalPose: variation: empty (a view group without poses)");
    std::vector<int> ties;
    for (const auto& [s, p] : sums)
        if (s <= best * (1.0 + 1e-3) + 1e-9) ties.push_back(p);
    std::sort(ties.begin(), ties.end(), [&](int x, int y) {
        const auto& a = poses[static_cast<std::size_t>(x)];
        const auto& b = poses[static_cast<std::size_t>(y)];
        return std::tie(a.rotationDeg, a.declinationDeg, a.railMm) <
               std::tie(b.rotationDeg, b.declinationDeg, b.railMm);
    });
    return static_cast<std::size_t>(ties[(ties.size() - 1) / 2]);
}

/// The candidate pose list of the view pattern analysis (5.5.1): every
/// landmark's tried poses, pooled and deduplicated.
struct PosePool {
    std::map<std::tuple<long long, long long, long long>, int> index;
    std::vector<FixturePose> poses;
    std::vector<geometry::SightLines> sights;
    /// ownIndex[l][k]: pool index of landmark l's candidate k.
    std::vector<std::vector<int>> ownIndex;
};

PosePool poolCandidates(const std::vector<Analysed>& analysed, const geometry::Station& station)
{
    PosePool pool;
    pool.ownIndex.resize(analysed.size());
    for (std::size_t l = 0; l < analysed.size(); ++l)
        for (const auto& p : analysed[l].candidates) {
            auto [it, fresh] = pool.index.emplace(poseKey(p), static_cast<int>(pool.poses.size()));
            if (fresh) {
                pool.poses.push_back(p);
                pool.sights.push_back(station.fixture.sightLinesAt(p));
            }
            pool.ownIndex[l].push_back(it->second);
        }
    return pool;
}

/// View variation of each usable landmark (5.4, 5.5.1): the pooled poses at
/// which it passes Rules 1-4, with every rule check kept for the final views.
struct ViewVariations {
    std::vector<PoseSet> passing;
    std::vector<std::map<int, RuleCheck>> checkAt;
};

ViewVariations viewVariations(const std::vector<Analysed>& analysed, const PosePool& pool, const ViewRules& rules,
                              double bandDeg)
{
    ViewVariations vv;
    vv.passing.resize(analysed.size());
    vv.checkAt.resize(analysed.size());
    for (std::size_t l = 0; l < analysed.size(); ++l) {
        const auto& r = analysed[l];
        if (!r.usable) continue;
        auto& passing = vv.passing[l];
        std::vector<bool> tried(pool.poses.size(), false);
        for (std::size_t k = 0; k < r.candidates.size(); ++k) {
            const int p = pool.ownIndex[l][k];
            tried[static_cast<std::size_t>(p)] = true;
            vv.checkAt[l][p] = r.checks[k];
            if (r.checks[k].passes()) passing.push_back(p);
        }
        for (std::size_t p = 0; p < pool.poses.size(); ++p) {
            if (tried[p] || std::abs(tangentAngleDeg(pool.sights[p], r.a.position, r.a.normal)) > bandDeg) continue;
            const auto chk = rules.check(r.target, pool.poses[p]);
            vv.checkAt[l][static_cast<int>(p)] = chk;
            if (chk.passes()) passing.push_back(static_cast<int>(p));
        }
        std::sort(passing.begin(), passing.end());
        passing.erase(std::unique(passing.begin(), passing.end()), passing.end());
    }
    return vv;
}

/// View variation of a designer best view (5.4.1): the passing candidates
/// whose line of sight turns from the designer's by no more than Θ, the
/// largest angle eq. 5.3.6-3 allows at this distance — the closed form
/// C = D tan Θ (eq. 5.4.1-1/2) as an angle.
PoseSet designerViewVariation(int designer, const Analysed& r, const PoseSet& passing, const PosePool& pool,
                              double focal)
{
    const geometry::SightLines& designed = pool.sights[static_cast<std::size_t>(designer)];
    const Vec3 dv = designed.towards(r.a.position);
    // A telecentric camera's fx, fy are px per mm: its pixel is 1/f mm at any depth.
    const double theta = designed.parallel ? maxTelecentricViewAngleRad(1.0 / focal, r.a.toleranceMm)
                                           : maxViewAngleRad(focal, designed.distanceTo(r.a.position), r.a.toleranceMm);
    PoseSet sub{designer};
    for (int p : passing) {
        const Vec3 dp = pool.sights[static_cast<std::size_t>(p)].towards(r.a.position);
        if (std::acos(std::clamp(dp.dot(dv), -1.0, 1.0)) <= theta + 1e-12) sub.push_back(p);
    }
    std::sort(sub.begin(), sub.end());
    sub.erase(std::unique(sub.begin(), sub.end()), sub.end());
    return sub;
}

/// Best views as AND-of-OR requirements (eq. 5.3.2-1/2): a derived landmark
/// needs one pose of its variation list; a designer's landmark one pose of
/// each AND group's OR views. A group without a reachable pose fails the
/// landmark (best_views_fail), which then drops all its requirements.
std::vector<Requirement> bestViewRequirements(const PlanProblem& problem, std::vector<Analysed>& analysed,
                                              const PosePool& pool, const ViewVariations& vv, ViewPlan& plan)
{
    std::vector<Requirement> requirements;
    const auto& K = problem.station->camera.K;
    const double focal = std::min(K(0, 0), K(1, 1));
    for (std::size_t l = 0; l < analysed.size(); ++l) {
        auto& r = analysed[l];
        if (!r.usable) continue;
        const auto& lm = problem.landmarks[l];
        if (lm.bestViews.empty()) {
            requirements.push_back({l, {vv.passing[l]}});
            continue;
        }
        for (std::size_t t = 0; t < lm.bestViews.size(); ++t) {
            Requirement req{l, {}};
            for (const auto& v : lm.bestViews[t]) {
                auto it = pool.index.find(poseKey(v));
                if (it == pool.index.end()) continue; // unreachable, reported already
                req.anyOf.push_back(designerViewVariation(it->second, r, vv.passing[l], pool, focal));
            }
            if (req.anyOf.empty()) {
                r.a.verdict = LandmarkVerdict::BestViewsFail;
                r.a.reason = "landmark " + lm.id + ": best view group " + std::to_string(t + 1) +
                             " has no pose the fixture can reach; correct best_views or the fixture's ranges.";
                plan.problems.push_back(r.a.reason);
                r.usable = false;
                break;
            }
            requirements.push_back(std::move(req));
        }
    }
    requirements.erase(std::remove_if(requirements.begin(), requirements.end(),
                                      [&](const Requirement& q) { return !analysed[q.landmark].usable; }),
                       requirements.end());
    return requirements;
}

/// AND-OR reduction (5.6.1: OR removal, AND combination by largest
/// intersection), one final pose per group (5.4.4), the redundancy check and
/// the requested view count (5.5); `--exact` adds the GLPK optimum. Returns
/// the chosen pool indices, sorted.
std::vector<std::size_t> reduceViews(const std::vector<Requirement>& requirements,
                                     const std::vector<Analysed>& analysed, const PosePool& pool,
                                     const PlanOptions& options, ViewPlan& plan)
{
    PatternOptions pattern;
    pattern.minIntersection = options.minIntersection;
    const auto greedy = greedyViewPattern(requirements, pattern);
    for (std::size_t u : greedy.unserved) {
        const auto& a = analysed[requirements[u].landmark].a;
        plan.problems.push_back("landmark " + a.id + ": no pose satisfies Rules 1-4 for one of its best views.");
    }
    if (options.exact) {
        const auto exact = exactViewCover(requirements, options.exactTimeLimitSeconds);
        if (exact.solved) {
            plan.exactViews = exact.poses.size();
            plan.exactOptimal = exact.optimal;
        } else {
            log::category("plan")->warn("exact view cover not solved: {}", exact.message);
        }
    }
    std::vector<int> chosen;
    for (const auto& g : greedy.groups)
        chosen.push_back(static_cast<int>(finalPose(g.variation, g.landmarks, pool.sights, pool.poses, analysed)));
    std::sort(chosen.begin(), chosen.end());
    chosen.erase(std::unique(chosen.begin(), chosen.end()), chosen.end());
    chosen = removeRedundantPoses(requirements, chosen);
    plan.greedyViews = chosen.size();
    // 5.5: terminate on the requested view count, or fail when keeping every
    // landmark's accuracy needs more views than that.
    if (options.maxViews > 0 && chosen.size() > options.maxViews)
        plan.problems.push_back("the landmarks' tolerances need " + std::to_string(chosen.size()) +
                                " views but at most " + std::to_string(options.maxViews) +
                                " were requested: allow more views or loosen the tightest tolerances.");
    return {chosen.begin(), chosen.end()};
}

/// The predicted cycle time of the chosen poses in `order` from the home
/// pose, beside the order they were chosen in, the order of least travel
/// distance, and the next part's cycle from the last view.
PlanCycleTime planCycleTime(const std::vector<FixturePose>& chosenPoses, const std::vector<std::size_t>& order,
                            const geometry::FixtureMotion& motion, const FixturePose& home)
{
    auto inOrder = [&](const std::vector<std::size_t>& o) {
        std::vector<FixturePose> poses;
        for (std::size_t i : o) poses.push_back(chosenPoses[i]);
        return poses;
    };
    PlanCycleTime c;
    c.motion = motion;
    const auto ordered = inOrder(order);
    c.predicted = predictCycleTime(ordered, motion, home);
    c.unorderedS = predictCycleTime(chosenPoses, motion, home).totalS;
    c.leastDistanceS = predictCycleTime(inOrder(orderForTravel(chosenPoses, motion.type, home)), motion, home).totalS;
    c.repeatS = ordered.empty() ? 0.0 : predictCycleTime(ordered, motion, ordered.back()).totalS;
    return c;
}

/// The final views: the problem's first views as given, then the chosen
/// poses (one equal to a first view is not taken twice) in the order of least
/// cycle time from the last first view; each with every usable landmark it
/// observes under Rules 1-4 and the predicted MED.
void finalViews(const std::vector<std::size_t>& chosen, const std::vector<Analysed>& analysed, const PosePool& pool,
                const ViewVariations& vv, const ViewRules& rules, const PlanProblem& problem, ViewPlan& plan)
{
    const geometry::Station& station = *problem.station;
    const std::vector<FixturePose>& first = problem.firstViews;
    std::vector<FixturePose> rest;
    std::vector<std::optional<std::size_t>> poolIndex(first.size());
    for (std::size_t p : chosen) {
        const auto same = std::find(first.begin(), first.end(), pool.poses[p]);
        if (same == first.end()) {
            rest.push_back(pool.poses[p]);
            poolIndex.push_back(p);
        } else {
            poolIndex[static_cast<std::size_t>(same - first.begin())] = p;
        }
    }
    const auto motion = geometry::stationMotion(station);
    const auto home = homePose(station.fixture);
    std::vector<FixturePose> poses = first;
    poses.insert(poses.end(), rest.begin(), rest.end());
    std::vector<std::size_t> order(first.size());
    std::iota(order.begin(), order.end(), std::size_t{0});
    for (std::size_t k : orderForTime(rest, motion, first.empty() ? home : first.back()))
        order.push_back(first.size() + k);
    plan.cycleTime = planCycleTime(poses, order, motion, home);
    for (std::size_t k = 0; k < order.size(); ++k) {
        PlannedView view;
        view.id = "v" + std::to_string(k);
        view.pose = poses[order[k]];
        view.camera = station.cameraAt(view.pose);
        const std::optional<std::size_t> p = poolIndex[order[k]];
        for (std::size_t l = 0; l < analysed.size(); ++l) {
            if (!analysed[l].usable) continue;
            const auto it = p ? vv.checkAt[l].find(static_cast<int>(*p)) : vv.checkAt[l].end();
            const RuleCheck chk = it != vv.checkAt[l].end() ? it->second : rules.check(analysed[l].target, view.camera);
            if (chk.passes()) {
                view.landmarks.push_back(l);
                view.predictedMedMm.push_back(chk.predictedMedMm);
            }
        }
        plan.views.push_back(std::move(view));
    }
}

/// The problem's first views must be poses the fixture reaches.
void checkFirstViews(const PlanProblem& problem, ViewPlan& plan)
{
    for (std::size_t k = 0; k < problem.firstViews.size(); ++k)
        if (!problem.station->fixture.reachable(problem.firstViews[k]))
            plan.problems.push_back("view for the seat " + std::to_string(k + 1) + " (" +
                                    fmtPose(problem.firstViews[k], problem.station->fixture.type) +
                                    ") lies outside the fixture's ranges.");
}

/// Every usable landmark must be observed, and every designer AND term met.
void checkCoverage(const std::vector<Analysed>& analysed, const std::vector<Requirement>& requirements,
                   const std::vector<std::size_t>& chosen, ViewPlan& plan)
{
    for (std::size_t l = 0; l < analysed.size(); ++l) {
        if (!analysed[l].usable) continue;
        bool observed = false;
        for (const auto& v : plan.views)
            observed = observed || std::find(v.landmarks.begin(), v.landmarks.end(), l) != v.landmarks.end();
        if (!observed)
            plan.problems.push_back("landmark " + analysed[l].a.id + " is observed by none of the planned views.");
    }
    for (const auto& req : requirements) {
        bool met = false;
        for (const auto& sub : req.anyOf)
            for (std::size_t p : chosen) met = met || std::binary_search(sub.begin(), sub.end(), static_cast<int>(p));
        if (!met)
            plan.problems.push_back("landmark " + analysed[req.landmark].a.id +
                                    ": a best view group is not met by the planned views.");
    }
}

} // namespace

std::vector<LandmarkAnalysis> analyseLandmarks(const PlanProblem& problem, const PlanOptions& options)
{
    validate(problem);
    Analyser analyser(problem, options);
    std::vector<LandmarkAnalysis> out;
    for (const auto& lm : problem.landmarks) out.push_back(analyser.analyse(lm).a);
    return out;
}

ViewPlan planViews(const PlanProblem& problem, const PlanOptions& options)
{
    validate(problem);
    const Stopwatch watch;
    auto logger = log::category("plan");
    Analyser analyser(problem, options);

    // Weak convexity and witnesses of every landmark (chapter 2, 5.3).
    ViewPlan plan;
    std::vector<Analysed> analysed;
    for (const auto& lm : problem.landmarks) {
        analysed.push_back(analyser.analyse(lm));
        const auto& a = analysed.back().a;
        logger->debug("landmark {}: {} ({} witnesses)", a.id, enumName(a.verdict), a.witnessPoses.size());
        if (!a.inspectable()) plan.problems.push_back(a.reason);
    }
    // View pattern analysis (5.5): variations, AND-OR requirements, reduction, final views.
    const PosePool pool = poolCandidates(analysed, *problem.station);
    plan.candidatePoses = pool.poses.size();
    const ViewVariations vv = viewVariations(analysed, pool, analyser.rules(), options.bandDeg);
    const auto requirements = bestViewRequirements(problem, analysed, pool, vv, plan);
    const auto chosen = reduceViews(requirements, analysed, pool, options, plan);
    checkFirstViews(problem, plan);
    finalViews(chosen, analysed, pool, vv, analyser.rules(), problem, plan);
    checkCoverage(analysed, requirements, chosen, plan);

    for (auto& r : analysed) plan.landmarks.push_back(std::move(r.a));
    plan.feasible = plan.problems.empty();
    plan.seconds = watch.seconds();
    logger->info("plan: {} landmarks, {} candidate poses, {} views in {:.3f} s", plan.landmarks.size(),
                 plan.candidatePoses, plan.views.size(), plan.seconds);
    return plan;
}

} // namespace hg::plan
