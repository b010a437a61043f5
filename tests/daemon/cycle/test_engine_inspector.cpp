// The daemon judges as the offline tool does (docs/daemon.md, "Archived
// parts"): the daemon's engine inspector is fed the frames the simulated camera
// renders of the simulated line's parts (config/sim) at the planned poses, each
// part is archived as the daemon archives it, and `hullgauge inspect --part P
// --views <archive>/manifest.json` — the program itself — must give every
// landmark the same status and the same error figures, to the last bit. The
// verdicts themselves are checked against the defects the variant meshes were
// built with (config/sim/README.md), and a station file's fixed threshold
// against what it must do to the silhouettes.
#include "cycle/engine_inspector.h"
#include "cycle/image_archive.h"
#include "daemon_config.h"
#include "hgtest/paths.h"
#include "hullgauge/align/pose_correction.h"
#include "hullgauge/common/config_node.h"
#include "hullgauge/geometry/transform.h"
#include "hullgauge/model/mesh_io.h"
#include "hullgauge/sim/renderer.h"
#include "hullgauge/vision/manifest.h"

#include <fstream>
#include <gtest/gtest.h>
#include <iostream>
#include <iterator>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace {

namespace fs = std::filesystem;
using hg::daemon::InspectionOutcome;
using hg::station::DaemonConfig;

fs::path simFolder()
{
    return hgtest::sourceDir() / "config" / "sim";
}

// The frames the simulated camera grabs of `part`, seated by `seat`
// (nominal_from_part, docs/alignment.md), at `poses` (default: the plan's):
// the renderer with the grey levels, blur and noise of the station's
// camera.driver, a fresh seed per frame.
std::vector<cv::Mat> frames(const DaemonConfig& config, const std::string& part,
                            const hg::geometry::RigidTransform& seat = {},
                            std::vector<hg::geometry::FixturePose> poses = {})
{
    if (poses.empty()) poses = config.programs.at(1).views;
    fs::path mesh;
    for (const auto& [name, file] : config.simulatedParts)
        if (name == part) mesh = file;
    const hg::ConfigNode driver = (*config.station.document)["camera"]["driver"];
    hg::sim::SilhouetteRenderer renderer({hg::model::loadMesh(mesh)});
    hg::sim::RenderOptions options;
    options.backgroundLevel = driver["background_level"].asDouble();
    options.objectLevel = driver["object_level"].asDouble();
    options.blurSigmaPx = driver["blur_sigma_px"].asDouble();
    options.noiseSigma = driver["noise_sigma"].asDouble();
    std::vector<cv::Mat> out;
    for (const auto& pose : poses) {
        options.seed = static_cast<std::uint64_t>(driver["seed"].asInt()) + out.size();
        out.push_back(renderer.render(hg::align::seatedCamera(config.station.cameraAt(pose), seat), options));
    }
    return out;
}

InspectionOutcome inspect(hg::daemon::Inspector& inspector, const DaemonConfig& config,
                          const std::vector<cv::Mat>& images)
{
    const hg::Status begun = inspector.begin(config.programs.at(1));
    EXPECT_TRUE(begun.ok()) << begun.message();
    const auto& poses = config.programs.at(1).views;
    for (std::size_t k = 0; k < images.size(); ++k) inspector.addView(k, poses[k], images[k], {});
    return inspector.finish();
}

std::map<std::string, std::string> notOk(const InspectionOutcome& outcome)
{
    std::map<std::string, std::string> out;
    for (const auto& l : outcome.landmarks)
        if (hg::enumName(l.status) != "ok") out[l.id] = std::string(hg::enumName(l.status));
    return out;
}

// The daemon's archive of the part, as the cycle writes it when it archives the part.
fs::path archive(const DaemonConfig& config, InspectionOutcome& outcome, const fs::path& root, const std::string& name)
{
    EXPECT_TRUE(outcome.evidence) << "an inspected part can be archived";
    if (!outcome.evidence) return {};
    return hg::daemon::ImageArchive(root, config.results.retention).save(1'700'000'000'000, name, outcome.evidence());
}

// `hullgauge inspect` on the archive: the offline tool, not a call inside this process.
nlohmann::json inspectOffline(const fs::path& partFile, const fs::path& folder)
{
    const fs::path out = folder.parent_path() / (folder.filename().string() + "-offline.json");
    const auto r =
        hgtest::run((hgtest::binaryDir() / "bin" / "hullgauge").string() + " inspect --part " + partFile.string() +
                    " --views " + (folder / "manifest.json").string() + " --out " + out.string());
    EXPECT_TRUE(r.status == 0 || r.status == 1 || r.status == 3) << r.err;
    std::ifstream in(out);
    return in ? nlohmann::json::parse(in) : nlohmann::json::object();
}

