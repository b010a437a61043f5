// Closed, outward-oriented meshes of simple solids with known volume and
// projections; used by tests, benchmarks and the simulated line's parts.
#pragma once

#include "hullgauge/model/mesh.h"

namespace hg::model {

/// Axis-aligned box [min, max] (12 triangles).
TriangleMesh makeBox(const Eigen::Vector3d& min, const Eigen::Vector3d& max);

/// Sphere of `radius` about `centre`: a UV sphere with `segments` around the
/// equator and `rings` from pole to pole, vertices on the sphere (inscribed).
TriangleMesh makeSphere(const Eigen::Vector3d& centre, double radius, int segments = 64, int rings = 32);

/// Cylinder along +z from `base` (centre of the bottom disc) with `height`,
/// `segments` facets around, vertices on the circle (inscribed polygon).
TriangleMesh makeCylinder(const Eigen::Vector3d& base, double radius, double height, int segments = 64);

/// Right prism: the simple polygon `outline` (counter-clockwise in the xy
/// plane, seen from +z) extruded from z = z0 to z = z1.
TriangleMesh makePrism(const std::vector<Eigen::Vector2d>& outline, double z0, double z1);

} // namespace hg::model
