// Geometry values as every JSON document of hullgauge writes them (results,
// plans, manifests, the maintenance status): a vector [x, y, z], a rotation
// matrix as three rows, a fixture pose as the keys of docs/contracts.md §5.
#pragma once

#include <nlohmann/json.hpp>

#include "hullgauge/geometry/fixture.h"
#include "hullgauge/geometry/transform.h"

namespace hg::geometry {

nlohmann::json toJson(const Vec3& v);
/// Three rows.
nlohmann::json toJson(const Mat3& m);
/// {"rotation_deg", "declination_deg"}, or {"rail_mm"} for a rail.
nlohmann::json toJson(const FixturePose& pose, FixtureType type);

} // namespace hg::geometry
