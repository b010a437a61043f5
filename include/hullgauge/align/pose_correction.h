// Planned poses corrected for the measured seat (docs/alignment.md, "Poses
// corrected for the seat").
//
// The planner chose each view so that the camera sees the *drawn* part from a
// particular direction — most views graze a face (docs/planning.md), where a
// few tenths of a degree decide what the silhouette shows. A part seated
// turned by ρ is seen from directions turned by ρ. Once the first views have
// measured the seat, the remaining poses are corrected so that the camera sees
// the *seated* part from the planned direction: the fixture's own degrees of
// freedom absorb what they can — the turntable a turn about its axis, the
// declination a tilt about its axis, a rail a shift along its travel.
//
// What is matched is the direction of sight in the part's frame: from the
// part's reference point (the centre of its bounding box) to the camera
// centre. With the seat S (nominal_from_part) and the fixture at q, the camera
// sees the part through camera_from_fixture(q) · S, so the camera centre lies
// at S⁻¹(c(q)) in the part frame, c(q) its place in the nominal frame. The
// correction is the reachable q nearest the planned pose p with
//     S⁻¹(c(q)) − X_ref  ∥  c(p) − X_ref,
// found by Gauss–Newton over the fixture's one or two axes from q = p, kept
// within the fixture's ranges. The roll of the image about the line of sight
// is not matched (two axes cannot; a silhouette does not depend on it).
//
// Pure computation on values: no I/O, no state.
#pragma once

#include "hullgauge/geometry/fixture.h"
#include "hullgauge/geometry/transform.h"

namespace hg::align {

struct PoseCorrection {
    geometry::FixturePose pose; ///< the pose to command (the planned one when not corrected)
    bool corrected = false;     ///< `pose` differs from the planned pose
    bool limited = false;       ///< a range of the fixture stopped the correction short (or prevented it)
    /// Angle between the planned direction of sight and the seated part's
    /// direction of sight from the planned pose (before) and from `pose` (after).
    double sightErrorBeforeDeg = 0.0;
    double sightErrorAfterDeg = 0.0;
};

/// The angle (degrees) between the direction from `target` (part frame) to the
/// camera at `planned` with the part as drawn and the one at `commanded` with
/// the part seated by `seat` (nominal_from_part).
double sightErrorDeg(const geometry::FixtureKinematics& fixture, const geometry::FixturePose& planned,
                     const geometry::FixturePose& commanded, const geometry::RigidTransform& seat,
                     const geometry::Vec3& target);

/// The pose that shows the part seated by `seat` from the direction `planned`
/// shows the drawn part, seen at `target` (part frame). The planned pose is
/// kept when the correction would not bring the direction closer (less than
/// a micro-degree to gain, or the fixture cannot move that way).
PoseCorrection correctPose(const geometry::FixtureKinematics& fixture, const geometry::FixturePose& planned,
                           const geometry::RigidTransform& seat, const geometry::Vec3& target);

} // namespace hg::align
