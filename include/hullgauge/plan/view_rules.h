// The rules a view must satisfy to observe a landmark (dissertation 5.3.4-5.3.6)
// and the line-of-sight test of weak convexity in the practical form the
// station uses (Definition 2, "reconstructible": Definition 1 under the
// assumptions of 2.5.1, which implies weak convexity, 2.7.1).
//
// A landmark is observed from a pose when its witness voxel — the void
// neighbour of the landmark's voxel lying most nearly along the outward normal,
// at the inspection depth — is proven void by the volume-source test, i.e. its
// line of sight passes on to background (Definition 2: the half line v z ∞
// misses the part for the points z of the void neighbourhood).
//
//  Rule 1 (50 % rule, 5.3.4): at least half of the voxel's footprint is
//    background. Evaluated geometrically, without rendering: the footprint
//    (hull of the 8 projected corners) is sampled on an n x n pixel-space grid,
//    and each sample's line of sight is cast against the CAD solid (CGAL AABB
//    tree, Solid::firstHit) and the floor; the background fraction is the share
//    of samples whose whole line of sight misses both. The volume-source test of
//    the inspection engine integrates the same footprint exactly over pixels;
//    the sampling converges to it as n grows (n = 7 resolves 2 % of the area).
//  Rule 2 (obstruction, 5.3.5): no sampled line of sight meets the environment
//    (the floor disc) or a part of the object farther than `ownSurfaceRadius`
//    from the landmark — the blocker is reported (triangle, point).
//  Rule 3 (accuracy, eq. 5.3.6-3) with the landmark's tolerance as MED: the
//    view's predicted MED (the smallest MED solving 5.3.6-3 for the view's
//    distance d and angle θ between the line of sight and the optical axis —
//    the engine's eq. 4.4.5-11, inspect::viewDiscrimination) must not exceed
//    the tolerance; and, as the inspection engine requires of an observing
//    view, its eq. 4.4.4-19 MED must not exceed ΔV.
//  Rule 4 (depth of field, eq. 5.3.6-5): the landmark's depth along the
//    optical axis lies within the station's depth of field, when given.
//
// The floor (Assumption 2.10, docs/contracts.md §2 environment.floor_z_mm): the camera
// centre must lie above the plane z = floor_z_mm, and a line of sight is
// blocked where it crosses that plane within `floorRadiusMm` of the fixture
// axis (the turntable under the part); beyond it the back light is seen.
#pragma once

#include "hullgauge/common/enum_names.h"
#include "hullgauge/geometry/station.h"
#include "hullgauge/model/solid.h"

#include <Eigen/Geometry>
#include <cstddef>
#include <optional>
#include <string>

