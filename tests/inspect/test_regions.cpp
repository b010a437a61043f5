// The pixels an inspection touches (docs/inspection.md, "Pixels in proportion
// to the goal"): a footprint's region against its projection worked by hand,
// and, on the simulated line's part and its defect variants (config/sim), that
// the regions hold every pixel the voxel test, the alignment and the sub-pixel
// edges read — the same frames inspected through the regions and whole give
// the same landmarks to the last bit, and so do frames whose every pixel
// outside the regions is overwritten.
#include <gtest/gtest.h>

#include <cmath>

#include "hgtest/paths.h"
#include "hullgauge/align/alignment.h"
#include "hullgauge/common/config_node.h"
#include "hullgauge/geometry/station.h"
#include "hullgauge/inspect/inspector.h"
#include "hullgauge/inspect/part_map.h"
#include "hullgauge/inspect/regions.h"
#include "hullgauge/model/mesh_io.h"
#include "hullgauge/model/part_program.h"
#include "hullgauge/model/primitives.h"
#include "hullgauge/model/solid.h"
#include "hullgauge/sim/renderer.h"

using namespace hg::inspect;
using hg::geometry::CameraModel;
using hg::geometry::Intrinsics;
using hg::geometry::RigidTransform;

namespace {

/// f = 1000 px, principal point (320, 240), 640 x 480, at `centre` looking along +z.
CameraModel alongZ(const Eigen::Vector3d& centre)
{
    Intrinsics in;
    in.K << 1000, 0, 320, 0, 1000, 240, 0, 0, 1;
    in.imageSize = {640, 480};
    return CameraModel(in, RigidTransform{Eigen::Matrix3d::Identity(), -centre});
}

} // namespace

// Pixel (c, r) covers c ± ½: a footprint from u = 330.84 to 343.0 touches
// columns 331..343, rows 233..244 (v from 233.0 to 244.0); one pixel more all round.
TEST(Regions, AVoxelsFootprintRegionIsItsProjectedPixelBoundsPlusOnePixel)
{
    const CameraModel camera = alongZ(Eigen::Vector3d::Zero());
    const Box3 voxel(Eigen::Vector3d(1.1, -0.7, 100.0), Eigen::Vector3d(2.3, 0.4, 101.5));
    // By hand: u = 1000·x/z + 320, v = 1000·y/z + 240, extremes at the corners:
    // u_min = 1000·1.1/101.5 + 320 = 330.837, u_max = 1000·2.3/100 + 320 = 343.0,
    // v_min = −1000·0.7/100 + 240 = 233.0, v_max = 1000·0.4/100 + 240 = 244.0.
    const auto r = footprintRect(camera, voxel);
    ASSERT_TRUE(r.has_value());
    EXPECT_EQ(*r, cv::Rect(cv::Point(330, 232), cv::Point(345, 246)));
    // Behind the camera: no region.
    EXPECT_FALSE(footprintRect(camera, Box3(Eigen::Vector3d(1, 1, -2), Eigen::Vector3d(2, 2, 3))).has_value());
}

