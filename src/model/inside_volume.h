// Exact volume of a closed, outward-oriented triangle mesh inside an axis box
// (internal to the model module; Solid::insideFraction is the public face).
#pragma once

#include <array>
#include <cstddef>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace hg::model::detail {

struct BoxVolume {
    double volume = 0.0;     // mm³ of the solid inside the box
    double errorBound = 0.0; // bound on the floating-point error of `volume`, mm³
};

/// Volume of the solid bounded by `triangles` inside `box`.
///
/// `candidates` must hold every triangle that meets the closed box or the
/// corner line {x = box.max.x, y = box.max.y, z <= box.max.z}; other
/// triangles contribute nothing, extra ones are harmless.
BoxVolume insideVolume(const std::vector<Eigen::Vector3d>& vertices, const std::vector<std::array<int, 3>>& triangles,
                       const std::vector<std::size_t>& candidates, const Eigen::AlignedBox3d& box);

} // namespace hg::model::detail