// A landmark the inspection did not measure has null error figures offline and zeros in the daemon's record.
double figure(const nlohmann::json& j)
{
    return j.is_null() ? 0.0 : j.get<double>();
}

// Every landmark's status and error figures, compared exactly; returns how many were compared.
std::size_t expectSameLandmarks(const InspectionOutcome& daemon, const nlohmann::json& offline)
{
    EXPECT_EQ(offline.value("verdict", ""), daemon.pass ? "pass" : "fail");
    const auto& landmarks = offline["landmarks"];
    EXPECT_EQ(landmarks.size(), daemon.landmarks.size());
    std::size_t compared = 0;
    for (std::size_t i = 0; i < std::min(landmarks.size(), daemon.landmarks.size()); ++i) {
        const auto& d = daemon.landmarks[i];
        const auto& o = landmarks[i];
        EXPECT_EQ(o["id"], d.id);
        EXPECT_EQ(o["status"], std::string(hg::enumName(d.status))) << d.id;
        EXPECT_EQ(figure(o["error_min_mm"]), d.errorMinMm) << d.id;
        EXPECT_EQ(figure(o["error_max_mm"]), d.errorMaxMm) << d.id;
        EXPECT_EQ(figure(o["error_mm"]), d.errorMm) << d.id;
        EXPECT_EQ(o["tolerance_mm"].get<double>(), d.toleranceMm) << d.id;
        // The sub-voxel deviation, when the program measures it (docs/inspection.md).
        EXPECT_EQ(o.contains("deviation_mm") && o["deviation_mm"].is_number(), d.deviationMm.has_value()) << d.id;
        if (d.deviationMm) {
            EXPECT_EQ(o["deviation_mm"].get<double>(), *d.deviationMm) << d.id;
            EXPECT_EQ(o["uncertainty_mm"].get<double>(), *d.uncertaintyMm) << d.id;
        }
        EXPECT_EQ(o.value("decision", ""), d.decision ? std::string(hg::enumName(*d.decision)) : "") << d.id;
        ++compared;
    }
    return compared;
}

class EngineParity : public ::testing::Test {
  protected:
    static void SetUpTestSuite()
    {
        config_ = new DaemonConfig(hg::station::loadDaemonConfig(simFolder() / "hullgauged.yaml"));
    }
    static void TearDownTestSuite()
    {
        delete config_;
        config_ = nullptr;
    }
    static DaemonConfig* config_;
};

DaemonConfig* EngineParity::config_ = nullptr;

TEST_F(EngineParity, EveryVariantsArchiveReproducesTheDaemonsLandmarksExactly)
{
    // What the variants were built to show (config/sim/README.md), independent of the code under test.
    const std::map<std::string, std::map<std::string, std::string>> expected = {
        {"nominal", {}},
        {"face-low", {{"step-top", "out_of_tolerance"}, {"step-top-back", "out_of_tolerance"}}},
        {"corner-missing", {{"tall-corner", "not_found"}, {"tall-side", "overflow"}}}};
    ASSERT_EQ(config_->simulatedParts.size(), expected.size());
    hgtest::TempDir dir;
    auto inspector = hg::daemon::makeEngineInspector(*config_);
    std::size_t compared = 0;
    for (const auto& [part, mesh] : config_->simulatedParts) {
        SCOPED_TRACE(part);
        const auto images = frames(*config_, part);
        auto outcome = inspect(*inspector, *config_, images);
        ASSERT_TRUE(outcome.ok) << outcome.error;
        EXPECT_EQ(notOk(outcome), expected.at(part));
        EXPECT_EQ(outcome.pass, expected.at(part).empty());

        const fs::path folder = archive(*config_, outcome, dir / "images", part);
        ASSERT_FALSE(folder.empty());
        // The frames as grabbed, lossless, with the cameras and the segmentation the daemon used.
        const auto manifest = hg::vision::readManifest(folder / "manifest.json");
        ASSERT_EQ(manifest.views.size(), images.size());
        EXPECT_EQ(manifest.segmentation.method, hg::vision::SegmentationMethod::Otsu);
        for (std::size_t k = 0; k < images.size(); ++k) {
            EXPECT_EQ(cv::norm(hg::vision::readViewImage(manifest, k), images[k], cv::NORM_INF), 0.0);
            const auto camera = config_->station.cameraAt(config_->programs.at(1).views[k]);
            EXPECT_EQ(manifest.views[k].camera.cameraFromPart().R, camera.cameraFromPart().R);
            EXPECT_EQ(manifest.views[k].camera.cameraFromPart().t, camera.cameraFromPart().t);
            EXPECT_TRUE(fs::exists(folder / ("view_" + std::to_string(k) + ".png")));
        }
        compared += expectSameLandmarks(outcome, inspectOffline(config_->programs.at(1).partFile, folder));
    }
    EXPECT_EQ(compared, 30u) << "3 parts x 10 landmarks";
}

