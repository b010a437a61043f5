// Triangle meshes of CAD parts, in millimetres in the part frame.
//
// Orientation convention: triangles are counter-clockwise seen from outside,
// so face normals (v1-v0) x (v2-v0) point out of the solid and a closed mesh
// has positive signed volume.
#pragma once

#include <array>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace hg::model {

struct TriangleMesh {
    std::vector<Eigen::Vector3d> vertices;
    std::vector<std::array<int, 3>> triangles;

    bool empty() const { return triangles.empty(); }
    Eigen::AlignedBox3d bounds() const;
    /// Signed volume by the divergence theorem (positive when oriented outward).
    double signedVolume() const;
    double area() const;
    /// Unit outward normal of triangle `i` (zero for a degenerate triangle).
    Eigen::Vector3d faceNormal(std::size_t i) const;

    /// Appends another mesh (no merging of vertices).
    void append(const TriangleMesh& other);
    /// Applies x -> R x + t to every vertex.
    void transform(const Eigen::Matrix3d& R, const Eigen::Vector3d& t);
    /// Reverses every triangle (flips the orientation).
    void flip();
};

} // namespace hg::model
