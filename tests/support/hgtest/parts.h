// Test parts: the dissertation's objects (cube, open U channel, handleless
// cup, post of fig. 3.5, circular hole of fig. 3.6) and a plate carrying the
// defect list, as CAD meshes with the designer's landmarks; defective parts
// made from the CAD with csg.h, each with the true offset of its surface at
// every landmark computed from the defect geometry; and the analytic grazing
// views of docs/architecture.md ("perspective and grazing views").
//
// Every part fits the same octree: a 32 mm cube at depth 8 (ΔV = 0.125 mm),
// 6 adjacency layers, its origin placed so that no nominal face lies on a
// voxel face or mid-plane. Units: mm, part frame.
#pragma once

#include "hullgauge/geometry/camera.h"
#include "hullgauge/inspect/inspection_map.h"
#include "hullgauge/inspect/inspector.h"
#include "hullgauge/model/mesh.h"
#include "hullgauge/model/solid.h"

#include <cstdint>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <vector>

namespace hgtest {

struct TestPart {
    std::string name;
    hg::model::TriangleMesh mesh; ///< nominal CAD
    std::shared_ptr<const hg::model::Solid> solid;
    std::vector<hg::inspect::MapLandmark> landmarks;
    std::vector<hg::inspect::MapParameter> parameters;
    hg::inspect::MapGeometry geometry;