// A copy of the simulated line whose station file's `segmentation` section is `segmentation`.
fs::path lineWithSegmentation(const hgtest::TempDir& dir, const std::string& segmentation)
{
    fs::copy(simFolder(), dir.path() / "sim", fs::copy_options::recursive);
    const fs::path station = dir.path() / "sim" / "station.yaml";
    std::ifstream in(station);
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::string section = "\nsegmentation: {method: otsu, object_is_dark: true}\n";
    const auto at = text.find(section);
    EXPECT_NE(at, std::string::npos) << "config/sim/station.yaml names its segmentation";
    if (at != std::string::npos) text.replace(at, section.size(), "\nsegmentation: " + segmentation + "\n");
    hgtest::writeFile(station, text);
    return dir.path() / "sim" / "hullgauged.yaml";
}

TEST_F(EngineParity, StationFixedThresholdIsWhatTheDaemonSegmentsWith)
{
    const auto images = frames(*config_, "nominal");
    // config/sim/station.yaml renders the part at 0.04 x 255 = 10 grey levels (noise σ 1.5) on a
    // 0.92 x 255 = 235 backlight. Half way between them the silhouettes are Otsu's: the nominal
    // part passes. Below the part's grey level no pixel is dark enough to be part: no view
    // holds the part, so its seat cannot be measured on the threshold's edges either — a
    // seating fault, every landmark not inspected (docs/alignment.md).
    std::map<std::string, std::string> nothingSeen;
    for (const char* id : {"tall-top", "tall-corner", "tall-side", "tall-foot", "riser", "step-top", "step-side",
                           "end-front", "end-back", "step-top-back"})
        nothingSeen[id] = "not_inspected";
    const std::map<std::string, std::map<std::string, std::string>> expected = {
        {"{method: fixed, threshold: 122}", {}}, {"{method: fixed, threshold: 2}", nothingSeen}};
    for (const auto& [segmentation, failing] : expected) {
        SCOPED_TRACE(segmentation);
        hgtest::TempDir dir;
        const auto config = hg::station::loadDaemonConfig(lineWithSegmentation(dir, segmentation));
        ASSERT_EQ(config.segmentation.method, hg::vision::SegmentationMethod::Fixed);
        auto inspector = hg::daemon::makeEngineInspector(config);
        auto outcome = inspect(*inspector, config, images);
        ASSERT_TRUE(outcome.ok) << outcome.error;
        EXPECT_EQ(notOk(outcome), failing);
        EXPECT_EQ(outcome.seatingFault, !failing.empty());
        // The archive says how the daemon segmented, and the offline tool follows it.
        const fs::path folder = archive(config, outcome, dir / "images", "nominal");
        ASSERT_FALSE(folder.empty());
        const auto manifest = hg::vision::readManifest(folder / "manifest.json");
        EXPECT_EQ(manifest.segmentation.method, hg::vision::SegmentationMethod::Fixed);
        EXPECT_EQ(manifest.segmentation.threshold, config.segmentation.threshold);
        EXPECT_EQ(expectSameLandmarks(outcome, inspectOffline(config.programs.at(1).partFile, folder)), 10u);
    }
}

TEST_F(EngineParity, PartProgramInspectionSectionIsWhatTheDaemonInspectsWith)
{
    // early_exit in the part program: the daemon stops at face-low's first moved landmark in
    // the program's order (step-top, the sixth); the four after it are not inspected.
    hgtest::TempDir dir;
    auto config = hg::station::loadDaemonConfig(lineWithSegmentation(dir, "{method: otsu}"));
    std::ofstream(dir.path() / "sim" / "stepped-block.yaml", std::ios::app) << "inspection: {early_exit: true}\n";
    auto inspector = hg::daemon::makeEngineInspector(config);
    auto outcome = inspect(*inspector, config, frames(config, "face-low"));
    ASSERT_TRUE(outcome.ok) << outcome.error;
    const std::map<std::string, std::string> expected = {{"step-top", "out_of_tolerance"},
                                                         {"step-side", "not_inspected"},
                                                         {"end-front", "not_inspected"},
                                                         {"end-back", "not_inspected"},
                                                         {"step-top-back", "not_inspected"}};
    EXPECT_EQ(notOk(outcome), expected);
    const fs::path folder = archive(config, outcome, dir / "images", "face-low");
    ASSERT_FALSE(folder.empty());
    EXPECT_EQ(expectSameLandmarks(outcome, inspectOffline(config.programs.at(1).partFile, folder)), 10u);
}

