#include "hullgauge/model/mesh.h"

namespace hg::model {

Eigen::AlignedBox3d TriangleMesh::bounds() const
{
    Eigen::AlignedBox3d box;
    for (const auto& v : vertices) box.extend(v);
    return box;
}

double TriangleMesh::signedVolume() const
{
    // Sum of signed tetrahedra (origin, v0, v1, v2): divergence theorem.
    double six = 0.0;
    for (const auto& t : triangles) six += vertices[t[0]].dot(vertices[t[1]].cross(vertices[t[2]]));
    return six / 6.0;
}

double TriangleMesh::area() const
{
    double a = 0.0;
    for (const auto& t : triangles)
        a += 0.5 * (vertices[t[1]] - vertices[t[0]]).cross(vertices[t[2]] - vertices[t[0]]).norm();
    return a;
}

Eigen::Vector3d TriangleMesh::faceNormal(std::size_t i) const
{
    const auto& t = triangles[i];
    Eigen::Vector3d n = (vertices[t[1]] - vertices[t[0]]).cross(vertices[t[2]] - vertices[t[0]]);
    double len = n.norm();
    return len > 0 ? Eigen::Vector3d(n / len) : Eigen::Vector3d::Zero();
}

void TriangleMesh::append(const TriangleMesh& other)
{
    int offset = static_cast<int>(vertices.size());
    vertices.insert(vertices.end(), other.vertices.begin(), other.vertices.end());
    for (auto t : other.triangles) triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
}

void TriangleMesh::transform(const Eigen::Matrix3d& R, const Eigen::Vector3d& t)
{
    for (auto& v : vertices) v = R * v + t;
    if (R.determinant() < 0) flip(); // a reflection would turn the solid inside out
}

void TriangleMesh::flip()
{
    for (auto& t : triangles) std::swap(t[1], t[2]);
}

} // namespace hg::model