namespace hg::plan {

using geometry::FixturePose;
using geometry::Vec3;

struct RuleOptions {
    /// Samples per side of the footprint grid (Rule 1), >= 2.
    int samplesPerSide = 7;
    /// Radius of the floor disc about the fixture axis, mm. Default: the part's
    /// largest distance from the axis (the turntable is as large as the part).
    std::optional<double> floorRadiusMm;
    /// A hit closer than this to the landmark is the landmark's own surface
    /// (Rule 1); farther, an obstruction (Rule 2). Default: 3 ΔV.
    std::optional<double> ownSurfaceRadiusMm;
    /// Pixels of margin the footprint keeps from the image border.
    double imageMarginPx = 1.0;
    /// Rule 3 also asks what the inspection engine asks of an observing view
    /// (inspect::InspectionOptions::requireResolution): eq. 4.4.4-19 MED <= ΔV.
    bool requireVoxelResolution = true;
};

/// What blocked a line of sight.
enum class Blocker { None, OwnSurface, Part, Floor, CameraBelowFloor };
constexpr auto nameTable(Blocker)
{
    using enum Blocker;
    return std::to_array<EnumName<Blocker>>({{None, "none"},
                                             {OwnSurface, "own surface"},
                                             {Part, "part"},
                                             {Floor, "floor"},
                                             {CameraBelowFloor, "camera below floor"}});
}

/// A landmark as the rules see it: where it is, its voxel neighbourhood and
/// its tolerance (= the MED Rule 3 asks for).
struct LandmarkTarget {
    Vec3 position = Vec3::Zero();
    Vec3 normal = Vec3::UnitZ();
    Eigen::AlignedBox3d witnessVoxel;
    double toleranceMm = 0.0;
};

struct RuleCheck {
    bool inFrame = false;            ///< footprint in front of the camera and inside the image
    double backgroundFraction = 0.0; ///< Rule 1: share of the footprint seen as background
    bool rule1 = false;
    bool rule2 = false;
    bool rule3 = false;
    bool rule4 = false;                          ///< in the depth of field and (telecentric) in the telecentric field
    bool inDepthOfField = false;                 ///< Rule 4's depth half
    bool inTelecentricField = false;             ///< Rule 4's field half (always true without a stated field)
    double predictedMedMm = 0.0;                 ///< eq. 5.3.6-3 (= 4.4.5-11) solved for MED at this view
    double rangeMedMm = 0.0;                     ///< eq. 4.4.4-19 solved for ΔV at this view
    double distanceMm = 0.0;                     ///< camera (CameraModel::rangeTo) to landmark
    double depthMm = 0.0;                        ///< landmark depth along the optical axis
    double offAxisMm = 0.0;                      ///< landmark's distance from the optical axis
    double viewAngleDeg = 0.0;                   ///< θ: line of sight to the landmark vs optical axis
    Blocker obstruction = Blocker::None;         ///< first Rule-2 blocker met
    std::optional<std::size_t> blockingTriangle; ///< when obstruction == Part
    Vec3 blockingPoint = Vec3::Zero();
    /// Rules 1, 2 and 4 — the view sees the landmark against background.
    bool sees() const { return inFrame && rule1 && rule2 && rule4; }
    /// All four rules.
    bool passes() const { return sees() && rule3; }
    /// The first failed rule in words, empty when passes().
    std::string failure() const;
};

/// Eq. 5.3.6-3 solved for the MED (the scalar form of inspect::viewDiscrimination's
/// medAngleMm, needed here to invert it): with f = f/Δp in pixels, the smallest MED with
///   1 < 2 (f/d) (MED/2√2) d (cos θ − sin θ) / (d cos θ − MED/2√2)
/// is MED = 2√2 d cos θ / (2 f (cos θ − sin θ) + 1). Infinite for θ >= 45°.
double predictedMedMm(double focalPx, double distanceMm, double thetaRad);

/// The largest θ (radians) at which a view at `distanceMm` still resolves
/// `medMm` (eq. 5.3.6-3 inverted by bisection); 0 when even θ = 0 does not.
/// Used as the view-variation limit Θ of eq. 5.4.1-1/2 (C = D tan Θ).
double maxViewAngleRad(double focalPx, double distanceMm, double medMm);

/// Eq. 5.3.6-3 for a telecentric camera (docs/telecentric.md): written with
/// the pixel's size at the landmark m = d/f, MED = 2√2·m·cos θ / (2(cos θ −
/// sin θ) + 1/f), and a telecentric camera is its limit 1/f → 0 at
/// m = 1/min(fx, fy): √2·m·cos θ / (cos θ − sin θ). Its lines of sight do not
/// turn off the axis (θ = 0 at every landmark); θ is the turn of the line of
/// sight a view variation may make.
double telecentricMedMm(double mmPerPx, double thetaRad);
/// maxViewAngleRad's telecentric counterpart, from telecentricMedMm.
double maxTelecentricViewAngleRad(double mmPerPx, double medMm);

class ViewRules {
  public:
    /// `solid` and `station` must outlive the object. `voxelSizeMm` is ΔV.
    ViewRules(const model::Solid& solid, const geometry::Station& station, double voxelSizeMm,
              RuleOptions options = {});

    /// Evaluates Rules 1–4 for `target` from `pose`. Reachability is not checked.
    RuleCheck check(const LandmarkTarget& target, const FixturePose& pose) const;
    /// As check(), from an already posed camera.
    RuleCheck check(const LandmarkTarget& target, const geometry::CameraModel& camera) const;

    /// Rule 1 for any void voxel (used for the type-four paring of 3.3.8).
    bool provenVoid(const Eigen::AlignedBox3d& voxel, const geometry::CameraModel& camera) const;

    /// What blocks the whole line of sight from `origin` along unit `direction`.
    Blocker lineOfSight(const Vec3& origin, const Vec3& direction, std::optional<model::RayHit>* hit = nullptr) const;

    const geometry::Station& station() const { return station_; }
    const model::Solid& solid() const { return solid_; }
    double voxelSizeMm() const { return voxelSize_; }
    double floorRadiusMm() const { return floorRadius_; }
    double ownSurfaceRadiusMm() const { return ownRadius_; }
    const RuleOptions& options() const { return options_; }

  private:
    struct Footprint;
    RuleCheck evaluate(const LandmarkTarget* target, const Eigen::AlignedBox3d& voxel,
                       const geometry::CameraModel& camera, bool stopAtDecision) const;

    const model::Solid& solid_;
    const geometry::Station& station_;
    double voxelSize_;
    RuleOptions options_;
    double floorRadius_ = 0.0;
    double ownRadius_ = 0.0;
};

} // namespace hg::plan