TEST_F(EngineParity, TheSubVoxelDeviationIsTheOfflineToolsToo)
{
    // inspection.deviation in the part program: the daemon measures every landmark's signed
    // deviation; face-low's step top is 0.7 mm low (config/sim/README.md), the rest as drawn.
    hgtest::TempDir dir;
    auto config = hg::station::loadDaemonConfig(lineWithSegmentation(dir, "{method: otsu}"));
    std::ofstream(dir.path() / "sim" / "stepped-block.yaml", std::ios::app) << "inspection: {deviation: true}\n";
    auto inspector = hg::daemon::makeEngineInspector(config);
    for (const std::string part : {"nominal", "face-low"}) {
        SCOPED_TRACE(part);
        auto outcome = inspect(*inspector, config, frames(config, part));
        ASSERT_TRUE(outcome.ok) << outcome.error;
        int measured = 0;
        for (const auto& l : outcome.landmarks) {
            if (!l.deviationMm) continue;
            ++measured;
            const bool lowered = part == "face-low" && (l.id == "step-top" || l.id == "step-top-back");
            EXPECT_NEAR(*l.deviationMm, lowered ? -0.7 : 0.0, std::max(*l.uncertaintyMm, 0.02)) << l.id;
            EXPECT_EQ(l.decision ? hg::enumName(*l.decision) : "", lowered ? "nonconforms" : "conforms") << l.id;
        }
        EXPECT_GE(measured, 6) << "most landmarks lie on some view's outline";
        const fs::path folder = archive(config, outcome, dir / "images", part);
        ASSERT_FALSE(folder.empty());
        EXPECT_EQ(expectSameLandmarks(outcome, inspectOffline(config.programs.at(1).partFile, folder)), 10u);
    }
}

