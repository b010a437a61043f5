#include "hullgauge/geometry/json.h"

namespace hg::geometry {

nlohmann::json toJson(const Vec3& v)
{
    return nlohmann::json::array({v.x(), v.y(), v.z()});
}

nlohmann::json toJson(const Mat3& m)
{
    nlohmann::json rows = nlohmann::json::array();
    for (int r = 0; r < 3; ++r) rows.push_back(nlohmann::json::array({m(r, 0), m(r, 1), m(r, 2)}));
    return rows;
}

nlohmann::json toJson(const FixturePose& pose, FixtureType type)
{
    if (type == FixtureType::Rail) return {{"rail_mm", pose.railMm}};
    return {{"rotation_deg", pose.rotationDeg}, {"declination_deg", pose.declinationDeg}};
}

} // namespace hg::geometry
