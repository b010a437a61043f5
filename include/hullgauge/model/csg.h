// Boolean operations on closed meshes, for making defective parts from a
// nominal CAD model (material missing at a corner, a hole drilled too large):
// `hullgauge simulate --subtract`. Exact: CGAL corefinement with an exact
// kernel, so coplanar faces and shared edges are handled robustly.
#pragma once

#include "hullgauge/model/mesh.h"

#include <vector>

namespace hg::model {

/// a minus b. Both must be closed, outward-oriented 2-manifolds without
/// self-intersections; the result is one as well (possibly empty). Failure
/// (a non-manifold result) throws InputError naming the operation.
TriangleMesh difference(const TriangleMesh& a, const TriangleMesh& b);

/// a less every cutter in turn, exact from the first cut to the last (the
/// intermediate results are never rounded), under the same conditions.
TriangleMesh difference(const TriangleMesh& a, const std::vector<TriangleMesh>& cutters);

/// a united with b, under the same conditions.
TriangleMesh unionOf(const TriangleMesh& a, const TriangleMesh& b);

/// a intersected with b, under the same conditions.
TriangleMesh intersectionOf(const TriangleMesh& a, const TriangleMesh& b);

} // namespace hg::model