// The capability check when the daemon loads a program (docs/inspection.md,
// "Capability"): ±0.005 mm at 0.16 mm per pixel is a zone no view of the
// plan can prove; the program is refused naming the landmark, unless its
// entry says `force`, and then that landmark is never ok. The station's
// calibration records enter the budget, and the archive carries them: the
// offline tool gives the same deviations and uncertainties to the last bit.
TEST_F(EngineParity, AToleranceTheStationCannotProveIsRefusedAtLoadUnlessForced)
{
    hgtest::TempDir dir;
    const fs::path line = lineWithSegmentation(dir, "{method: otsu}");
    const fs::path program = dir.path() / "sim" / "stepped-block.yaml";
    std::ifstream in(program);
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::string tallTop = "{id: tall-top, position: [-15, 0, 30], tolerance_mm: 0.4}";
    ASSERT_NE(text.find(tallTop), std::string::npos);
    text.replace(text.find(tallTop), tallTop.size(), "{id: tall-top, position: [-15, 0, 30], tolerance_mm: 0.005}");
    hgtest::writeFile(program, text);
    const fs::path station = dir.path() / "sim" / "station.yaml";
    std::ifstream sin(station);
    std::string stationText((std::istreambuf_iterator<char>(sin)), std::istreambuf_iterator<char>());
    stationText.replace(stationText.find("  driver:\n    backend: sim"), 0,
                        "  calibration: {std_dev: {fx: 2.0, fy: 2.0, cx: 0.3, cy: 0.3}}\n");
    hgtest::writeFile(station, stationText);

    auto config = hg::station::loadDaemonConfig(line);
    EXPECT_EQ(config.station.calibration.intrinsicsStdDev[2], 0.3);
    const hg::Status begun = hg::daemon::makeEngineInspector(config)->begin(config.programs.at(1));
    const std::string& error = begun.message();
    EXPECT_FALSE(begun.ok());
    EXPECT_NE(error.find("landmark tall-top: tolerance zone 0.01 mm is narrower than 4 U"), std::string::npos) << error;
    EXPECT_NE(error.find("programs.1.force: true"), std::string::npos) << error;

    // `hullgauged --check` (and so the start and every reload) refuses the configuration likewise.
    const std::string check =
        (hgtest::binaryDir() / "bin" / "hullgauged").string() + " --config " + line.string() + " --check";
    const auto checked = hgtest::run(check);
    EXPECT_EQ(checked.status, 2) << checked.err;
    EXPECT_NE(checked.err.find("landmark tall-top: tolerance zone 0.01 mm"), std::string::npos) << checked.err;
    std::ifstream lin(line);
    std::string lineText((std::istreambuf_iterator<char>(lin)), std::istreambuf_iterator<char>());
    const std::string entry = "views: stepped-block-views.yaml}";
    ASSERT_NE(lineText.find(entry), std::string::npos);
    lineText.replace(lineText.find(entry), entry.size(), "views: stepped-block-views.yaml, force: true}");
    hgtest::writeFile(line, lineText);
    const auto forcedCheck = hgtest::run(check);
    EXPECT_EQ(forcedCheck.status, 0) << forcedCheck.err;

    config = hg::station::loadDaemonConfig(line);
    EXPECT_TRUE(config.programs.at(1).force);
    auto inspector = hg::daemon::makeEngineInspector(config);
    auto outcome = inspect(*inspector, config, frames(config, "nominal"));
    ASSERT_TRUE(outcome.ok) << outcome.error;
    EXPECT_EQ(notOk(outcome), (std::map<std::string, std::string>{{"tall-top", "uncertain"}}));
    const fs::path folder = archive(config, outcome, dir / "images", "nominal");
    ASSERT_FALSE(folder.empty());
    const auto manifest = hg::vision::readManifest(folder / "manifest.json");
    EXPECT_EQ(manifest.calibration.intrinsicsStdDev[0], 2.0);
    // Offline the landmark is refused too, and forced it is the daemon's to the last bit.
    const auto refused = hgtest::run((hgtest::binaryDir() / "bin" / "hullgauge").string() + " inspect --part " +
                                     program.string() + " --views " + (folder / "manifest.json").string());
    EXPECT_EQ(refused.status, 2) << refused.err;
    const fs::path out = dir.path() / "forced.json";
    const auto forced =
        hgtest::run((hgtest::binaryDir() / "bin" / "hullgauge").string() + " inspect --force --part " +
                    program.string() + " --views " + (folder / "manifest.json").string() + " --out " + out.string());
    EXPECT_EQ(forced.status, 1) << forced.err;
    std::ifstream result(out);
    EXPECT_EQ(expectSameLandmarks(outcome, nlohmann::json::parse(result)), 10u);
}

// A seat of `shiftMm` along `direction` and `rotationDeg` about `axis`, both through the centre of the
// nominal mesh's bounding box (the aligner's reference point, docs/alignment.md).
hg::geometry::RigidTransform seatAboutCentre(const DaemonConfig& config, const hg::geometry::Vec3& direction,
                                             double shiftMm, const hg::geometry::Vec3& axis, double rotationDeg)
{
    const auto c = hg::model::loadMesh(config.simulatedParts.front().second).bounds().center();
    const auto R = hg::geometry::RigidTransform::rotation(axis, rotationDeg).R;
    return {R, c + direction.normalized() * shiftMm - R * c};
}

TEST_F(EngineParity, TheDaemonMeasuresTheSeatAndInspectsTheSeatedPart)
{
    // Within the program's default limits (1 mm, 1°): 0.3 mm and 0.3°, the simulated line's play.
    const auto seat = seatAboutCentre(*config_, {1, 1, 0}, 0.3, {0.2, -0.3, 1.0}, 0.3);
    const auto c = hg::model::loadMesh(config_->simulatedParts.front().second).bounds().center();
    auto inspector = hg::daemon::makeEngineInspector(*config_);
    for (const std::string part : {"nominal", "face-low"}) {
        SCOPED_TRACE(part);
        auto outcome = inspect(*inspector, *config_, frames(*config_, part, seat));
        ASSERT_TRUE(outcome.ok) << outcome.error;
        ASSERT_TRUE(outcome.alignment);
        EXPECT_TRUE(outcome.alignment->measured) << outcome.alignment->message;
        EXPECT_FALSE(outcome.seatingFault);
        // The seat within 0.02 mm (at the reference point) and 0.02° (docs/alignment.md, "Validation").
        EXPECT_LT((outcome.alignment->seat.apply(c) - seat.apply(c)).norm(), 0.02);
        EXPECT_LT(hg::geometry::rotationAngleDeg(outcome.alignment->seat.R, seat.R), 0.02);
        const std::map<std::string, std::map<std::string, std::string>> expected = {
            {"nominal", {}}, {"face-low", {{"step-top", "out_of_tolerance"}, {"step-top-back", "out_of_tolerance"}}}};
        EXPECT_EQ(notOk(outcome), expected.at(part));
    }
}

