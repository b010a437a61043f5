// Exact queries on the ideal CAD solid — the representation map of
// dissertation 5.3.3 and the labels of the octree inspection map (3.3.1).
//
// Built once per part from a closed, outward-oriented mesh (an AABB tree over
// its triangles); every query is evaluated lazily, only for the voxels and
// rays asked for. Thread-safe for concurrent const queries.
#pragma once

#include <memory>
#include <optional>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "hullgauge/model/mesh.h"

namespace hg::model {

/// Where an axis-aligned box lies relative to the solid, decided exactly
/// (exact triangle–box intersection, then a point-in-solid test).
enum class Occupancy { Outside, Inside, Boundary };

/// Inside volume fraction of a box, bracketed: the true fraction lies in
/// [lower, upper]; `estimate` is the best single value.
struct InsideFraction {
    double lower = 0.0;
    double upper = 1.0;
    double estimate = 0.5;
};

struct SurfacePoint {
    Eigen::Vector3d point;
    Eigen::Vector3d normal; // outward unit normal of the nearest triangle
    std::size_t triangle = 0;
    double distance = 0.0; // from the query point
};

struct RayHit {
    double distance = 0.0; // along the unit ray direction
    Eigen::Vector3d point;
    std::size_t triangle = 0;
};

class Solid {
  public:
    /// `mesh` must be closed and outward oriented (see mesh_io.h checkMesh);
    /// a mesh that is not a 2-manifold throws ArgumentError.
    explicit Solid(TriangleMesh mesh);
    ~Solid();
    Solid(Solid&&) noexcept;
    Solid& operator=(Solid&&) noexcept;

    const TriangleMesh& mesh() const;

    /// True inside the solid or on its surface.
    bool contains(const Eigen::Vector3d& point) const;
    /// Classifies the open box (its interior): a box that touches the surface
    /// only with a face, edge or corner is Inside or Outside, not Boundary.
    Occupancy classify(const Eigen::AlignedBox3d& box) const;
    /// Inside volume fraction, refined until the bracket is narrower than
    /// `tolerance` or decides the 50 % question, whichever comes first when
    /// `decideHalf` is set. The fraction is computed in closed form, so the
    /// bracket is always just the floating-point error bound (~1e-12 or
    /// less) whatever `tolerance` asks for.
    InsideFraction insideFraction(const Eigen::AlignedBox3d& box, double tolerance = 1e-3,
                                  bool decideHalf = false) const;
    /// The inspection-map label: object when at least 50 % of the box is inside
    /// (5.3.3); a fraction within rounding error of exactly 50 % is object.
    bool isObjectVoxel(const Eigen::AlignedBox3d& box) const;

    /// Nearest surface point; `normal` is the outward normal of the nearest triangle.
    SurfacePoint closestPoint(const Eigen::Vector3d& point) const;
    /// Outward unit normal at a surface point that may lie on an edge or a
    /// corner: the angle-weighted mean of the normals of the triangles within
    /// `radius` (the face normal inside a face, the bisector on an edge).
    Eigen::Vector3d surfaceNormal(const Eigen::Vector3d& surfacePoint, double radius) const;
    /// First intersection of the ray origin + s * direction (s > 0) with the surface.
    std::optional<RayHit> firstHit(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction) const;
    /// True when the open segment a-b meets the surface.
    bool segmentHits(const Eigen::Vector3d& a, const Eigen::Vector3d& b) const;

  private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

} // namespace hg::model
