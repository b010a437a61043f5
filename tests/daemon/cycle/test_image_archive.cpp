// The parts' archive: written whole or not at all, annotated views, the
// frames and their manifest for the offline inspection, and its retention.
#include "cycle/image_archive.h"
#include "hgtest/paths.h"
#include "hullgauge/vision/manifest.h"

#include <cmath>
#include <fstream>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

namespace hg::daemon {
namespace {

TEST(ImageArchive, FailedViewsAreAnnotatedInStatusColours)
{
    hgtest::TempDir dir;
    ImageArchive archive(dir / "images", {});
    ViewEvidence v;
    v.image = cv::Mat(100, 120, CV_16UC1, cv::Scalar(4000));
    v.silhouette = cv::Mat(100, 120, CV_8UC1, cv::Scalar(0));
    v.silhouette(cv::Rect(30, 20, 60, 50)).setTo(255);
    v.landmarks = {{cv::Point2d(90, 70), "c2", inspect::LandmarkStatus::OutOfTolerance},
                   {cv::Point2d(30, 20), "c1", inspect::LandmarkStatus::Ok}};
    auto folder = archive.save(1'700'000'000'000, "SN/1", {v, v});
    ASSERT_FALSE(folder.empty());
    EXPECT_EQ(folder.filename(), "1700000000000_SN_1");
    auto png = cv::imread((folder / "view_1.png").string(), cv::IMREAD_COLOR);
    ASSERT_FALSE(png.empty());
    EXPECT_EQ(png.size(), cv::Size(120, 100));
    // The landmark circle (radius 4) is drawn in its status colour around its pixel.
    auto red = png.at<cv::Vec3b>(70, 90 + 4);
    EXPECT_GT(red[2], 200);
    EXPECT_LT(red[1], 60);
    auto green = png.at<cv::Vec3b>(20 + 4, 30);
    EXPECT_GT(green[1], 150);
    EXPECT_LT(green[2], 60);
    // The silhouette outline (blue) runs along its top edge.
    auto edge = png.at<cv::Vec3b>(20, 60);
    EXPECT_GT(edge[0], 200);
    // Away from the drawing: the frame scaled to 8 bit (grey).
    auto plain = png.at<cv::Vec3b>(5, 5);
    EXPECT_EQ(plain[0], plain[1]);
    EXPECT_EQ(plain[0], 255);
}

TEST(ImageArchive, RetentionKeepsTheNewestWithinCountAndBytes)
{
    hgtest::TempDir dir;
    station::RetentionConfig keep3;
    keep3.maxCount = 3;
    ImageArchive archive(dir / "images", keep3);
    ViewEvidence v{cv::Mat(10, 10, CV_8UC1, cv::Scalar(9)), {}, {}};
    std::vector<std::filesystem::path> folders;
    for (int i = 0; i < 5; ++i) {
        folders.push_back(archive.save(1000 + i, "S", {v}));
        std::filesystem::last_write_time(folders.back(),
                                         std::filesystem::file_time_type::clock::now() - std::chrono::minutes(10 - i));
    }
    EXPECT_EQ(archive.enforceRetention(), 2u);
    EXPECT_FALSE(std::filesystem::exists(folders[0]));
    EXPECT_FALSE(std::filesystem::exists(folders[1]));
    EXPECT_TRUE(std::filesystem::exists(folders[4]));

    station::RetentionConfig young;
    young.maxAge = std::chrono::hours(1);
    std::filesystem::last_write_time(folders[2], std::filesystem::file_time_type::clock::now() - std::chrono::hours(2));
    EXPECT_EQ(ImageArchive(dir / "images", young).enforceRetention(), 1u);
    EXPECT_FALSE(std::filesystem::exists(folders[2]));

    station::RetentionConfig tiny;
    tiny.maxBytes = 1; // less than one folder: everything goes
    EXPECT_EQ(ImageArchive(dir / "images", tiny).enforceRetention(), 2u);
}

TEST(ImageArchive, RetentionNeverRemovesTheNewestFailedParts)
{
    hgtest::TempDir dir;
    ImageArchive writer(dir / "images", {});
    ViewEvidence v{cv::Mat(10, 10, CV_8UC1, cv::Scalar(9)), {}, {}};
    // Oldest first: fail, pass, fail, pass, fail, pass (part 5 the newest).
    std::vector<std::filesystem::path> folders;
    for (int i = 0; i < 6; ++i) {
        folders.push_back(writer.save(1000 + i, "S", {v}, i % 2 == 0));
        std::filesystem::last_write_time(folders.back(),
                                         std::filesystem::file_time_type::clock::now() - std::chrono::minutes(10 - i));
    }
    EXPECT_TRUE(std::filesystem::exists(folders[0] / ImageArchive::kFailedMarker));
    EXPECT_FALSE(std::filesystem::exists(folders[1] / ImageArchive::kFailedMarker));

    // Count 1 and bytes 1 would leave nothing; the two newest rejects (parts 4 and 2) stay.
    station::RetentionConfig strict;
    strict.maxCount = 1;
    strict.maxBytes = 1;
    strict.keepFailed = 2;
    EXPECT_EQ(ImageArchive(dir / "images", strict).enforceRetention(), 4u);
    for (int i = 0; i < 6; ++i) EXPECT_EQ(std::filesystem::exists(folders[i]), i == 2 || i == 4) << "part " << i;

    // Age too: a reject older than max_age_days stays while it is among the newest keep_failed.
    station::RetentionConfig young;
    young.maxAge = std::chrono::hours(1);
    young.keepFailed = 1;
    std::filesystem::last_write_time(folders[4], std::filesystem::file_time_type::clock::now() - std::chrono::hours(3));
    std::filesystem::last_write_time(folders[2], std::filesystem::file_time_type::clock::now() - std::chrono::hours(4));
    EXPECT_EQ(ImageArchive(dir / "images", young).enforceRetention(), 1u);
    EXPECT_TRUE(std::filesystem::exists(folders[4]));
    EXPECT_FALSE(std::filesystem::exists(folders[2]));
}

// docs/daemon.md, "Archived parts": the verdict and its record win over images. A volume that
// holds 3 folders' worth of bytes beyond the others' files (the probe counts the archive's bytes
// against a capacity) keeps min_free_mb free by removing the oldest folders, failed ones too.
TEST(ImageArchive, TheOldestFoldersGiveWayWhileTheVolumeHasLessThanMinFree)
{
    hgtest::TempDir dir;
    const auto root = dir / "images";
    ViewEvidence v{cv::Mat(10, 10, CV_8UC1, cv::Scalar(9)), {}, {}};
    std::vector<std::filesystem::path> folders;
    {
        ImageArchive writer(root, {});
        for (int i = 0; i < 5; ++i) {
            folders.push_back(writer.save(1000 + i, "S", {v}, i == 0));
            std::filesystem::last_write_time(folders.back(), std::filesystem::file_time_type::clock::now() -
                                                                 std::chrono::minutes(10 - i));
        }
    }
    std::uintmax_t folderBytes = 0;
    for (const auto& f : std::filesystem::recursive_directory_iterator(folders[0]))
        if (f.is_regular_file()) folderBytes += f.file_size();
    ASSERT_GT(folderBytes, 0u);
    const auto archiveBytes = [&] {
        std::uintmax_t total = 0;
        for (const auto& f : std::filesystem::recursive_directory_iterator(root))
            if (f.is_regular_file()) total += f.file_size();
        return total;
    };
    // Five folders on a volume of 6.5 folders: 1.5 free. min_free is 3 folders: two must go.
    const std::uintmax_t capacity = folderBytes * 13 / 2;
    const auto probe = [&](const std::filesystem::path&) { return capacity - archiveBytes(); };
    station::RetentionConfig retention; // count, age and bytes all hold: only the free space acts
    retention.minFreeBytes = folderBytes * 3;
    retention.keepFailed = 5;
    ImageArchive archive(root, retention, Clock::steady(), probe);
    EXPECT_FALSE(archive.hasRoom());
    EXPECT_EQ(archive.enforceRetention(), 2u);
    EXPECT_TRUE(archive.hasRoom());
    for (int i = 0; i < 5; ++i) EXPECT_EQ(std::filesystem::exists(folders[i]), i >= 2) << "part " << i;
    EXPECT_EQ(archive.makeRoom(), 0u) << "room enough: nothing more goes";

    // A volume that nothing in the archive can free: every folder goes, and there is still no room.
    ImageArchive full(root, retention, Clock::steady(), [](const std::filesystem::path&) { return 0ull; });
    EXPECT_EQ(full.makeRoom(), 3u);
    EXPECT_FALSE(full.hasRoom());
    EXPECT_TRUE(std::filesystem::is_empty(root));
}

// A view as the engine inspector hands it over: a 16-bit frame and the camera it was inspected with.
ViewEvidence capturedView(const std::string& id, double rotationDeg)
{
    geometry::Intrinsics in;
    in.K << 80, 0, 32, 0, 80, 24, 0, 0, 1;
    in.imageSize = {64, 48};
    const double a = rotationDeg * M_PI / 180.0;
    geometry::RigidTransform pose;
    pose.R << std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a), 0, 0, 0, 1;
    pose.t = {0.1, -0.2, 300};
    ViewEvidence v;
    v.image = cv::Mat(48, 64, CV_16UC1);
    cv::randu(v.image, 0, 65535);
    geometry::FixturePose fixture;
    fixture.rotationDeg = rotationDeg;
    v.capture = vision::ManifestView{id,
                                     {},
                                     geometry::CameraModel(in, pose),
                                     false,
                                     vision::ManifestFixturePose{geometry::FixtureType::RotationDeclination, fixture}};
    v.segmentation.method = vision::SegmentationMethod::Fixed;
    v.segmentation.threshold = 30000;
    return v;
}

std::vector<std::filesystem::path> entries(const std::filesystem::path& dir)
{
    std::vector<std::filesystem::path> out;
    for (const auto& e : std::filesystem::directory_iterator(dir)) out.push_back(e.path().filename());
    return out;
}

TEST(ImageArchive, ArchivedPartHoldsItsFramesLosslesslyAndTheManifestOfItsCameras)
{
    hgtest::TempDir dir;
    ImageArchive archive(dir / "images", {});
    const std::vector<ViewEvidence> views = {capturedView("v0", 0.0), capturedView("v1", 33.0)};
    const auto folder = archive.save(1'700'000'000'000, "SN-9", views);
    ASSERT_FALSE(folder.empty());
    EXPECT_EQ(entries(dir / "images"), std::vector<std::filesystem::path>{"1700000000000_SN-9"});
    const auto manifest = vision::readManifest(folder / "manifest.json");
    ASSERT_EQ(manifest.views.size(), 2u);
    EXPECT_EQ(manifest.segmentation.method, vision::SegmentationMethod::Fixed);
    EXPECT_EQ(manifest.segmentation.threshold, 30000);
    for (std::size_t k = 0; k < views.size(); ++k) {
        const auto& wrote = *views[k].capture;
        const auto& read = manifest.views[k];
        EXPECT_EQ(read.id, wrote.id);
        EXPECT_EQ(read.image, folder / (wrote.id + ".png"));
        // Bit for bit: the offline inspection must see the cameras and pixels the daemon saw.
        EXPECT_EQ(read.camera.cameraFromPart().R, wrote.camera.cameraFromPart().R);
        EXPECT_EQ(read.camera.cameraFromPart().t, wrote.camera.cameraFromPart().t);
        EXPECT_EQ(read.camera.intrinsics().K, wrote.camera.intrinsics().K);
        EXPECT_EQ(read.camera.imageSize(), wrote.camera.imageSize());
        ASSERT_TRUE(read.fixturePose);
        EXPECT_EQ(read.fixturePose->pose.rotationDeg, wrote.fixturePose->pose.rotationDeg);
        const cv::Mat frame = vision::readViewImage(manifest, k);
        EXPECT_EQ(frame.type(), CV_16UC1);
        EXPECT_EQ(cv::norm(frame, views[k].image, cv::NORM_INF), 0.0);
        EXPECT_TRUE(std::filesystem::exists(folder / ("view_" + std::to_string(k) + ".png")));
    }
}

// The overlay the HMI draws on the plain frame (docs/daemon.md, "Archived parts"; docs/hmi.md, "Reject
// views"): a 16-bit frame gets an 8-bit frame_<k>.png, an 8-bit captured one is its own plain frame; the
// outline's polylines and every landmark inside the frame with its outcome.
TEST(ImageArchive, EveryViewHasItsOverlayAndPlainFrame)
{
    hgtest::TempDir dir;
    ImageArchive archive(dir / "images", {});
    ViewEvidence wide = capturedView("v0", 0.0);
    wide.outline = {{{{10.0, 10.0}, {50.0, 10.0}, {50.0, 40.0}}, true}};
    wide.seatMeasured = true;
    station::LandmarkOutcome low{"step-top", inspect::LandmarkStatus::OutOfTolerance, 0.6, 0.8, 0.7, 0.4};
    low.deviationMm = -0.699;
    low.uncertaintyMm = 0.02;
    wide.landmarks = {{cv::Point2d(12.5, 20.25), "step-top", low.status, cv::Point2d(0, -1), low},
                      {cv::Point2d(70, 20), "outside", inspect::LandmarkStatus::Ok}};
    ViewEvidence narrow = capturedView("v1", 10.0);
    narrow.image.convertTo(narrow.image, CV_8U, 1.0 / 256);
    const auto folder = archive.save(1'700'000'000'000, "SN-7", {wide, narrow});
    ASSERT_FALSE(folder.empty());
    std::ifstream in0(folder / "view_0.json"), in1(folder / "view_1.json");
    const auto v0 = nlohmann::json::parse(in0), v1 = nlohmann::json::parse(in1);
    EXPECT_EQ(v0["frame"], "frame_0.png");
    EXPECT_EQ(v1["frame"], "v1.png");
    EXPECT_FALSE(std::filesystem::exists(folder / "frame_1.png"));
    const cv::Mat plain = cv::imread((folder / "frame_0.png").string(), cv::IMREAD_UNCHANGED);
    EXPECT_EQ(plain.type(), CV_8UC1);
    EXPECT_EQ(plain.size(), wide.image.size());
    EXPECT_EQ(v0["image_size"], nlohmann::json({64, 48}));
    EXPECT_EQ(v0["seat"], "measured");
    EXPECT_EQ(v1["seat"], "nominal");
    ASSERT_EQ(v0["outline"].size(), 1u);
    EXPECT_EQ(v0["outline"][0]["closed"], true);
    EXPECT_EQ(v0["outline"][0]["points"][1], nlohmann::json({50.0, 10.0}));
    ASSERT_EQ(v0["landmarks"].size(), 1u) << "a landmark outside the frame is not in its overlay";
    const auto& l = v0["landmarks"][0];
    EXPECT_EQ(l["id"], "step-top");
    EXPECT_EQ(l["status"], "out_of_tolerance");
    EXPECT_EQ(l["pixel"], nlohmann::json({12.5, 20.25}));
    EXPECT_EQ(l["direction"], nlohmann::json({0.0, -1.0}));
    EXPECT_EQ(l["deviation_mm"], -0.699);
    EXPECT_EQ(l["tolerance_mm"], 0.4);
    EXPECT_EQ(l["error_min_mm"], 0.6);
}

TEST(ImageArchive, AFolderThatCannotBeWrittenWholeLeavesNothing)
{
    hgtest::TempDir dir;
    ImageArchive archive(dir / "images", {});
    // The second view cannot be encoded: the first one's files were written already.
    std::vector<ViewEvidence> views = {capturedView("v0", 0.0), capturedView("v1", 10.0)};
    views[1].image = cv::Mat();
    EXPECT_TRUE(archive.save(1000, "S", views).empty());
    EXPECT_TRUE(entries(dir / "images").empty()) << "neither the folder nor a partial one is left";

    // The folder's name is taken (by a file here): the rename fails, the partial folder goes.
    hgtest::writeFile(archive.folderFor(2000, "S"), "taken");
    EXPECT_TRUE(archive.save(2000, "S", {capturedView("v0", 0.0)}).empty());
    EXPECT_EQ(entries(dir / "images"), std::vector<std::filesystem::path>{"2000_S"});
}

TEST(ImageArchive, RetentionRemovesAPartialFolderACrashLeft)
{
    hgtest::TempDir dir;
    ImageArchive archive(dir / "images", {});
    const auto kept = archive.save(1000, "S", {capturedView("v0", 0.0)});
    ASSERT_FALSE(kept.empty());
    hgtest::writeFile(dir / "images" / ".partial-2000_S" / "view_0.png", "cut short");
    EXPECT_EQ(archive.enforceRetention(), 0u) << "a partial folder is no archived part";
    EXPECT_EQ(entries(dir / "images"), std::vector<std::filesystem::path>{kept.filename()});
}

} // namespace
} // namespace hg::daemon