// A one-landmark map (ΔV = 1 mm, adjacency 1): the landmark (5, 5.5, 8) with
// normal +z has its voxel at the point a quarter ΔV inside, index (5, 5, 7),
// so its network is [4, 7] x [4, 7] x [6, 9]; the camera at (5, 5.5, −100)
// looking along +z sees it from z + 100 = 106 to 109.
TEST(Regions, ALandmarksRegionIsItsNetworksProjectionWidenedByTheSeatMargin)
{
    MapGeometry g;
    g.cubeOrigin = Eigen::Vector3d::Zero();
    g.cubeSize = 16.0;
    g.depth = 4;
    g.adjacencyDepth = 1;
    g.coarsestLevel = 4;
    const auto solid = std::make_shared<const hg::model::Solid>(hg::model::makeBox({0, 0, 0}, {16, 16, 8}));
    const InspectionMap map = InspectionMap::build(
        "box", g, {{"top", Eigen::Vector3d(5, 5.5, 8), Eigen::Vector3d::UnitZ(), 0.3}}, {}, cadLabels(solid));
    const CameraModel camera = alongZ(Eigen::Vector3d(5, 5.5, -100));

    // u from 320 − 1000·1/106 = 310.57 to 320 + 1000·2/106 = 338.87: columns 311..339;
    // v from 240 ∓ 1000·1.5/106 = 225.85 .. 254.15: rows 226..254; one pixel more.
    RegionQuery q;
    const ViewRegions plain = viewRegions(map, camera, q);
    ASSERT_EQ(plain.voxels.size(), 1u);
    EXPECT_EQ(plain.voxels[0], cv::Rect(cv::Point(310, 225), cv::Point(341, 256)));
    EXPECT_EQ(plain.bounds, plain.voxels[0]);
    EXPECT_EQ(plain.voxelPixels(), 31 * 31);

    // The seat's 0.5 mm margin widens the box: x − 5 in [−1.5, 2.5], y − 5.5 in
    // [−2, 2], nearest at z + 100 = 105.5: u 305.78 .. 343.70, v 221.04 .. 258.96.
    q.marginMm = 0.5;
    const ViewRegions seated = viewRegions(map, camera, q);
    ASSERT_EQ(seated.voxels.size(), 1u);
    EXPECT_EQ(seated.voxels[0], cv::Rect(cv::Point(305, 220), cv::Point(346, 261)));

    // The normal runs along the line of sight: the sub-voxel step leaves this
    // view out, so it reads nothing here.
    q.edges = true;
    EXPECT_TRUE(viewRegions(map, camera, q).edges.empty());
    // A masked landmark asks for nothing.
    q.active = {0};
    EXPECT_TRUE(viewRegions(map, camera, q).voxels.empty());
}

TEST(Regions, OverlappingRectanglesMergeUntilNoneOverlap)
{
    // A chain a–b–c where only a∪b reaches c, and d apart (touching c only).
    const std::vector<cv::Rect> in = {{0, 0, 10, 10}, {8, 8, 10, 10}, {17, 0, 5, 9}, {22, 0, 4, 4}};
    const std::vector<cv::Rect> out = mergeOverlapping(in);
    ASSERT_EQ(out.size(), 2u);
    EXPECT_EQ(out[0], cv::Rect(0, 0, 22, 18));
    EXPECT_EQ(out[1], cv::Rect(22, 0, 4, 4));
}

namespace {

std::filesystem::path simFolder()
{
    return hgtest::sourceDir() / "config" / "sim";
}

/// The simulated line: its part program, station and planned poses, and the
/// frames its simulated camera renders of a variant seated by `seat` (grey
/// levels, blur and noise of the station's camera.driver, docs/camera.md).
struct SimLine {
    hg::model::PartProgram program = hg::model::loadPartProgram(simFolder() / "stepped-block.yaml");
    hg::geometry::Station station = hg::geometry::loadStation(simFolder() / "station.yaml");
    std::vector<hg::geometry::FixturePose> poses =
        hg::geometry::loadPoses(simFolder() / "stepped-block-views.yaml", &station.fixture);
    InspectionMap map = buildInspectionMap(program, inspectionOptions(program.inspection));

