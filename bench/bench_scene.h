// The benchmarks' part and views, shared by bench_inspect and bench_open3d:
// a 40 x 40 x 20 mm block in a 64 mm part cube, n x n landmarks on its top
// face, and `views` cameras in the face's tangent plane (grazing views)
// around it, 400 mm away, f = 3500 px.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "hullgauge/inspect/inspector.h"
#include "hullgauge/inspect/part_map.h"
#include "hullgauge/model/primitives.h"
#include "hullgauge/model/solid.h"
#include "hullgauge/sim/renderer.h"

namespace hgbench {

constexpr double kTop = 20.0;
inline const Eigen::Vector3d kCubeOrigin(-12, -12, -22);
constexpr double kCubeSize = 64.0;

/// A camera at `centre` looking along unit `forward`, image-down `down`
/// (unit, orthogonal to forward), f = 3500 px, principal point centred.
inline hg::geometry::CameraModel camera(const Eigen::Vector3d& centre, const Eigen::Vector3d& forward,
                                        const Eigen::Vector3d& down, cv::Size size)
{
    Eigen::Matrix3d R;
    R.row(0) = down.cross(forward).transpose();
    R.row(1) = down.transpose();
    R.row(2) = forward.transpose();
    hg::geometry::Intrinsics in;
    in.K << 3500, 0, (size.width - 1) / 2.0, 0, 3500, (size.height - 1) / 2.0, 0, 0, 1;
    in.imageSize = size;
    return {in, {R, -R * centre}};
}

/// A camera at `centre` looking along unit `forward` with image-down the
/// world −z made orthogonal to the line of sight (upright images).
inline hg::geometry::CameraModel upright(const Eigen::Vector3d& centre, const Eigen::Vector3d& forward, cv::Size size)
{
    const Eigen::Vector3d minusZ(0, 0, -1);
    return camera(centre, forward, (minusZ - minusZ.dot(forward) * forward).normalized(), size);
}

/// A level camera at `centre` looking along horizontal `forward`.
inline hg::geometry::CameraModel lookAt(const Eigen::Vector3d& centre, const Eigen::Vector3d& forward, cv::Size size)
{
    return upright(centre, forward, size);
}

/// The telecentric camera (docs/telecentric.md) along `pinhole`'s optical
/// axis with the same scale at `target` (a point of that axis, on its focus
/// plane): fx / distance pixels per millimetre at every depth.
inline hg::geometry::CameraModel telecentricAt(const hg::geometry::CameraModel& pinhole, const Eigen::Vector3d& target)
{
    hg::geometry::Intrinsics in = pinhole.intrinsics();
    in.projection = hg::geometry::Projection::Telecentric;
    const double distance = pinhole.rangeTo(target);
    in.K(0, 0) /= distance;
    in.K(1, 1) /= distance;
    const Eigen::Matrix3d& R = pinhole.cameraFromPart().R;
    return {in, {R, -R * target}};
}

inline hg::model::TriangleMesh block(double raise = 0.0)
{
    return hg::model::makeBox({0, 0, 0}, {40, 40, kTop + raise});
}

struct Scene {
    hg::inspect::InspectionMap map;
    std::vector<hg::inspect::CapturedView> frames;

    /// `seat` (nominal_from_part, docs/alignment.md): the block is rendered
    /// seated so, the frames keep the nominal cameras. `telecentric`: each
    /// view a telecentric camera along the same axis with the pinhole's scale
    /// at the top face's middle.
    Scene(int n, int views, cv::Size size, double raise, int depth = 9, double distance = 400.0,
          const hg::geometry::RigidTransform& seat = {}, bool telecentric = false)
    {
        using namespace hg::inspect;
        auto solid = std::make_shared<const hg::model::Solid>(block());
        MapGeometry g;
        g.cubeOrigin = kCubeOrigin;
        g.cubeSize = kCubeSize;
        g.depth = depth; // ΔV = 0.125 mm at depth 9
        g.adjacencyDepth = 4;
        g.coarsestLevel = depth;
        std::vector<MapLandmark> lms;
        for (int i = 0; i < n; ++i)
            for (int j = 0; j < n; ++j)
                lms.push_back(
                    {"l" + std::to_string(i * n + j),
                     Eigen::Vector3d(5.0 + 30.0 * i / std::max(1, n - 1), 5.0 + 30.0 * j / std::max(1, n - 1), kTop),
                     Eigen::Vector3d::UnitZ(), 0.3});
        map = InspectionMap::build("block", g, lms, {}, cadLabels(solid));
        hg::sim::SilhouetteRenderer r({block(raise)});
        for (int v = 0; v < views; ++v) {
            const double a = 2 * M_PI * v / views;
            const Eigen::Vector3d dir(std::cos(a), std::sin(a), 0);
            const Eigen::Vector3d middle(20, 20, kTop);
            const auto pinhole = lookAt(middle + distance * dir, -dir, size);
            const auto cam = telecentric ? telecentricAt(pinhole, middle) : pinhole;
            const hg::geometry::CameraModel seated(cam.intrinsics(), cam.cameraFromPart() * seat);
            frames.push_back({"v" + std::to_string(v), cam, r.render(seated)});
        }
    }
};

/// The block's four top corners as landmarks (normals along the body
/// diagonals), seen from two grazing views each — the camera centre in the
/// corner's tangent plane, 400 mm out along (n × z) and along n's in-plane
/// downward direction — rendered with the block grown by `grow` on every side
/// (true offset at each corner: √3·grow along its normal).
struct CornerScene {
    hg::inspect::InspectionMap map;
    std::vector<hg::inspect::CapturedView> frames;

