#include "hullgauge/workbench/placement.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <unordered_map>

namespace hg::workbench {
namespace {

std::uint64_t edgeKey(int a, int b)
{
    const auto lo = static_cast<std::uint32_t>(std::min(a, b));
    const auto hi = static_cast<std::uint32_t>(std::max(a, b));
    return (std::uint64_t(lo) << 32) | hi;
}

/// The point of segment a-b nearest to p.
Eigen::Vector3d nearestOnSegment(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b)
{
    const Eigen::Vector3d ab = b - a;
    const double len2 = ab.squaredNorm();
    if (len2 <= 0.0) return a;
    const double s = std::clamp((p - a).dot(ab) / len2, 0.0, 1.0);
    return a + s * ab;
}

/// A corner: three or more sharp edges meet at the vertex, or two whose
/// directions turn by more than the sharp angle (the end of a feature line
/// that bends, e.g. where a box's outline turns).
bool isCorner(const model::TriangleMesh& mesh, int vertex, const std::vector<int>& others, double cosSharp)
{
    if (others.size() >= 3) return true;
    if (others.size() != 2) return false;
    const Eigen::Vector3d& v = mesh.vertices[static_cast<std::size_t>(vertex)];
    const Eigen::Vector3d in = (v - mesh.vertices[static_cast<std::size_t>(others[0])]).normalized();
    const Eigen::Vector3d out = (mesh.vertices[static_cast<std::size_t>(others[1])] - v).normalized();
    return in.dot(out) < cosSharp;
}

} // namespace

SharpFeatures sharpFeatures(const model::TriangleMesh& mesh, double angleDeg)
{
    std::unordered_map<std::uint64_t, std::vector<std::size_t>> faces;
    faces.reserve(mesh.triangles.size() * 2);
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
        const auto& tri = mesh.triangles[t];
        for (int k = 0; k < 3; ++k) faces[edgeKey(tri[k], tri[(k + 1) % 3])].push_back(t);
    }
    const double cosSharp = std::cos(angleDeg * std::numbers::pi / 180.0);
    SharpFeatures out;
    std::unordered_map<int, std::vector<int>> incident;
    for (const auto& [key, tris] : faces) {
        if (tris.size() != 2) continue;
        const Eigen::Vector3d n0 = mesh.faceNormal(tris[0]), n1 = mesh.faceNormal(tris[1]);
        if (n0.squaredNorm() == 0.0 || n1.squaredNorm() == 0.0 || n0.dot(n1) >= cosSharp) continue;
        const int a = static_cast<int>(key >> 32), b = static_cast<int>(key & 0xffffffffu);
        out.edges.push_back({mesh.vertices[static_cast<std::size_t>(a)], mesh.vertices[static_cast<std::size_t>(b)]});
        incident[a].push_back(b);
        incident[b].push_back(a);
    }
    for (const auto& [vertex, others] : incident)
        if (isCorner(mesh, vertex, others, cosSharp))
            out.corners.push_back(mesh.vertices[static_cast<std::size_t>(vertex)]);
    // The map's order is the hash's: sort so that ties resolve the same way every run.
    auto less = [](const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
        return std::lexicographical_compare(a.data(), a.data() + 3, b.data(), b.data() + 3);
    };
    std::sort(out.corners.begin(), out.corners.end(), less);
    std::sort(out.edges.begin(), out.edges.end(),
              [&](const auto& e, const auto& f) { return less(e[0], f[0]) || (e[0] == f[0] && less(e[1], f[1])); });
    return out;
}

double snapDistanceMm(const Eigen::AlignedBox3d& bounds)
{
    return kSnapShareOfDiagonal * (bounds.max() - bounds.min()).norm();
}

Snapped snapToFeature(const Eigen::Vector3d& surfacePoint, const SharpFeatures& features, double snapMm)
{
    double best = std::numeric_limits<double>::infinity();
    Snapped out{surfacePoint, Placement::Face};
    for (const Eigen::Vector3d& c : features.corners) {
        const double d = (c - surfacePoint).norm();
        if (d <= snapMm && d < best) {
            best = d;
            out = {c, Placement::Corner};
        }
    }
    if (out.on == Placement::Corner) return out;
    for (const auto& e : features.edges) {
        const Eigen::Vector3d q = nearestOnSegment(surfacePoint, e[0], e[1]);
        const double d = (q - surfacePoint).norm();
        if (d <= snapMm && d < best) {
            best = d;
            out = {q, Placement::Edge};
        }
    }
    return out;
}

Placement classify(const Eigen::Vector3d& position, const SharpFeatures& features, double toleranceMm)
{
    for (const Eigen::Vector3d& c : features.corners)
        if ((c - position).norm() <= toleranceMm) return Placement::Corner;
    for (const auto& e : features.edges)
        if ((nearestOnSegment(position, e[0], e[1]) - position).norm() <= toleranceMm) return Placement::Edge;
    return Placement::Face;
}

} // namespace hg::workbench
