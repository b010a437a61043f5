#include "hullgauge/model/primitives.h"

#include "hullgauge/common/error.h"
#include "hullgauge/common/format.h"

#include <cmath>
#include <string>

namespace hg::model {
namespace {
constexpr double kPi = 3.14159265358979323846;
}

TriangleMesh makeBox(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi)
{
    TriangleMesh m;
    for (int i = 0; i < 8; ++i)
        m.vertices.emplace_back((i & 1) ? hi.x() : lo.x(), (i & 2) ? hi.y() : lo.y(), (i & 4) ? hi.z() : lo.z());
    // Quads listed counter-clockwise seen from outside.
    const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
    for (const auto& q : quads) {
        m.triangles.push_back({q[0], q[1], q[2]});
        m.triangles.push_back({q[0], q[2], q[3]});
    }
    return m;
}

TriangleMesh makeSphere(const Eigen::Vector3d& c, double r, int segments, int rings)
{
    if (segments < 3 || rings < 2)
        throw ArgumentError("makeSphere: need segments >= 3 and rings >= 2, found segments " +
                            std::to_string(segments) + ", rings " + std::to_string(rings));
    TriangleMesh m;
    m.vertices.push_back(c + Eigen::Vector3d(0, 0, r)); // north pole
    for (int i = 1; i < rings; ++i) {
        double theta = kPi * i / rings;
        for (int j = 0; j < segments; ++j) {
            double phi = 2 * kPi * j / segments;
            m.vertices.push_back(c + r * Eigen::Vector3d(std::sin(theta) * std::cos(phi),
                                                         std::sin(theta) * std::sin(phi), std::cos(theta)));
        }
    }
    m.vertices.push_back(c - Eigen::Vector3d(0, 0, r)); // south pole
    const int south = static_cast<int>(m.vertices.size()) - 1;
    auto at = [&](int ring, int seg) { return 1 + (ring - 1) * segments + (seg % segments); };
    for (int j = 0; j < segments; ++j) m.triangles.push_back({0, at(1, j), at(1, j + 1)});
    for (int i = 1; i < rings - 1; ++i)
        for (int j = 0; j < segments; ++j) {
            m.triangles.push_back({at(i, j), at(i + 1, j), at(i + 1, j + 1)});
            m.triangles.push_back({at(i, j), at(i + 1, j + 1), at(i, j + 1)});
        }
    for (int j = 0; j < segments; ++j) m.triangles.push_back({south, at(rings - 1, j + 1), at(rings - 1, j)});
    return m;
}

TriangleMesh makeCylinder(const Eigen::Vector3d& base, double radius, double height, int segments)
{
    std::vector<Eigen::Vector2d> outline;
    for (int j = 0; j < segments; ++j) {
        double phi = 2 * kPi * j / segments;
        outline.emplace_back(base.x() + radius * std::cos(phi), base.y() + radius * std::sin(phi));
    }
    return makePrism(outline, base.z(), base.z() + height);
}

TriangleMesh makePrism(const std::vector<Eigen::Vector2d>& outline, double z0, double z1)
{
    const int n = static_cast<int>(outline.size());
    if (n < 3 || !(z1 > z0))
        throw ArgumentError("makePrism: need >= 3 outline points and z1 > z0, found " + std::to_string(n) +
                            " points, z0 " + formatNumber(z0) + ", z1 " + formatNumber(z1));
    TriangleMesh m;
    for (const auto& p : outline) m.vertices.emplace_back(p.x(), p.y(), z0);
    for (const auto& p : outline) m.vertices.emplace_back(p.x(), p.y(), z1);
    // Caps by ear clipping, so concave outlines (U channels, stamps) work.
    std::vector<int> idx(n);
    for (int i = 0; i < n; ++i) idx[i] = i;
    auto cross = [&](int a, int b, int c) {
        Eigen::Vector2d u = outline[b] - outline[a], v = outline[c] - outline[a];
        return u.x() * v.y() - u.y() * v.x();
    };
    auto inside = [&](int p, int a, int b, int c) {
        return cross(a, b, p) >= 0 && cross(b, c, p) >= 0 && cross(c, a, p) >= 0;
    };
    std::vector<std::array<int, 3>> cap;
    int guard = 0;
    while (idx.size() > 3 && guard++ < n * n) {
        bool clipped = false;
        for (std::size_t k = 0; k < idx.size(); ++k) {
            int a = idx[(k + idx.size() - 1) % idx.size()], b = idx[k], c = idx[(k + 1) % idx.size()];
            if (cross(a, b, c) <= 0) continue; // reflex vertex
            bool ear = true;
            for (int p : idx)
                if (p != a && p != b && p != c && inside(p, a, b, c)) {
                    ear = false;
                    break;
                }
            if (!ear) continue;
            cap.push_back({a, b, c});
            idx.erase(idx.begin() + static_cast<long>(k));
            clipped = true;
            break;
        }
        if (!clipped)
            throw ArgumentError("makePrism: outline: its " + std::to_string(n) +
                                " points are not a simple counter-clockwise polygon");
    }
    cap.push_back({idx[0], idx[1], idx[2]});
    for (const auto& t : cap) {
        m.triangles.push_back({t[0] + n, t[1] + n, t[2] + n}); // top, seen from +z: CCW
        m.triangles.push_back({t[0], t[2], t[1]});             // bottom, reversed
    }
    for (int i = 0; i < n; ++i) {
        int j = (i + 1) % n;
        m.triangles.push_back({i, j, j + n});
        m.triangles.push_back({i, j + n, i + n});
    }
    return m;
}

} // namespace hg::model