// What the cycle runner does with a seated part (docs/alignment.md, "Poses
// corrected for the seat"): the first two views measure the seat while the
// fixture moves on, the remaining three are taken at poses corrected for it.
TEST_F(EngineParity, TheFirstTwoViewsSeatCorrectsThePosesOfTheRest)
{
    const auto seat = seatAboutCentre(*config_, {1, -1, 0.5}, 0.3, {0.3, 0.2, 1.0}, 0.3);
    const auto c = hg::model::loadMesh(config_->simulatedParts.front().second).bounds().center();
    const auto& fixture = config_->station.fixture;
    const auto& planned = config_->programs.at(1).views;
    auto inspector = hg::daemon::makeEngineInspector(*config_);
    for (const std::string part : {"nominal", "face-low"}) {
        SCOPED_TRACE(part);
        const hg::Status begun = inspector->begin(config_->programs.at(1));
        ASSERT_TRUE(begun.ok()) << begun.message();
        ASSERT_EQ(inspector->seatViews(), 2u); // the default alignment.correct_poses_after
        const auto first = frames(*config_, part, seat, {planned[0], planned[1]});
        for (std::size_t k = 0; k < 2; ++k) inspector->addView(k, planned[k], first[k], {});
        const auto provisional = inspector->provisionalSeat();
        ASSERT_TRUE(provisional && provisional->measured && provisional->withinLimits);
        const double shiftError = (provisional->seat.apply(c) - seat.apply(c)).norm();
        const double turnError = hg::geometry::rotationAngleDeg(provisional->seat.R, seat.R);
        // Two views of five already hold the seat within 0.02 mm and 0.02° (docs/alignment.md, "Validation").
        EXPECT_LT(shiftError, 0.02);
        EXPECT_LT(turnError, 0.02);
        std::vector<hg::geometry::FixturePose> rest;
        for (std::size_t k = 2; k < planned.size(); ++k)
            rest.push_back(hg::align::correctPose(fixture, planned[k], provisional->seat, c).pose);
        const auto later = frames(*config_, part, seat, rest);
        for (std::size_t k = 0; k < rest.size(); ++k) {
            inspector->addView(k + 2, rest[k], later[k], {});
            // Judged with the true seat: the corrected view sees the part from the planned direction.
            const double before = hg::align::sightErrorDeg(fixture, planned[k + 2], planned[k + 2], seat, c);
            const double after = hg::align::sightErrorDeg(fixture, planned[k + 2], rest[k], seat, c);
            EXPECT_LT(after, 0.03) << "view " << k + 2 << ", " << before << "° off uncorrected";
            EXPECT_LT(after, 0.25 * before) << "view " << k + 2;
        }
        auto outcome = inspector->finish();
        ASSERT_TRUE(outcome.ok) << outcome.error;
        ASSERT_TRUE(outcome.alignment && outcome.alignment->measured);
        EXPECT_LT((outcome.alignment->seat.apply(c) - seat.apply(c)).norm(), 0.02);
        EXPECT_LT(hg::geometry::rotationAngleDeg(outcome.alignment->seat.R, seat.R), 0.02);
        const std::map<std::string, std::map<std::string, std::string>> expected = {
            {"nominal", {}}, {"face-low", {{"step-top", "out_of_tolerance"}, {"step-top-back", "out_of_tolerance"}}}};
        EXPECT_EQ(notOk(outcome), expected.at(part));
        std::cout << part << ": seat of the first two views off by " << shiftError << " mm, " << turnError << "°\n";
    }
}

