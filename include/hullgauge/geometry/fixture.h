// Fixture kinematics (docs/contracts.md §2).
//
// Rotation/declination fixture: the part is mounted with its frame on the
// turntable frame; the turntable rotates about `rotationAxis`, and the whole
// turntable tilts about `declinationAxis`, both through the fixture origin:
//   camera_from_part = camera_from_fixture * Rot(declination_axis, declination)
//                                          * Rot(rotation_axis, rotation)
// Extension: a calibrated fixture's axes need not meet. Each axis may pass
// through its own point (`rotationAxisPoint`, `declinationAxisPoint`, default
// the origin); Rot(L, a) is then the rotation about the line L:
// Trans(p) * Rot(axis, a) * Trans(-p). With both points at the origin this is
// exactly the formula above.
// Rail: the part travels along `railAxis`:
//   camera_from_part = camera_from_fixture * Trans(rail_axis * rail_mm)
#pragma once

#include <cmath>

#include "hullgauge/common/enum_names.h"
#include "hullgauge/common/format.h"
#include "hullgauge/geometry/camera.h"
#include "hullgauge/geometry/transform.h"

namespace hg::geometry {

enum class FixtureType { RotationDeclination, Rail };
constexpr auto nameTable(FixtureType)
{
    using enum FixtureType;
    return std::to_array<EnumName<FixtureType>>({{RotationDeclination, "rotation_declination"}, {Rail, "rail"}});
}

/// A commanded fixture position. A rotation/declination fixture uses the two
/// angles (degrees), a rail uses `railMm`; the other fields stay zero.
struct FixturePose {
    double rotationDeg = 0.0;
    double declinationDeg = 0.0;
    double railMm = 0.0;

    bool operator==(const FixturePose&) const = default;
};

/// A pose as a fixture of `type` takes it, to be written into text: every
/// message, log and progress line names a pose as fmt::format("{}",
/// PoseOn{pose, type}), "rotation 30 deg, declination 10 deg" (or "rail 120 mm").
struct PoseOn {
    FixturePose pose;
    FixtureType type = FixtureType::RotationDeclination;
};

struct Range {
    double min = 0.0;
    double max = 0.0;
    bool contains(double v, double tol = 1e-9) const { return v >= min - tol && v <= max + tol; }
};

/// A posed camera's lines of sight in the part frame (docs/telecentric.md):
/// through its centre (pinhole) or all parallel to its optical axis (telecentric).
struct SightLines {
    Vec3 centre = Vec3::Zero(); ///< the centre; telecentric: the axis's point on the focus plane
    Vec3 axis = Vec3::UnitZ();  ///< the optical axis (unit)
    bool parallel = false;      ///< telecentric
    /// Unit direction of the line of sight from the camera towards `x`.
    Vec3 towards(const Vec3& x) const { return parallel ? axis : Vec3((x - centre).normalized()); }
    /// How far `x` lies from where the camera sees best: from the centre, or
    /// (telecentric, whose scale does not change with depth) from the plane of
    /// best focus along the axis.
    double distanceTo(const Vec3& x) const { return parallel ? std::abs(axis.dot(x - centre)) : (x - centre).norm(); }
};

class FixtureKinematics {
  public:
    FixtureType type = FixtureType::RotationDeclination;
    RigidTransform cameraFromFixture;
    Vec3 rotationAxis = Vec3::UnitZ();
    Vec3 declinationAxis = Vec3::UnitX();
    /// A point of each axis line in the fixture frame (mm); the origin unless calibrated otherwise.
    Vec3 rotationAxisPoint = Vec3::Zero();
    Vec3 declinationAxisPoint = Vec3::Zero();
    Range rotationRangeDeg{-180.0, 180.0};
    Range declinationRangeDeg{0.0, 60.0};
    Vec3 railAxis = Vec3::UnitZ();
    Range railRangeMm{0.0, 300.0};

    /// The pose of the part in the camera frame at a fixture position.
    RigidTransform cameraFromPart(const FixturePose& pose) const;
    /// True when the fixture can reach `pose` (within its ranges).
    bool reachable(const FixturePose& pose) const;
    /// How the camera on the fixture projects (the station's camera.model):
    /// where its lines of sight come from depends on it.
    Projection cameraProjection = Projection::Pinhole;

    /// Camera centre in the part frame at `pose`: for a telecentric camera,
    /// which has none, the point of its optical axis on the focus plane.
    Vec3 cameraCentreInPart(const FixturePose& pose) const;
    /// The camera's lines of sight at `pose`, part frame.
    SightLines sightLinesAt(const FixturePose& pose) const;
};

} // namespace hg::geometry

template <> struct fmt::formatter<hg::geometry::PoseOn> : hg::ValueFormatter {
    fmt::format_context::iterator format(const hg::geometry::PoseOn& pose, fmt::format_context& ctx) const;
};
