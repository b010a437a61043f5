#include "hgtest/parts.h"

#include "hullgauge/inspect/part_map.h"
#include "hullgauge/model/csg.h"
#include "hullgauge/model/primitives.h"
#include "hullgauge/sim/renderer.h"

#include <algorithm>
#include <cmath>
#include <gtest/gtest.h>
#include <stdexcept>

namespace hgtest {

using Eigen::Vector3d;
using hg::inspect::MapLandmark;
using hg::inspect::MapParameter;
using hg::inspect::ParameterKind;
using hg::model::TriangleMesh;

namespace {

constexpr double kTolerance = 0.3; // mm, every landmark: > 2ΔV, so nominal landmarks must pass

/// The common octree: 32 mm cube at depth 8 (ΔV = 0.125 mm), 7 adjacency
/// layers. The origin sits at fractions .24, .32 and .2 of a voxel below the
/// part's lowest corner, so faces at whole millimetres never fall on a voxel
/// face or mid-plane.
hg::inspect::MapGeometry octree(const Vector3d& partMin)
{
    hg::inspect::MapGeometry g;
    g.cubeOrigin = partMin - Vector3d(1.53, 1.54, 1.525);
    g.cubeSize = 32.0;
    g.depth = 8;
    g.adjacencyDepth = 7;
    g.coarsestLevel = 8;
    return g;
}

TestPart makePart(std::string name, TriangleMesh mesh, std::vector<MapLandmark> landmarks,
                  std::vector<MapParameter> parameters = {})
{
    TestPart p;
    p.name = std::move(name);
    p.solid = std::make_shared<const hg::model::Solid>(mesh);
    p.geometry = octree(mesh.bounds().min());
    p.mesh = std::move(mesh);
    for (MapLandmark& l : landmarks) {
        l.normal.normalize();
        l.toleranceMm = kTolerance;
    }
    p.landmarks = std::move(landmarks);
    p.parameters = std::move(parameters);
    return p;
}

TriangleMesh box(double x0, double y0, double z0, double x1, double y1, double z1)
{
    return hg::model::makeBox({x0, y0, z0}, {x1, y1, z1});
}

constexpr int kFacets = 64; // hole and cup facets: vertices every 5.625°

TriangleMesh holePlate(double r)
{
    return hg::model::difference(box(0, 0, 0, 28, 28, 6), hg::model::makeCylinder({14, 14, -1}, r, 8, kFacets));
}

/// The defect plate with its feature sizes as parameters (nominal: boss x 16..22,
/// boss top 12, hole r 3, no corner cut, no burr; the burr is a 2 x 2 mm pad
/// `burr` mm proud of the -y face).
TriangleMesh defectPlate(double bossX0, double bossTop, double holeR, double cornerCut, double burr)
{
    TriangleMesh m = hg::model::unionOf(box(0, 0, 0, 28, 20, 8), box(bossX0, 7, 8, bossX0 + 6, 13, bossTop));
    m = hg::model::difference(m, hg::model::makeCylinder({8, 10, -1}, holeR, 10, kFacets));
    if (cornerCut > 0) m = hg::model::difference(m, box(28 - cornerCut, 20 - cornerCut, -1, 29, 21, 9));
    if (burr > 0) m = hg::model::unionOf(m, box(21, -burr, 3, 23, 0.01, 5));
    return m;
}

} // namespace

hg::inspect::InspectionMap TestPart::map() const
{
    return hg::inspect::InspectionMap::build(name, geometry, landmarks, parameters, hg::inspect::cadLabels(solid));
}

std::size_t TestPart::landmark(const std::string& id) const
{
    for (std::size_t i = 0; i < landmarks.size(); ++i)
        if (landmarks[i].id == id) return i;
    throw std::out_of_range("test part " + name + " has no landmark " + id);
}

TestPart cubePart()
{
    const double s3 = 1.0 / std::sqrt(3.0);
    return makePart("cube", box(0, 0, 0, 20, 20, 20),
                    {
                        {"face-px", {20, 10, 10}, {1, 0, 0}, 0},
                        {"face-nx", {0, 10, 10}, {-1, 0, 0}, 0},
                        {"face-py", {10, 20, 10}, {0, 1, 0}, 0},
                        {"face-ny", {10, 0, 10}, {0, -1, 0}, 0},
                        {"face-pz", {10, 10, 20}, {0, 0, 1}, 0},
                        {"face-nz", {10, 10, 0}, {0, 0, -1}, 0},
                        {"face-pz-off", {4, 15, 20}, {0, 0, 1}, 0},
                        {"edge-x-top", {20, 10, 20}, {1, 0, 1}, 0},
                        {"edge-y-front", {10, 0, 20}, {0, -1, 1}, 0},
                        {"edge-vertical", {0, 20, 10}, {-1, 1, 0}, 0},
                        {"corner-ppp", {20, 20, 20}, {s3, s3, s3}, 0},
                        {"corner-nnp", {0, 0, 20}, {-s3, -s3, s3}, 0},
                    });
}

TestPart uChannelPart()
{
    return makePart("u-channel", hg::model::difference(box(0, 0, 0, 20, 24, 12), box(5, -1, 4, 15, 25, 13)),
                    {
                        {"out-nx", {0, 12, 6}, {-1, 0, 0}, 0},
                        {"out-px", {20, 12, 6}, {1, 0, 0}, 0},
                        {"out-bottom", {10, 12, 0}, {0, 0, -1}, 0},
                        {"end-ny", {10, 0, 2}, {0, -1, 0}, 0},
                        {"wall-top", {2.5, 12, 12}, {0, 0, 1}, 0},
                        {"in-x0", {5, 12, 8}, {1, 0, 0}, 0},
                        {"in-x1", {15, 12, 8}, {-1, 0, 0}, 0},
                        {"in-floor", {10, 12, 4}, {0, 0, 1}, 0},
                    });
}

TestPart cupPart()
{
    const TriangleMesh cup = hg::model::difference(hg::model::makeCylinder({0, 0, 0}, 10, 14, kFacets),
                                                   hg::model::makeCylinder({0, 0, 2}, 8, 13, kFacets));
    return makePart("cup", cup,
                    {
                        {"outer-0", {10, 0, 7}, {1, 0, 0}, 0},
                        {"outer-90", {0, 10, 7}, {0, 1, 0}, 0},
                        {"rim", {9, 0, 14}, {0, 0, 1}, 0},
                        {"base", {0, 0, 0}, {0, 0, -1}, 0},
                        {"inner-bottom", {0, 0, 2}, {0, 0, 1}, 0},
                    });
}

TestPart postPart()
{
    const TriangleMesh post = hg::model::unionOf(box(0, 0, 0, 24, 24, 4), box(9, 9, 4, 15, 15, 24));
    std::vector<MapParameter> params{
        {"post-perimeter", ParameterKind::Perimeter, {"c-nn", "c-pn", "c-pp", "c-np"}, 24.0, 0.4},
        {"post-area", ParameterKind::Area, {"c-nn", "c-pn", "c-pp", "c-np"}, 36.0, 1.2},
    };
    return makePart("post", post,
                    {
                        {"c-nn", {9, 9, 14}, {-1, -1, 0}, 0},
                        {"c-pn", {15, 9, 14}, {1, -1, 0}, 0},
                        {"c-pp", {15, 15, 14}, {1, 1, 0}, 0},
                        {"c-np", {9, 15, 14}, {-1, 1, 0}, 0},
                    },
                    std::move(params));
}

double polygon16Perimeter(double r)
{
    return 16.0 * 2.0 * r * std::sin(M_PI / 16.0);
}
double polygon16Area(double r)
{
    return 8.0 * r * r * std::sin(2.0 * M_PI / 16.0);
}

TestPart holePlatePart()
{
    std::vector<MapLandmark> lms;
    std::vector<std::string> ids;
    for (int k = 0; k < 16; ++k) {
        const double a = k * M_PI / 8.0; // 22.5°, every fourth facet vertex
        const Vector3d radial(std::cos(a), std::sin(a), 0);
        ids.push_back("h" + std::to_string(k));
        lms.push_back({ids.back(), Vector3d(14, 14, 3) + 6.0 * radial, -radial, 0});
    }
    std::vector<MapParameter> params{
        {"hole-perimeter", ParameterKind::Perimeter, ids, polygon16Perimeter(6.0), 0.5},
        {"hole-area", ParameterKind::Area, ids, polygon16Area(6.0), 3.0},
    };
    return makePart("hole-plate", holePlate(6.0), std::move(lms), std::move(params));
}

TestPart defectPlatePart()
{
    const double r = 1.0 / std::sqrt(2.0);
    return makePart("defect-plate", defectPlate(16, 12, 3, 0, false),
                    {
                        {"boss-px", {22, 10, 10}, {1, 0, 0}, 0},
                        {"boss-nx", {16, 10, 10}, {-1, 0, 0}, 0},
                        {"boss-py", {19, 13, 10}, {0, 1, 0}, 0},
                        {"boss-top", {19, 10, 12}, {0, 0, 1}, 0},
                        {"corner", {28, 20, 4}, {r, r, 0}, 0},
                        {"burr-site", {22, 0, 4}, {0, -1, 0}, 0},
                        {"face-ny", {8, 0, 4}, {0, -1, 0}, 0},
                        {"face-nx", {0, 10, 4}, {-1, 0, 0}, 0},
                        {"face-px", {28, 6, 4}, {1, 0, 0}, 0},
                        {"top", {4, 4, 8}, {0, 0, 1}, 0},
                        {"bottom", {14, 10, 0}, {0, 0, -1}, 0},
                        {"hole-0", {11, 10, 4}, {-1, 0, 0}, 0},
                        {"hole-90", {8, 13, 4}, {0, -1, 0}, 0},
                        {"hole-180", {5, 10, 4}, {1, 0, 0}, 0},
                        {"hole-270", {8, 7, 4}, {0, 1, 0}, 0},
                    });
}

PartAsMade asDesigned(const TestPart& part)
{
    return {"nominal", part.mesh, std::vector<double>(part.landmarks.size(), 0.0)};
}

std::vector<PartAsMade> plateDefects(const TestPart& plate, double d)
{
    auto made = [&](std::string name, TriangleMesh mesh, std::vector<std::pair<std::string, double>> offsets) {
        PartAsMade m{std::move(name), std::move(mesh), std::vector<double>(plate.landmarks.size(), 0.0)};
        for (const auto& [id, e] : offsets) m.offsetMm[plate.landmark(id)] = e;
        return m;
    };
    return {
        // Boss moved +x: its +x face d out, its -x face d in.
        made("feature_shifted", defectPlate(16 + d, 12, 3, 0, 0), {{"boss-px", d}, {"boss-nx", -d}}),
        // The new vertical edge at (28 - c, 20 - c) lies c·√2 = d inside along the bisector.
        made("corner_missing", defectPlate(16, 12, 3, d / std::sqrt(2.0), 0), {{"corner", -d}}),
        made("burr", defectPlate(16, 12, 3, 0, d), {{"burr-site", d}}),
        // Hole radius +d: the wall moves away from the axis, against the
        // landmark normals (which point into the hole). The landmarks sit on
        // facet vertices of both 64-gons, so the offset is exactly radial.
        made("hole_too_large", defectPlate(16, 12, 3 + d, 0, 0),
             {{"hole-0", -d}, {"hole-90", -d}, {"hole-180", -d}, {"hole-270", -d}}),
        made("face_too_low", defectPlate(16, 12 - d, 3, 0, 0), {{"boss-top", -d}}),
    };
}

PartAsMade uChannelInsideBurr(const TestPart& channel)
{
    PartAsMade m{"inside_burr", hg::model::unionOf(channel.mesh, box(14.4, 10, 6, 15.01, 14, 10)),
                 std::vector<double>(channel.landmarks.size(), 0.0)};
    m.offsetMm[channel.landmark("in-x1")] = 0.6; // wall x = 15 (normal -x) now at 14.4
    return m;
}

PartAsMade postWidened(const TestPart& post, double byMm)
{
    const double lo = 9 - byMm, hi = 15 + byMm;
    PartAsMade m{"post_widened", hg::model::unionOf(box(0, 0, 0, 24, 24, 4), box(lo, lo, 4, hi, hi, 24)),
                 std::vector<double>(post.landmarks.size(), byMm * std::sqrt(2.0))};
    return m;
}

PartAsMade holeEnlarged(const TestPart& plate, double byMm)
{
    return {"hole_enlarged", holePlate(6.0 + byMm), std::vector<double>(plate.landmarks.size(), -byMm)};
}

hg::geometry::CameraModel lookAt(const Vector3d& centre, const Vector3d& target, const Vector3d& down,
                                 const CameraSpec& spec)
{
    const Vector3d forward = (target - centre).normalized();
    const Vector3d d = (down - down.dot(forward) * forward).normalized();
    Eigen::Matrix3d R;
    R.row(0) = d.cross(forward).transpose(); // x = y × z
    R.row(1) = d.transpose();
    R.row(2) = forward.transpose();
    hg::geometry::Intrinsics in;
    in.K << spec.focalPx, 0, (spec.imageSize.width - 1) / 2.0, 0, spec.focalPx, (spec.imageSize.height - 1) / 2.0, 0, 0,
        1;
    in.imageSize = spec.imageSize;
    return hg::geometry::CameraModel(in, hg::geometry::RigidTransform{R, -R * centre});
}

namespace {

/// `down` rotated about `forward` by a random roll within ±maxRollDeg.
Vector3d rolled(const Vector3d& down, const Vector3d& forward, double maxRollDeg, std::mt19937_64& rng)
{
    std::uniform_real_distribution<double> roll(-maxRollDeg, maxRollDeg);
    return Eigen::AngleAxisd(roll(rng) * M_PI / 180.0, forward) * down;
}

} // namespace

std::optional<hg::geometry::CameraModel> grazingView(const MapLandmark& lm, const std::vector<Clearance>& clearOf,
                                                     std::mt19937_64& rng, const GrazingOptions& o)
{
    const Vector3d n = lm.normal.normalized();
    const Vector3d u = n.unitOrthogonal(), v = n.cross(u);
    std::uniform_real_distribution<double> distance(o.minDistanceMm, o.maxDistanceMm);
    const double d = distance(rng);
    // The lines of sight from the camera centre through the clearance points, continued 100 mm beyond.
    auto clear = [&](const Vector3d& w) {
        const Vector3d c = lm.position - d * w;
        for (const Clearance& k : clearOf) {
            const Vector3d q = lm.position + (k.offsetMm + o.clearanceMm) * n;
            if (k.solid->segmentHits(c, c + (d + 100.0) * (q - c).normalized())) return false;
        }
        return true;
    };
    // Uniform azimuths first; where only a narrow band is clear (inside a
    // channel or a hole) fall back to the part axes projected into the
    // tangent plane and a 0.05° scan, and draw among the clear ones.
    std::uniform_real_distribution<double> azimuth(0.0, 2.0 * M_PI);
    std::optional<Vector3d> dir;
    for (int i = 0; i < 48 && !dir; ++i) {
        const double a = azimuth(rng);
        const Vector3d w = std::cos(a) * u + std::sin(a) * v;
        if (clear(w)) dir = w;
    }
    if (!dir) {
        std::vector<Vector3d> candidates;
        for (int a = 0; a < 3; ++a) {
            const Vector3d t = Vector3d::Unit(a) - Vector3d::Unit(a).dot(n) * n;
            if (t.norm() < 1e-9) continue;
            for (double sign : {1.0, -1.0})
                if (clear(sign * t.normalized())) candidates.push_back(sign * t.normalized());
        }
        if (candidates.empty())
            for (int k = 0; k < 7200; ++k) {
                const double a = k * M_PI / 3600.0;
                const Vector3d w = std::cos(a) * u + std::sin(a) * v;
                if (clear(w)) candidates.push_back(w);
            }
        if (candidates.empty()) return std::nullopt;
        dir = candidates[std::uniform_int_distribution<std::size_t>(0, candidates.size() - 1)(rng)];
    }
    const Vector3d centre = lm.position - d * *dir;
    return lookAt(centre, lm.position, rolled(-n, *dir, o.maxRollDeg, rng), o.camera);
}

hg::geometry::CameraModel randomView(const Vector3d& target, std::mt19937_64& rng, const GrazingOptions& o)
{
    std::normal_distribution<double> gauss;
    Vector3d w(gauss(rng), gauss(rng), gauss(rng));
    w.normalize();
    std::uniform_real_distribution<double> distance(o.minDistanceMm, o.maxDistanceMm);
    const Vector3d centre = target - distance(rng) * w;
    return lookAt(centre, target, rolled(w.unitOrthogonal(), w, 180.0, rng), o.camera);
}

std::vector<hg::inspect::CapturedView> renderViews(const TriangleMesh& mesh,
                                                   const std::vector<hg::geometry::CameraModel>& cameras,
                                                   double noiseSigma, std::uint64_t seed)
{
    const hg::sim::SilhouetteRenderer renderer({mesh});
    hg::sim::RenderOptions o;
    o.noiseSigma = noiseSigma;
    std::vector<hg::inspect::CapturedView> views;
    for (std::size_t i = 0; i < cameras.size(); ++i) {
        o.seed = seed + i;
        views.push_back({"v" + std::to_string(i), cameras[i], renderer.render(cameras[i], o)});
    }
    return views;
}

std::vector<hg::geometry::CameraModel> grazingViewSet(const TestPart& part, const PartAsMade* asMade, int extraViews,
                                                      std::mt19937_64& rng, const GrazingOptions& options)
{
    std::optional<hg::model::Solid> made;
    if (asMade) made.emplace(asMade->mesh);
    std::vector<hg::geometry::CameraModel> cameras;
    for (std::size_t i = 0; i < part.landmarks.size(); ++i) {
        std::vector<Clearance> clearOf{part.solid.get()};
        if (made) clearOf.emplace_back(&*made, asMade->offsetMm[i]);
        if (auto c = grazingView(part.landmarks[i], clearOf, rng, options)) cameras.push_back(*c);
    }
    const Vector3d centre = part.mesh.bounds().center();
    for (int i = 0; i < extraViews; ++i) cameras.push_back(randomView(centre, rng, options));
    return cameras;
}

void expectJudgedAgainstTruth(const hg::inspect::InspectionResult& r, const TestPart& part, const PartAsMade& asMade,
                              const std::vector<std::string>& skip, const std::vector<std::string>& tips)
{
    using hg::inspect::LandmarkStatus;
    ASSERT_EQ(r.landmarks.size(), part.landmarks.size());
    for (std::size_t i = 0; i < r.landmarks.size(); ++i) {
        const hg::inspect::LandmarkResult& l = r.landmarks[i];
        if (std::find(skip.begin(), skip.end(), l.id) != skip.end()) continue;
        const bool tip = std::find(tips.begin(), tips.end(), l.id) != tips.end();
        const double dv = (tip ? 2.0 : 1.0) * r.voxelSizeMm;
        const double e = asMade.offsetMm[i];
        const std::string where = asMade.name + " " + l.id + " (e = " + std::to_string(e) + " mm, status " +
                                  std::string(hg::enumName(l.status)) + ", " + l.reason + ")";
        ASSERT_TRUE(l.measured) << where;
        EXPECT_LE(l.errorMinMm - dv, std::abs(e)) << where;
        EXPECT_GE(l.errorMaxMm + dv, std::abs(e)) << where;
        EXPECT_LE(l.offsetLowMm - dv, e) << where << " bracket [" << l.offsetLowMm << ", " << l.offsetHighMm << "]";
        EXPECT_GE(l.offsetHighMm + dv, e) << where << " bracket [" << l.offsetLowMm << ", " << l.offsetHighMm << "]";
        if (std::abs(e) > l.toleranceMm + 2 * dv) {
            EXPECT_NE(l.status, LandmarkStatus::Ok) << where;
        }
        if (std::abs(e) < l.toleranceMm - 2 * dv) {
            EXPECT_EQ(l.status, LandmarkStatus::Ok) << where;
        }
    }
}

} // namespace hgtest