TEST_F(EngineParity, APartTwoMillimetresOffIsNotSeatedAndTheOfflineToolSaysSo)
{
    const auto seat = seatAboutCentre(*config_, {1, 0, 0}, 2.0, {0, 0, 1}, 0.0);
    auto inspector = hg::daemon::makeEngineInspector(*config_);
    auto outcome = inspect(*inspector, *config_, frames(*config_, "nominal", seat));
    ASSERT_TRUE(outcome.ok) << outcome.error;
    EXPECT_TRUE(outcome.seatingFault);
    EXPECT_FALSE(outcome.pass);
    ASSERT_TRUE(outcome.alignment);
    EXPECT_GT(outcome.alignment->shiftMm, 1.0); // beyond max_shift_mm
    EXPECT_FALSE(outcome.alignment->withinLimits);
    for (const auto& l : outcome.landmarks) EXPECT_EQ(hg::enumName(l.status), "not_inspected") << l.id;

    // The offline tool on the same frames: exit 3 naming the shift and its limit, the result with its seat.
    hgtest::TempDir dir;
    hg::vision::CaptureManifest manifest;
    const auto images = frames(*config_, "nominal", seat);
    for (std::size_t k = 0; k < images.size(); ++k) {
        const fs::path file = dir / ("v" + std::to_string(k) + ".png");
        ASSERT_TRUE(cv::imwrite(file.string(), images[k]));
        manifest.views.push_back({"v" + std::to_string(k), file,
                                  config_->station.cameraAt(config_->programs.at(1).views[k]), false, std::nullopt});
    }
    hg::vision::writeManifest(manifest, dir / "manifest.json");
    const auto r = hgtest::run((hgtest::binaryDir() / "bin" / "hullgauge").string() + " inspect --part " +
                               config_->programs.at(1).partFile.string() + " --views " +
                               (dir / "manifest.json").string() + " --out " + (dir / "result.json").string());
    EXPECT_EQ(r.status, 3) << r.err;
    EXPECT_NE(r.err.find("seating fault"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("(limit 1 mm)"), std::string::npos) << r.err;
    std::ifstream in(dir / "result.json");
    ASSERT_TRUE(in);
    const auto result = nlohmann::json::parse(in);
    ASSERT_TRUE(result.contains("alignment"));
    EXPECT_GT(result["alignment"]["shift_mm"].get<double>(), 1.0);
}

TEST(ArchiveRule, FailedPartsWithSaveFailedImagesAndEveryInspectedPartWithArchiveAll)
{
    using hg::station::Verdict;
    hg::station::ResultsConfig results; // save_failed_images: true, archive_all: false
    EXPECT_TRUE(hg::daemon::archivesPart(results, Verdict::Fail));
    EXPECT_FALSE(hg::daemon::archivesPart(results, Verdict::Pass));
    results.saveFailedImages = false;
    EXPECT_FALSE(hg::daemon::archivesPart(results, Verdict::Fail));
    results.archiveAll = true;
    EXPECT_TRUE(hg::daemon::archivesPart(results, Verdict::Fail));
    EXPECT_TRUE(hg::daemon::archivesPart(results, Verdict::Pass));
    // A cycle that inspected nothing has nothing to archive.
    EXPECT_FALSE(hg::daemon::archivesPart(results, Verdict::Aborted));
    EXPECT_FALSE(hg::daemon::archivesPart(results, Verdict::Error));
}

} // namespace

namespace {

// Regions per view (docs/daemon.md): frames the camera sent as each view's
// bounds are archived as grabbed with their origin (docs/contracts.md §3), and
// `hullgauge inspect` on that archive gives the daemon's landmarks exactly —
// which are those of the whole frames.
TEST_F(EngineParity, AnArchiveOfRegionFramesReproducesTheDaemonsLandmarks)
{
    hgtest::TempDir dir;
    auto inspector = hg::daemon::makeEngineInspector(*config_);
    const auto& poses = config_->programs.at(1).views;
    for (const std::string part : {"nominal", "face-low"}) {
        SCOPED_TRACE(part);
        const auto images = frames(*config_, part);
        const hg::Status begun = inspector->begin(config_->programs.at(1));
        ASSERT_TRUE(begun.ok()) << begun.message();
        std::vector<cv::Rect> cuts;
        for (std::size_t k = 0; k < images.size(); ++k) {
            const cv::Rect cut = inspector->region(k, poses[k]);
            ASSERT_FALSE(cut.empty()) << k;
            ASSERT_LT(cut.area(), images[k].size().area()) << k << ": a region of the sensor";
            cuts.push_back(cut);
            inspector->addView(k, poses[k], images[k](cut).clone(), cut.tl());
        }
        auto outcome = inspector->finish();
        ASSERT_TRUE(outcome.ok) << outcome.error;
        const auto wholeOutcome = inspect(*inspector, *config_, images);
        EXPECT_EQ(outcome.pass, wholeOutcome.pass);
        EXPECT_EQ(notOk(outcome), notOk(wholeOutcome));

        const fs::path folder = archive(*config_, outcome, dir / "images", part);
        ASSERT_FALSE(folder.empty());
        const auto manifest = hg::vision::readManifest(folder / "manifest.json");
        ASSERT_EQ(manifest.views.size(), images.size());
        for (std::size_t k = 0; k < images.size(); ++k) {
            ASSERT_TRUE(manifest.views[k].origin.has_value()) << k;
            EXPECT_EQ(*manifest.views[k].origin, cuts[k].tl());
            EXPECT_EQ(manifest.views[k].camera.imageSize(), images[k].size()) << "the sensor's size";
            EXPECT_EQ(cv::norm(hg::vision::readViewImage(manifest, k), images[k](cuts[k]), cv::NORM_INF), 0.0);
        }
        EXPECT_EQ(expectSameLandmarks(outcome, inspectOffline(config_->programs.at(1).partFile, folder)), 10u);
    }
}

} // namespace