    std::vector<CapturedView> render(const std::string& mesh, const RigidTransform& seat) const
    {
        const hg::ConfigNode driver = (*station.document)["camera"]["driver"];
        hg::sim::SilhouetteRenderer renderer({hg::model::loadMesh(simFolder() / mesh)});
        hg::sim::RenderOptions o;
        o.backgroundLevel = driver["background_level"].asDouble();
        o.objectLevel = driver["object_level"].asDouble();
        o.blurSigmaPx = driver["blur_sigma_px"].asDouble();
        o.noiseSigma = driver["noise_sigma"].asDouble();
        std::vector<CapturedView> views;
        for (std::size_t k = 0; k < poses.size(); ++k) {
            o.seed = 7 + k;
            const CameraModel camera = station.cameraAt(poses[k]);
            views.push_back(
                {"v" + std::to_string(k), camera, renderer.render(hg::align::seatedCamera(camera, seat), o)});
        }
        return views;
    }
    /// As the daemon inspects: the program's options, alignment and deviation.
    Inspector inspector(bool wholeFrame) const
    {
        InspectionOptions options = inspectionOptions(program.inspection);
        options.wholeFrame = wholeFrame;
        return Inspector(map, options, makeAligner(program), makeDeviationGauge(program, station.calibration));
    }
};

// The same landmarks to the last bit: statuses, brackets, error figures,
// deviations and their uncertainties, the seat.
void expectSameResult(const InspectionResult& a, const InspectionResult& b)
{
    EXPECT_EQ(a.pass, b.pass);
    EXPECT_EQ(a.voxelsReconstructed, b.voxelsReconstructed);
    ASSERT_EQ(a.alignment.has_value(), b.alignment.has_value());
    if (a.alignment) {
        EXPECT_EQ(a.alignment->seat.R, b.alignment->seat.R);
        EXPECT_EQ(a.alignment->seat.t, b.alignment->seat.t);
    }
    ASSERT_EQ(a.landmarks.size(), b.landmarks.size());
    for (std::size_t i = 0; i < a.landmarks.size(); ++i) {
        const LandmarkResult &x = a.landmarks[i], &y = b.landmarks[i];
        SCOPED_TRACE(x.id);
        EXPECT_EQ(x.status, y.status);
        EXPECT_EQ(x.errorNumber, y.errorNumber);
        EXPECT_EQ(x.errorMinMm, y.errorMinMm);
        EXPECT_EQ(x.errorMaxMm, y.errorMaxMm);
        EXPECT_EQ(x.offsetLowMm, y.offsetLowMm);
        EXPECT_EQ(x.offsetHighMm, y.offsetHighMm);
        ASSERT_EQ(x.deviation.has_value(), y.deviation.has_value());
        if (!x.deviation) continue;
        EXPECT_EQ(x.deviation->measured, y.deviation->measured);
        EXPECT_EQ(x.deviation->deviationMm, y.deviation->deviationMm);
        EXPECT_EQ(x.deviation->uncertaintyMm, y.deviation->uncertaintyMm);
    }
}

/// `frame` with every pixel outside `keep` overwritten by a pattern no
/// backlit frame shows (alternating object and background columns).
cv::Mat outsideOverwritten(const cv::Mat& frame, const ViewRegions& keep)
{
    cv::Mat out(frame.size(), frame.type());
    for (int r = 0; r < out.rows; ++r)
        for (int c = 0; c < out.cols; ++c) out.at<std::uint8_t>(r, c) = (c + r) % 2 ? 255 : 0;
    for (const auto* list : {&keep.voxels, &keep.edges})
        for (const cv::Rect& rect : *list) frame(rect).copyTo(out(rect));
    return out;
}

const RigidTransform kSeat = [] {
    const auto turn = RigidTransform::rotation(Eigen::Vector3d(1, -2, 3), 0.25);
    return RigidTransform{turn.R, turn.R * Eigen::Vector3d(0, 0, -15) + Eigen::Vector3d(0.2, -0.1, 15.15)};
}();

} // namespace

TEST(Regions, TheSimulatedLineInspectsThroughItsRegionsAsThroughWholeFrames)
{
    const SimLine line;
    ASSERT_EQ(line.program.alignment.method, hg::model::AlignmentMethod::Silhouette) << "the line aligns";
    ASSERT_TRUE(line.program.inspection.deviation) << "the line measures the deviation";
    const Inspector regions = line.inspector(false), whole = line.inspector(true);
    // One threshold for both, between the driver's two levels (0.04 and 0.92 of 255),
    // so that only which pixels are segmented differs.
    hg::vision::SegmentationSettings fixed;
    fixed.method = hg::vision::SegmentationMethod::Fixed;
    fixed.threshold = 122.0;
    const std::map<std::string, std::size_t> failing = {
        {"stepped-block.stl", 0}, {"stepped-block-face-low.stl", 2}, {"stepped-block-corner-missing.stl", 2}};
    for (const auto& [mesh, fails] : failing) {
        SCOPED_TRACE(mesh);
        const auto frames = line.render(mesh, kSeat);
        const InspectionResult r = regions.inspect(frames, fixed);
        expectSameResult(r, whole.inspect(frames, fixed));
        std::size_t notOk = 0;
        for (const LandmarkResult& l : r.landmarks) notOk += l.status != LandmarkStatus::Ok;
        EXPECT_EQ(notOk, fails) << toJson(r).dump(1);
    }
}

