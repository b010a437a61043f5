// The planner's problem for the planning tests: a landmark, and a part on a
// station with the map's frame given as a cube (its corner, edge and depth:
// ΔV = edge / 2^depth).
#pragma once

#include "hullgauge/plan/planner.h"

#include <string>
#include <utility>
#include <vector>

namespace hg::plan::test {

inline PlanLandmark landmark(std::string id, Vec3 p, Vec3 n, double tol)
{
    PlanLandmark l;
    l.id = std::move(id);
    l.position = p;
    l.normal = n.normalized();
    l.toleranceMm = tol;
    return l;
}

inline PlanProblem problemFor(const model::Solid& solid, const geometry::Station& station,
                              std::vector<PlanLandmark> lms, const Vec3& cubeCorner, double cubeMm, int depth)
{
    PlanProblem p;
    p.part = "test";
    p.solid = &solid;
    p.station = &station;
    p.frame = {cubeCorner, cubeMm, depth};
    p.landmarks = std::move(lms);
    return p;
}

} // namespace hg::plan::test