    explicit CornerScene(double grow, cv::Size size = {1224, 1024}, int depth = 9)
    {
        using namespace hg::inspect;
        auto solid = std::make_shared<const hg::model::Solid>(block());
        MapGeometry g;
        g.cubeOrigin = kCubeOrigin;
        g.cubeSize = kCubeSize;
        g.depth = depth;
        g.adjacencyDepth = 6;
        g.coarsestLevel = depth;
        std::vector<MapLandmark> lms;
        hg::sim::SilhouetteRenderer r(
            {hg::model::makeBox(Eigen::Vector3d::Constant(-grow), Eigen::Vector3d(40 + grow, 40 + grow, kTop + grow))});
        for (int c = 0; c < 4; ++c) {
            const double sx = (c & 1) ? 1.0 : -1.0, sy = (c & 2) ? 1.0 : -1.0;
            const Eigen::Vector3d p(sx > 0 ? 40 : 0, sy > 0 ? 40 : 0, kTop);
            const Eigen::Vector3d n = Eigen::Vector3d(sx, sy, 1).normalized();
            lms.push_back({"corner" + std::to_string(c), p, n, 0.3});
            const Eigen::Vector3d d1 = n.cross(Eigen::Vector3d::UnitZ()).normalized();
            const Eigen::Vector3d d2 = n.cross(d1).normalized(); // in the plane, pointing down and outwards
            for (const Eigen::Vector3d& d : {d1, d2}) {
                const auto cam = upright(p + 400 * d, -d, size);
                frames.push_back({"c" + std::to_string(frames.size()), cam, r.render(cam)});
            }
        }
        map = InspectionMap::build("block-corners", g, lms, {}, cadLabels(solid));
    }
};

/// An upright camera looking at `target` from `distance` at azimuth/elevation
/// (degrees).
inline hg::geometry::CameraModel orbit(const Eigen::Vector3d& target, double azimuthDeg, double elevationDeg,
                                       double distance, cv::Size size)
{
    const double a = azimuthDeg * M_PI / 180, e = elevationDeg * M_PI / 180;
    const Eigen::Vector3d dir(std::cos(e) * std::cos(a), std::cos(e) * std::sin(a), std::sin(e));
    return upright(target + distance * dir, -dir, size);
}

/// Whole-object reconstruction views of the block (16): 4 along its side
/// faces, and 4 azimuths at each of the elevations −35°, 10° and 55°,
/// staggered, so top, bottom, sides and edges are all cut.
inline std::vector<hg::inspect::CapturedView> carvingViews(cv::Size size)
{
    hg::sim::SilhouetteRenderer r({block()});
    std::vector<hg::inspect::CapturedView> out;
    for (int i = 0; i < 4; ++i) {
        const auto cam = orbit({20, 20, kTop / 2}, 90.0 * i, 0.0, 400.0, size);
        out.push_back({"c" + std::to_string(out.size()), cam, r.render(cam)});
    }
    const double elevations[] = {-35.0, 10.0, 55.0};
    for (int k = 0; k < 3; ++k)
        for (int i = 0; i < 4; ++i) {
            const auto cam = orbit({20, 20, kTop / 2}, 90.0 * i + 30.0 * k + 15.0, elevations[k], 400.0, size);
            out.push_back({"c" + std::to_string(out.size()), cam, r.render(cam)});
        }
    return out;
}

/// True-solid label of a voxel of the block: object when >= 50 % of it lies
/// inside [0,40] x [0,40] x [0,20] (analytic: the product of 1-D overlaps).
inline bool trulyObject(const Eigen::AlignedBox3d& b)
{
    const Eigen::Vector3d hi(40, 40, kTop);
    double f = 1.0;
    for (int a = 0; a < 3; ++a)
        f *= std::max(0.0, std::min(b.max()[a], hi[a]) - std::max(b.min()[a], 0.0)) / b.sizes()[a];
    return f >= 0.5;
}

/// A dense voxel grid over the part cube at `depth` (index (i, j, k) at
/// (i·n + j)·n + k, n = 2^depth), one byte per voxel: 1 = reconstructed object.
struct DenseGrid {
    int depth;
    int n;
    std::vector<std::uint8_t> object;
    explicit DenseGrid(int d) : depth(d), n(1 << d), object(static_cast<std::size_t>(n) * n * n, 0) {}
    void set(const Eigen::Vector3i& v) { object[(static_cast<std::size_t>(v.x()) * n + v.y()) * n + v.z()] = 1; }
    double voxelSize() const { return kCubeSize / n; }
};

/// Voxels of a reconstruction that disagree with the true solid.
struct Disagreement {
    std::uint64_t extra = 0;   ///< reconstructed object, truly void
    std::uint64_t missing = 0; ///< truly object, reconstructed void
    std::uint64_t object = 0;  ///< reconstructed object voxels
};

inline Disagreement compareWithTruth(const DenseGrid& g)
{
    Disagreement d;
    const double dv = g.voxelSize();
    for (int i = 0; i < g.n; ++i)
        for (int j = 0; j < g.n; ++j)
            for (int k = 0; k < g.n; ++k) {
                const Eigen::Vector3d lo = kCubeOrigin + dv * Eigen::Vector3d(i, j, k);
                const bool truth = trulyObject(Eigen::AlignedBox3d(lo, lo + Eigen::Vector3d::Constant(dv)));
                const bool got = g.object[(static_cast<std::size_t>(i) * g.n + j) * g.n + k] != 0;
                d.extra += got && !truth;
                d.missing += truth && !got;
                d.object += got;
            }
    return d;
}

} // namespace hgbench