namespace {

// Where the thresholded frame changes between part and background: the pixels with a 4-neighbour of the other
// class, as the HMI's browser test reads the plain frame (docs/hmi.md, "Reject views").
cv::Mat silhouetteEdges(const cv::Mat& frame)
{
    cv::Mat mask;
    cv::threshold(frame, mask, 0, 255, cv::THRESH_BINARY_INV | cv::THRESH_OTSU);
    cv::Mat eroded, dilated;
    const cv::Mat cross = cv::getStructuringElement(cv::MORPH_CROSS, {3, 3});
    cv::erode(mask, eroded, cross);
    cv::dilate(mask, dilated, cross);
    return dilated != eroded;
}

nlohmann::json readJson(const fs::path& file)
{
    std::ifstream in(file);
    return in ? nlohmann::json::parse(in) : nlohmann::json();
}

} // namespace

// The overlay of a reject picture (docs/hmi.md, "Reject views"): per view its plain frame and view_<k>.json
// with the CAD outline at the measured seat, within a pixel of the silhouette's edge in the frame, and every
// landmark in the frame with its pixel, measuring direction and outcome.
TEST_F(EngineParity, AnArchivedPartHoldsTheOverlayOfEveryView)
{
    const auto seat = seatAboutCentre(*config_, {1, 1, 0}, 0.3, {0.2, -0.3, 1.0}, 0.3);
    auto inspector = hg::daemon::makeEngineInspector(*config_);
    hgtest::TempDir dir;
    for (const std::string part : {"nominal", "corner-missing"}) {
        SCOPED_TRACE(part);
        const auto images = frames(*config_, part, seat);
        auto outcome = inspect(*inspector, *config_, images);
        ASSERT_TRUE(outcome.ok) << outcome.error;
        const fs::path folder = archive(*config_, outcome, dir / "images", part);
        ASSERT_FALSE(folder.empty());
        std::map<std::string, std::string> failedSeen;
        for (std::size_t k = 0; k < images.size(); ++k) {
            const auto overlay = readJson(folder / ("view_" + std::to_string(k) + ".json"));
            ASSERT_TRUE(overlay.is_object()) << "view " << k;
            EXPECT_EQ(overlay["image_size"], nlohmann::json({images[k].cols, images[k].rows}));
            EXPECT_EQ(overlay["seat"], "measured");
            const cv::Mat frame =
                cv::imread((folder / overlay["frame"].get<std::string>()).string(), cv::IMREAD_UNCHANGED);
            EXPECT_EQ(cv::norm(frame, images[k], cv::NORM_INF), 0.0) << "the plain frame is the grabbed one";
            ASSERT_FALSE(overlay["outline"].empty());
            if (part == "nominal") {
                // The nominal part at its seat: the outline lies on the silhouette's edge (within a pixel).
                cv::Mat distance;
                cv::distanceTransform(~silhouetteEdges(images[k]), distance, cv::DIST_L2, cv::DIST_MASK_PRECISE);
                for (const auto& line : overlay["outline"])
                    for (const auto& p : line["points"]) {
                        const cv::Point px(cvRound(p[0].get<double>()), cvRound(p[1].get<double>()));
                        EXPECT_LE(distance.at<float>(px), 1.0f) << "view " << k << " at " << px;
                    }
            }
            for (const auto& l : overlay["landmarks"]) {
                EXPECT_EQ(l["pixel"].size(), 2u);
                if (l["status"] != "ok") failedSeen[l["id"]] = l["status"];
            }
        }
        EXPECT_EQ(failedSeen, notOk(outcome)) << "every failed landmark in a view, with its status";
    }
}