    /// The inspection map, labels from the CAD (hg::inspect::cadLabels).
    hg::inspect::InspectionMap map() const;
    /// Index of a landmark by id; throws std::out_of_range.
    std::size_t landmark(const std::string& id) const;
};

/// 20 mm cube [0, 20]³: landmarks at face centres and off-centre face
/// points, on edges (bisector normals) and at corners ((±1, ±1, ±1)/√3).
TestPart cubePart();
/// Open U channel along y: [0, 20] x [0, 24] x [0, 12] less the slot
/// [5, 15] x all y x [4, 12] — weakly convex, not convex. Landmarks on the
/// outside and on the three inside faces ("in-x0", "in-x1", "in-floor").
TestPart uChannelPart();
/// Handleless cup: a cylinder r = 10, h = 14 (64 facets) less r = 8 from
/// z = 2 up. "inner-bottom" at (0, 0, 2) cannot be reconstructed from any view.
TestPart cupPart();
/// Fig. 3.5: a 6 x 6 mm post [9, 15]² x [4, 24] on a 24 x 24 x 4 mm base;
/// four landmarks on its vertical edges at mid-height (bisector normals),
/// with the perimeter (24 mm) and area (36 mm²) of the square through them.
TestPart postPart();
/// Fig. 3.6: a 28 x 28 x 6 mm plate with a through hole r = 6 (64 facets,
/// vertices at multiples of 5.625°) about (14, 14); 16 landmarks at 22.5° on
/// the wall at mid-thickness, normals pointing into the hole (out of the
/// material), and the perimeter and area of the 16-gon through them.
TestPart holePlatePart();
/// Perimeter and area of the regular 16-gon inscribed in a circle of radius r.
double polygon16Perimeter(double r);
double polygon16Area(double r);

/// The plate of the defect list: block [0, 28] x [0, 20] x [0, 8], a boss
/// [16, 22] x [7, 13] x [8, 12] on top, a through hole r = 3 about (8, 10).
TestPart defectPlatePart();

/// A part as made: its mesh and, for every landmark of the nominal part, the
/// true signed offset e (mm) of the surface along the landmark's outward
/// normal (positive = material added), derived by hand from the geometry.
struct PartAsMade {
    std::string name;
    hg::model::TriangleMesh mesh;
    std::vector<double> offsetMm;
};

/// The nominal part as made (all offsets zero).
PartAsMade asDesigned(const TestPart& part);
/// The defect list on defectPlatePart(), each moving its landmarks' surface
/// by `sizeMm`: "feature_shifted" (boss +size in x: boss-px +size, boss-nx
/// −size), "corner_missing" (the vertical edge at (28, 20) cut back size/√2 in
/// x and y: corner −size along its bisector), "burr" (size proud of the −y
/// face around burr-site), "hole_too_large" (r + size: hole-* −size),
/// "face_too_low" (boss top size low: boss-top −size).
std::vector<PartAsMade> plateDefects(const TestPart& plate, double sizeMm = 0.65);
/// uChannelPart() with a 0.6 mm burr on the inside wall x = 15 around "in-x1".
PartAsMade uChannelInsideBurr(const TestPart& channel);
/// postPart() with every side moved out by `byMm` (corner offsets byMm·√2).
PartAsMade postWidened(const TestPart& post, double byMm);
/// holePlatePart() with the hole radius larger by `byMm` (offsets -byMm).
PartAsMade holeEnlarged(const TestPart& plate, double byMm);

/// Camera intrinsics of the test views: f = 3500 px, 640 x 480, centred.
struct CameraSpec {
    double focalPx = 3500.0;
    cv::Size imageSize{640, 480};
};

/// A camera at `centre` looking at `target`; image down is `down` made
/// orthogonal to the viewing direction.
hg::geometry::CameraModel lookAt(const Eigen::Vector3d& centre, const Eigen::Vector3d& target,
                                 const Eigen::Vector3d& down, const CameraSpec& spec = {});

/// How grazing views are drawn.
struct GrazingOptions {
    double minDistanceMm = 260.0; ///< camera centre to landmark, uniform in [min, max]
    double maxDistanceMm = 380.0;
    double maxRollDeg = 20.0; ///< random roll about the viewing direction
    /// The line of sight through landmark + clearance·normal must miss the
    /// part: then the void next to the landmark shows as background.
    double clearanceMm = 0.03;
    CameraSpec camera;
};

/// A solid the grazing line of sight must miss, and where it passes: through
/// landmark + (offsetMm + clearance)·normal — the void just outside the
/// nominal surface (offset 0) or outside the surface as made (offset e).
struct Clearance {
    Clearance(const hg::model::Solid* s, double offset = 0.0) : solid(s), offsetMm(offset) {}
    const hg::model::Solid* solid;
    double offsetMm;
};

/// A grazing view of `landmark` (docs/architecture.md): the camera centre lies in
/// the landmark's tangent plane, at a random azimuth within it and a random
/// distance, looking at the landmark. The azimuth is drawn uniformly among
/// those whose lines of sight (camera centre through the points of
/// `clearOf`, continued beyond) miss their solids — for a convex edge any
/// azimuth, inside a channel or a hole only those along it. Returns
/// std::nullopt when no azimuth is clear (e.g. the inside of a cup).
std::optional<hg::geometry::CameraModel> grazingView(const hg::inspect::MapLandmark& landmark,
                                                     const std::vector<Clearance>& clearOf, std::mt19937_64& rng,
                                                     const GrazingOptions& options = {});

/// A view from a direction uniform on the sphere at a random distance in
/// [minDistanceMm, maxDistanceMm], looking at `target`, random roll.
hg::geometry::CameraModel randomView(const Eigen::Vector3d& target, std::mt19937_64& rng,
                                     const GrazingOptions& options = {});

/// Backlit frames of `mesh` in every camera (simulator), Gaussian noise σ =
/// `noiseSigma` grey levels, seeds seed, seed + 1, ...; view ids "v0", "v1", ...
std::vector<hg::inspect::CapturedView> renderViews(const hg::model::TriangleMesh& mesh,
                                                   const std::vector<hg::geometry::CameraModel>& cameras,
                                                   double noiseSigma, std::uint64_t seed);

/// A view set: one grazing view of every landmark of `part` (those with no
/// clear azimuth are left out) followed by `extraViews` random views of the
/// part's centre. Lines of sight clear the nominal solid next to the nominal
/// surface; given a part as made, they also clear it next to the surface as
/// made (landmark + (e + clearance)·normal) — so a defect elsewhere does not
/// hide a landmark, and the void next to a displaced surface is seen (a
/// notch's inner edge only from along it): the views a planner needs for the
/// part as made, which the defect tests assume; the visual hull's limits
/// without them are chapter 2's subject.
std::vector<hg::geometry::CameraModel> grazingViewSet(const TestPart& part, const PartAsMade* asMade, int extraViews,
                                                      std::mt19937_64& rng, const GrazingOptions& options = {});

/// The judgement docs/contracts.md §4 promises, checked (gtest) at every landmark of
/// `result` against the true offsets of `asMade`: the landmark is measured,
/// e lies in [error_min − ΔV, error_max + ΔV] and, signed, in [offset_low −
/// ΔV, offset_high + ΔV]; a landmark with |e| > tolerance + 2ΔV is not ok, one
/// with |e| < tolerance − 2ΔV is ok. Landmarks in `skip` are not checked;
/// landmarks in `tips` (a part's corners, whose image in a grazing view is a
/// silhouette tip) are allowed one ΔV more in their bracket: at the threshold
/// half-way between backlight and object (coverage ½) a tip of angle α
/// retreats by ½ pixel / sin(α/2), more than a voxel where α is acute.
void expectJudgedAgainstTruth(const hg::inspect::InspectionResult& result, const TestPart& part,
                              const PartAsMade& asMade, const std::vector<std::string>& skip = {},
                              const std::vector<std::string>& tips = {});

} // namespace hgtest
