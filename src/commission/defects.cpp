#include "hullgauge/commission/defects.h"

#include "hullgauge/model/csg.h"
#include "hullgauge/model/primitives.h"

#include <algorithm>
#include <cmath>

namespace hg::commission {
namespace {

/// A right-handed frame (t1, t2, n) whose first axis is `along` made square to
/// n, or any vector square to n when `along` has no part in the tangent plane.
Eigen::Matrix3d tangentFrame(const Eigen::Vector3d& n, const Eigen::Vector3d& along)
{
    Eigen::Vector3d t1 = along - along.dot(n) * n;
    if (t1.norm() < 1e-9) {
        const Eigen::Vector3d helper = std::abs(n.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
        t1 = n.cross(helper);
    }
    t1.normalize();
    Eigen::Matrix3d R;
    R << t1, n.cross(t1), n;
    return R;
}

} // namespace

model::TriangleMesh defectBox(const Eigen::Vector3d& landmark, const Eigen::Vector3d& normal,
                              const SeededDefect& defect, double halfWidthMm, const Eigen::Vector3d& along,
                              double halfLengthMm)
{
    const Eigen::Vector3d n = normal.normalized();
    const Eigen::Matrix3d R = tangentFrame(n, along);
    const double halfLength = along.norm() > 0.0 ? std::max(halfLengthMm, halfWidthMm) : halfWidthMm;
    // Removed: from the plane at −depth out past the surface by the patch's
    // half-width (not farther: across a bore it would reach the far wall).
    // Added: from inside the material (so the union holds together) out to +depth.
    const double reach = std::max(halfWidthMm, 2.0 * defect.depthMm);
    const double low = defect.kind == DefectKind::Removed ? -defect.depthMm : -reach;
    const double high = defect.kind == DefectKind::Removed ? reach : defect.depthMm;
    model::TriangleMesh box =
        model::makeBox(Eigen::Vector3d(-halfLength, -halfWidthMm, low), Eigen::Vector3d(halfLength, halfWidthMm, high));
    box.transform(R, landmark);
    return box;
}

model::TriangleMesh seedDefect(const model::TriangleMesh& nominal, const Eigen::Vector3d& landmark,
                               const Eigen::Vector3d& normal, const SeededDefect& defect, double halfWidthMm,
                               const std::vector<Eigen::Vector3d>& sightDirections)
{
    if (defect.kind == DefectKind::Added)
        return model::unionOf(nominal, defectBox(landmark, normal, defect, halfWidthMm));
    if (sightDirections.empty()) return model::difference(nominal, defectBox(landmark, normal, defect, halfWidthMm));
    // Along each line of sight, as far as the part reaches from the landmark;
    // lines of sight whose cut runs the same way (within 1°, either sense)
    // give the same box and are cut once.
    const double length = nominal.bounds().diagonal().norm();
    const Eigen::Vector3d n = normal.normalized();
    std::vector<Eigen::Vector3d> ways;
    for (const Eigen::Vector3d& sight : sightDirections) {
        Eigen::Vector3d t = sight - sight.dot(n) * n;
        if (t.norm() < 1e-9) continue;
        t.normalize();
        const bool seen = std::any_of(ways.begin(), ways.end(), [&](const Eigen::Vector3d& w) {
            return std::abs(w.dot(t)) > std::cos(1.0 * 3.14159265358979323846 / 180.0);
        });
        if (!seen) ways.push_back(t);
    }
    if (ways.empty()) return model::difference(nominal, defectBox(landmark, normal, defect, halfWidthMm));
    std::vector<model::TriangleMesh> cuts;
    for (const Eigen::Vector3d& way : ways)
        cuts.push_back(defectBox(landmark, normal, defect, halfWidthMm, way, length));
    return model::difference(nominal, cuts);
}

} // namespace hg::commission