TEST(Regions, NoPixelOutsideTheRegionsIsRead)
{
    const SimLine line;
    const Inspector inspector = line.inspector(false);
    const auto segmentation = hg::vision::stationSegmentation(line.station);
    ASSERT_EQ(segmentation.method, hg::vision::SegmentationMethod::Otsu);
    for (const std::string mesh : {"stepped-block.stl", "stepped-block-face-low.stl"}) {
        SCOPED_TRACE(mesh);
        const auto frames = line.render(mesh, kSeat);
        std::vector<CapturedView> overwritten = frames;
        std::int64_t touched = 0, all = 0;
        for (CapturedView& v : overwritten) {
            const ViewRegions roi = inspector.regions(v.camera);
            for (const cv::Rect& r : roi.voxels) EXPECT_EQ(r & roi.bounds, r);
            for (const cv::Rect& r : roi.edges) EXPECT_EQ(r & roi.bounds, r);
            touched += roi.bounds.area();
            all += static_cast<std::int64_t>(v.frame.total());
            v.frame = outsideOverwritten(v.frame, roi);
        }
        // The Otsu threshold comes from the regions alone, the seat from the
        // band along the outline, the edges from beside the landmarks.
        expectSameResult(inspector.inspect(frames, segmentation), inspector.inspect(overwritten, segmentation));
        EXPECT_LT(touched, all) << "the regions' bounding boxes leave part of the frames out";
    }
}

// Frames that are regions of the sensor (docs/inspection.md, "Frames that are
// regions"): each view's frame cut to its bounds, as a camera delivering one
// region per grab sends it, inspects to the last bit as the whole frame does.
TEST(Regions, FramesCutToEachViewsBoundsInspectAsWholeFrames)
{
    const SimLine line;
    const Inspector inspector = line.inspector(false);
    const auto segmentation = hg::vision::stationSegmentation(line.station);
    for (const std::string mesh :
         {"stepped-block.stl", "stepped-block-face-low.stl", "stepped-block-corner-missing.stl"}) {
        SCOPED_TRACE(mesh);
        const auto frames = line.render(mesh, kSeat);
        std::vector<CapturedView> cut = frames;
        for (CapturedView& v : cut) {
            const cv::Rect bounds = inspector.regions(v.camera).bounds;
            ASSERT_FALSE(bounds.empty()) << v.id;
            ASSERT_LT(bounds.area(), v.camera.imageSize().area()) << v.id << ": a real cut";
            v.frame = v.frame(bounds).clone();
            v.origin = bounds.tl();
        }
        expectSameResult(inspector.inspect(frames, segmentation), inspector.inspect(cut, segmentation));
    }
}

// A region that holds none of what the inspection reads: nothing is guessed —
// no landmark is ok and the part does not pass.
TEST(Regions, AFrameMissingTheRegionsReadsNothingOutsideIt)
{
    const SimLine line;
    const Inspector inspector = line.inspector(false);
    const auto segmentation = hg::vision::stationSegmentation(line.station);
    std::vector<CapturedView> cut = line.render("stepped-block.stl", kSeat);
    for (CapturedView& v : cut) {
        // A 32 x 32 corner of the sensor, clear of every region.
        const cv::Rect corner(0, 0, 32, 32);
        ASSERT_TRUE((inspector.regions(v.camera).bounds & corner).empty()) << v.id;
        v.frame = v.frame(corner).clone();
    }
    const InspectionResult r = inspector.inspect(cut, segmentation);
    EXPECT_FALSE(r.pass);
    for (const LandmarkResult& l : r.landmarks) EXPECT_NE(l.status, LandmarkStatus::Ok) << l.id;
}

TEST(Regions, AFrameLeavingTheSensorIsAnErrorNamingTheView)
{
    const SimLine line;
    const Inspector inspector = line.inspector(false);
    std::vector<CapturedView> views = line.render("stepped-block.stl", RigidTransform{});
    CapturedView& last = views.back();
    const cv::Size sensor = last.camera.imageSize();
    last.frame = last.frame(cv::Rect(0, 0, 100, 80)).clone();
    last.origin = cv::Point(sensor.width - 50, 10);
    try {
        (void)inspector.inspect(views, hg::vision::stationSegmentation(line.station));
        FAIL() << "accepted";
    } catch (const std::invalid_argument& e) {
        const std::string what = e.what();
        EXPECT_NE(what.find("view '" + last.id + "'"), std::string::npos) << what;
        EXPECT_NE(what.find("does not lie on the camera's"), std::string::npos) << what;
    }
}
