// hullgauge calibrate intrinsics | rail | fixture (docs/contracts.md §5; docs/calibration.md).
#include "command.h"
#include "hullgauge/calib/fixture_axes.h"
#include "hullgauge/calib/fixture_sequence.h"
#include "hullgauge/calib/intrinsics.h"
#include "hullgauge/calib/rail.h"
#include "hullgauge/calib/station_file.h"
#include "hullgauge/calib/target.h"
#include "hullgauge/calib/telecentric.h"
#include "hullgauge/common/config_node.h"
#include "hullgauge/common/error.h"
#include "hullgauge/drivers/fixture.h"
#include "hullgauge/drivers/simulation.h"
#include "hullgauge/geometry/station.h"

#include <filesystem>
#include <iostream>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <string>
#include <vector>

namespace hg::cli {
namespace {

/// Writes the station file (atomically, keeping a backup) and says so on stderr.
void commitAndReport(calib::StationFileUpdate& update, const std::string& path)
{
    auto backup = update.commit();
    std::cerr << "wrote " << path << (backup ? " (previous file kept as " + backup->string() + ")" : "") << '\n';
}

namespace fs = std::filesystem;

cv::Mat readImage(const fs::path& file, const std::string& field)
{
    cv::Mat img = cv::imread(file.string(), cv::IMREAD_UNCHANGED);
    if (img.empty()) throw InputError(file.string(), field, "cannot read the image (PNG, TIFF or JPEG)");
    return img;
}

/// Detects the target in every image, with progress on stderr; images without
/// the target are reported and skipped.
std::vector<calib::TargetView> detectInImages(const std::vector<std::string>& files, const calib::TargetSpec& spec,
                                              cv::Size& size)
{
    std::vector<calib::TargetView> views;
    std::size_t i = 0;
    for (const auto& f : files) {
        ++i;
        cv::Mat img = readImage(f, "--images");
        if (size.area() == 0)
            size = img.size();
        else if (img.size() != size)
            throw InputError(f, "--images",
                             "image size " + std::to_string(img.cols) + "x" + std::to_string(img.rows) +
                                 " differs from the first image's " + std::to_string(size.width) + "x" +
                                 std::to_string(size.height));
        auto v = calib::detectTarget(img, spec, fs::path(f).filename().string());
        std::cerr << "[" << i << "/" << files.size() << "] " << f << ": "
                  << (v ? std::to_string(v->imagePoints.size()) + " corners" : std::string("target not found")) << '\n';
        if (v) views.push_back(std::move(*v));
    }
    return views;
}

/// The camera section of a station file (K, dist, image_size), without
/// requiring the rest of the station to be complete yet.
geometry::Intrinsics readCamera(const fs::path& file)
{
    auto root = ConfigNode::loadFile(file);
    auto cam = root["camera"];
    geometry::Intrinsics in;
    auto sizeNode = cam["image_size"];
    auto size = sizeNode.asDoubles(2);
    in.imageSize = cv::Size(static_cast<int>(size[0]), static_cast<int>(size[1]));
    in.K = cam["K"].asMatrix3();
    if (auto d = cam.optional("dist")) in.dist = d->asDoubles();
    try {
        in.validate();
    } catch (const ArgumentError& e) {
        cam.fail(e.what());
    }
    return in;
}

/// The station's telecentric camera section (docs/telecentric.md), read as
/// the daemon reads it.
geometry::Intrinsics readTelecentricCamera(const fs::path& file)
{
    auto cam = ConfigNode::loadFile(file)["camera"];
    auto in = geometry::parseCameraSection(cam);
    if (in.projection != geometry::Projection::Telecentric)
        cam["model"].fail("the station's camera is not telecentric");
    return in;
}

struct IntrinsicsArgs {
    std::string pattern;
    std::vector<std::string> images;
    std::string out;
    std::string model = "pinhole";
    std::optional<double> pixelPitchMm;
    bool noDistortion = false;
    bool tangential = false;
    calib::IntrinsicsOptions options;
};

/// `--model telecentric` (docs/telecentric-calibration.md): the affine
/// camera's calibration, written as a telecentric camera section.
int runTelecentricIntrinsics(const IntrinsicsArgs& a, const calib::TargetSpec& spec,
                             const std::vector<calib::TargetView>& views, cv::Size size)
{
    calib::TelecentricOptions options;
    options.fixAspectRatio = a.options.fixAspectRatio;
    options.fixK3 = a.options.fixK3;
    options.fixPrincipalPoint = a.options.fixPrincipalPoint;
    options.distortion = !a.noDistortion;
    options.tangential = a.tangential;
    auto result = calib::calibrateTelecentric(views, size, options);
    std::cout << calib::formatTelecentricReport(result);
    calib::StationFileUpdate update(a.out);
    update.setTelecentricIntrinsics(result, fmt::format("{}", spec), a.pixelPitchMm);
    commitAndReport(update, a.out);
    return 0;
}

int runIntrinsics(const IntrinsicsArgs& a)
{
    const bool telecentric = a.model == "telecentric";
    if (!telecentric) {
        if (a.pixelPitchMm) throw InputError("", "--pixel-pitch-mm", "only with --model telecentric");
        if (a.noDistortion) throw InputError("", "--no-distortion", "only with --model telecentric");
        if (a.tangential) throw InputError("", "--tangential", "only with --model telecentric");
    }
    auto spec = calib::TargetSpec::parse(a.pattern);
    cv::Size size;
    auto views = detectInImages(a.images, spec, size);
    if (telecentric) return runTelecentricIntrinsics(a, spec, views, size);
    auto result = calib::calibrateIntrinsics(views, size, a.options);
    std::cout << calib::formatIntrinsicsReport(result);
    calib::StationFileUpdate update(a.out);
    update.setIntrinsics(result, fmt::format("{}", spec));
    commitAndReport(update, a.out);
    return 0;
}

struct RailArgs {
    std::string observations;
    std::string out;
    std::string model = "pinhole";
    std::string station;
};

/// The telecentric rail (docs/telecentric-calibration.md): the rail's
/// direction from the tracks, through the station's calibrated camera.
int runTelecentricRail(const RailArgs& a)
{
    if (a.station.empty())
        throw InputError("", "--station", "the telecentric rail needs the calibrated camera: give --station");
    if (!a.out.empty()) throw InputError("", "--out", "the telecentric rail writes nothing: it reports the direction");
    const auto camera = readTelecentricCamera(a.station);
    const auto tracks = calib::loadTelecentricRailTracks(a.observations);
    calib::TelecentricRailAxis axis;
    try {
        axis = calib::calibrateTelecentricRail(tracks, camera);
    } catch (const InputError& e) {
        throw InputError(a.observations, e.field(), e.problem(), e.line());
    }
    std::cout << calib::formatTelecentricRailReport(axis);
    return 0;
}

int runRail(const RailArgs& a)
{
    if (a.model == "telecentric") return runTelecentricRail(a);
    if (!a.station.empty()) throw InputError("", "--station", "only with --model telecentric");
    auto obs = calib::RailObservations::load(a.observations);
    calib::RailCalibration cal;
    try {
        cal = calib::calibrateRail(obs);
    } catch (const InputError& e) {
        // Name the observations file in the message.
        throw InputError(a.observations, e.field(), e.problem(), e.line());
    }
    std::cout << calib::formatRailReport(cal);
    if (!a.out.empty()) {
        calib::StationFileUpdate update(a.out);
        update.setRailIntrinsics(cal, "--out");
        commitAndReport(update, a.out);
    }
    return 0;
}

struct FixtureArgs {
    std::string station;
    std::string out;
    std::string observations;
    std::string pattern;
    std::vector<std::string> images;
    std::string poses;
};

/// Views from an observations file: `pattern` and a list of views with the
/// commanded angles and either an image (relative to the file) or the corners.
std::vector<calib::FixtureView> loadFixtureObservations(const fs::path& file)
{
    auto root = ConfigNode::loadFile(file);
    root.allowOnlyKeys({"pattern", "views"});
    auto patternNode = root["pattern"];
    calib::TargetSpec spec;
    try {
        spec = calib::TargetSpec::parse(patternNode.asString(), "pattern");
    } catch (const InputError& e) {
        patternNode.fail(e.problem());
    }
    std::vector<calib::FixtureView> views;
    auto list = root["views"];
    if (!list.isSequence()) list.fail("expected a list of {rotation_deg, declination_deg, image | corners}");
    std::size_t i = 0;
    for (const auto& item : list.items()) {
        ++i;
        item.allowOnlyKeys({"rotation_deg", "declination_deg", "image", "corners", "ids"});
        calib::FixtureView v;
        v.pose.rotationDeg = item["rotation_deg"].asDouble();
        v.pose.declinationDeg = item["declination_deg"].asDouble();
        if (item.has("image") == item.has("corners")) item.fail("give exactly one of 'image' or 'corners'");
        if (auto img = item.optional("image")) {
            fs::path p = fs::path(img->asString());
            if (p.is_relative()) p = file.parent_path() / p;
            cv::Mat m = cv::imread(p.string(), cv::IMREAD_UNCHANGED);
            if (m.empty()) img->fail("cannot read image " + p.string());
            auto found = calib::detectTarget(m, spec, p.filename().string());
            std::cerr << "[" << i << "/" << list.size() << "] " << p.string() << ": "
                      << (found ? std::to_string(found->imagePoints.size()) + " corners" : "target not found") << '\n';
            if (!found) continue;
            v.target = std::move(*found);
        } else {
            auto cornersNode = item["corners"];
            std::vector<cv::Point2f> pixels;
            for (const auto& c : cornersNode.items()) {
                auto xy = c.asVector2();
                pixels.emplace_back(static_cast<float>(xy.x()), static_cast<float>(xy.y()));
            }
            std::vector<int> ids;
            if (auto idsNode = item.optional("ids")) {
                for (const auto& id : idsNode->items())
                    ids.push_back(static_cast<int>(id.asIntIn(0, spec.cornerCount() - 1)));
                if (ids.size() != pixels.size()) idsNode->fail("needs one id per corner");
            } else if (static_cast<int>(pixels.size()) != spec.cornerCount()) {
                cornersNode.fail(
                    fmt::format("expected all {} corners of {} in order (or give 'ids')", spec.cornerCount(), spec));
            }
            v.target = calib::viewFromCorners(spec, "views[" + std::to_string(i - 1) + "]", pixels, ids);
        }
        views.push_back(std::move(v));
    }
    return views;
}

int runFixture(const FixtureArgs& a)
{
    auto camera = readCamera(a.station);
    std::vector<calib::FixtureView> views;
    if (!a.observations.empty()) {
        views = loadFixtureObservations(a.observations);
    } else {
        if (a.pattern.empty() || a.poses.empty())
            throw InputError("", "--images", "give --pattern and --poses with --images (or --observations)");
        auto spec = calib::TargetSpec::parse(a.pattern);
        auto poses = geometry::loadPoses(a.poses);
        if (poses.size() != a.images.size())
            throw InputError(a.poses, "--poses",
                             std::to_string(poses.size()) + " poses for " + std::to_string(a.images.size()) +
                                 " images: give one pose per image, in the same order");
        for (std::size_t i = 0; i < a.images.size(); ++i) {
            cv::Mat img = readImage(a.images[i], "--images");
            auto v = calib::detectTarget(img, spec, fs::path(a.images[i]).filename().string());
            std::cerr << "[" << i + 1 << "/" << a.images.size() << "] " << a.images[i] << ": "
                      << (v ? std::to_string(v->imagePoints.size()) + " corners" : "target not found") << '\n';
            if (v) views.push_back({poses[i], std::move(*v)});
        }
    }
    auto result = calib::calibrateFixtureAxes(views, camera, a.observations.empty() ? "--images" : "views");
    std::cout << calib::formatFixtureReport(result);
    std::string out = a.out.empty() ? a.station : a.out;
    calib::StationFileUpdate update(out);
    update.setFixtureAxes(result);
    commitAndReport(update, out);
    return 0;
}

struct RunArgs {
    std::string station;
    std::string out;
    std::string pattern;
    std::string poses;
    std::string saveImages;
    double grabTimeoutS = 5.0;
};

/// Driver calls in the live sequence: a failure is a fault (exit 3) that names the step.
void check(bool ok, const std::string& step, const std::string& message)
{
    if (!ok) throw FaultError("calibrate run: " + step + ": " + message);
}

/// The station's camera for the live sequence, from the backend table. The
/// simulated twin shows the target it carries (`camera.driver.target`) at the
/// pose the fixture driver reports, so the whole sequence runs against the
/// fixture simulator as against the station.
std::unique_ptr<drivers::Camera> makeRunCamera(const ConfigNode& root, drivers::Fixture& fixture)
{
    drivers::SimulationControls sim;
    drivers::CameraEnvironment environment;
    environment.poseSource = [&fixture]() -> std::optional<geometry::FixturePose> {
        drivers::FixtureStatus status;
        if (!fixture.status(status).ok() || status.busy || status.fault) return std::nullopt;
        return status.position;
    };
    environment.simulation = &sim;
    auto camera = drivers::makeCamera(root, std::move(environment));
    if (sim.camera && !sim.camera->setPart("target")) {
        auto driver = root["camera"]["driver"];
        throw InputError(driver.file(), driver.path() + ".target",
                         "the simulated camera shows no calibration target: describe the chessboard the fixture "
                         "carries (docs/camera.md)",
                         driver.line());
    }
    return camera;
}

/// The live sequence (docs/calibration.md, `calibrate run`): home, then for every pose move, wait in
/// position, grab, detect; solve the axes; write the station with a backup.
int runLive(const RunArgs& a)
{
    auto station = geometry::loadStation(a.station);
    if (station.fixture.type != geometry::FixtureType::RotationDeclination)
        throw InputError(a.station, "fixture.type", "calibrate run solves rotation/declination fixtures");
    auto spec = calib::TargetSpec::parse(a.pattern);
    auto poses = geometry::loadPoses(a.poses, &station.fixture);
    if (!a.saveImages.empty()) fs::create_directories(a.saveImages);
    auto root = ConfigNode::loadFile(a.station);
    auto fixture = drivers::makeFixture(station);
    auto camera = makeRunCamera(root, *fixture);
    const auto grabTimeout = std::chrono::milliseconds(static_cast<long long>(a.grabTimeoutS * 1000.0));

    {
        auto s = camera->configure();
        check(s.ok(), "camera configure", s.message());
    }
    {
        auto r = fixture->configure();
        check(r.ok(), "fixture configure", r.message());
        r = fixture->activate();
        check(r.ok(), "fixture activate", r.message());
        std::cerr << "homing the fixture ..." << std::endl;
        r = fixture->home();
        check(r.ok(), "home", r.message());
        r = fixture->waitInPosition(fixture->homeTimeout());
        check(r.ok(), "home", r.message());
    }
    {
        auto s = camera->activate();
        check(s.ok(), "camera activate", s.message());
    }
    calib::FixtureSequenceIo io;
    io.moveTo = [&](const geometry::FixturePose& pose) {
        auto r = fixture->moveTo(pose);
        return r.ok() ? fixture->waitInPosition(fixture->moveTimeout()) : r;
    };
    io.grab = [&](cv::Mat& image) {
        auto frame = camera->grab(grabTimeout);
        if (frame.ok()) image = frame.image;
        return frame.ok() ? Status::success() : Status::failure(StatusCode::BadFrame, frame.message);
    };
    io.progress = [](std::size_t, std::size_t, const std::string& line) { std::cerr << line << std::endl; };
    if (!a.saveImages.empty())
        io.keep = [&](const std::string& name, const cv::Mat& image) {
            cv::imwrite((fs::path(a.saveImages) / name).string(), image);
        };
    auto sequence = calib::runFixtureSequence(poses, spec, station.camera, fixture->type(), io, "--poses");
    (void)camera->deactivate();
    (void)camera->cleanup();
    (void)fixture->deactivate();
    (void)fixture->cleanup();

    const auto& result = sequence.axes;
    std::cout << calib::formatFixtureReport(result);
    std::string out = a.out.empty() ? a.station : a.out;
    calib::StationFileUpdate update(out);
    update.setFixtureAxes(result);
    commitAndReport(update, out);
    return 0;
}

std::function<int()> addCalibrate(CLI::App& app)
{
    auto* cmd = app.add_subcommand("calibrate", "camera and fixture calibration (dissertation 4.3)");
    cmd->require_subcommand(1);

    auto intr = std::make_shared<IntrinsicsArgs>();
    auto* ci = cmd->add_subcommand("intrinsics", "camera matrix and distortion from images of a chessboard or ChArUco "
                                                 "board; writes camera.K, camera.dist, camera.image_size into --out");
    ci->add_option("--pattern", intr->pattern,
                   "chessboard:COLSxROWS:SQUARE_MM (inner corners) or charuco:COLSxROWS:SQUARE_MM:MARKER_MM[:DICT]")
        ->required();
    ci->add_option("--images", intr->images, "images of the target")->required()->check(CLI::ExistingFile);
    ci->add_option("--out", intr->out, "station YAML to update (other keys are kept, the old file backed up)")
        ->required();
    ci->add_flag("--fix-aspect-ratio", intr->options.fixAspectRatio, "estimate one focal length (fx = fy)");
    ci->add_flag("--zero-tangent", intr->options.zeroTangentDist, "no tangential distortion (p1 = p2 = 0)");
    ci->add_flag("--fix-k3", intr->options.fixK3, "no sixth-order radial term (k3 = 0)");
    ci->add_flag("--fix-principal-point", intr->options.fixPrincipalPoint, "principal point at the image centre");
    ci->add_option("--model", intr->model, "camera model: pinhole (default) or telecentric")
        ->check(CLI::IsMember({"pinhole", "telecentric"}));
    ci->add_option("--pixel-pitch-mm", intr->pixelPitchMm,
                   "telecentric: the sensor's horizontal pixel pitch (mm), to write the magnification")
        ->check(CLI::Range(1e-6, 1.0));
    ci->add_flag("--no-distortion", intr->noDistortion,
                 "telecentric: no lens distortion (the principal point is then the image centre)");
    ci->add_flag("--tangential", intr->tangential,
                 "telecentric: estimate p1, p2 too (the principal point is then the image centre)");

    auto rail = std::make_shared<RailArgs>();
    auto* cr = cmd->add_subcommand("rail", "the rail procedure of dissertation 4.3.1: optical centre and f/dp by "
                                           "similar triangles (Tables 4.3-4.6) and a least-squares fit");
    cr->add_option("--observations", rail->observations, "rail observations YAML (docs/calibration.md)")
        ->required()
        ->check(CLI::ExistingFile);
    cr->add_option("--out", rail->out, "station YAML whose camera.K is set from the least-squares fit (optional)");
    cr->add_option("--model", rail->model,
                   "pinhole (default) or telecentric: the rail's direction to the optical axis instead of f/dp")
        ->check(CLI::IsMember({"pinhole", "telecentric"}));
    cr->add_option("--station", rail->station, "telecentric: station YAML with the calibrated telecentric camera")
        ->check(CLI::ExistingFile);

    auto fix = std::make_shared<FixtureArgs>();
    auto* cf = cmd->add_subcommand("fixture", "rotation and declination axes and camera_from_fixture from views of a "
                                              "target carried by the fixture");
    cf->add_option("--station", fix->station, "station YAML with the calibrated camera")
        ->required()
        ->check(CLI::ExistingFile);
    cf->add_option("--out", fix->out, "station YAML to write (default: --station)");
    auto* obsOpt =
        cf->add_option("--observations", fix->observations, "fixture observations YAML (docs/calibration.md)")
            ->check(CLI::ExistingFile);
    auto* imgOpt = cf->add_option("--images", fix->images, "target images, one per pose")->check(CLI::ExistingFile);
    cf->add_option("--pattern", fix->pattern, "target, as for calibrate intrinsics (with --images)");
    cf->add_option("--poses", fix->poses, "poses YAML, one {rotation_deg, declination_deg} per image (with --images)")
        ->check(CLI::ExistingFile);
    obsOpt->excludes(imgOpt);
    imgOpt->excludes(obsOpt);

    auto run = std::make_shared<RunArgs>();
    auto* cl = cmd->add_subcommand("run", "live fixture calibration through the station's drivers: home, then move, "
                                          "grab and detect at every pose, solve the axes, write the station");
    cl->add_option("--station", run->station, "station YAML with camera, fixture and their driver sections")
        ->required()
        ->check(CLI::ExistingFile);
    cl->add_option("--pattern", run->pattern, "target carried by the fixture, e.g. chessboard:12x9:10")->required();
    cl->add_option("--poses", run->poses, "poses YAML: the {rotation_deg, declination_deg} grid to visit")
        ->required()
        ->check(CLI::ExistingFile);
    cl->add_option("--out", run->out, "station YAML to write (default: --station)");
    cl->add_option("--save-images", run->saveImages, "folder for the grabbed images (for calibrate fixture later)");
    cl->add_option("--grab-timeout", run->grabTimeoutS, "seconds to wait for each frame")
        ->check(CLI::Range(0.1, 600.0));

    return [=]() -> int {
        if (cl->parsed()) return runLive(*run);
        if (ci->parsed()) return runIntrinsics(*intr);
        if (cr->parsed()) return runRail(*rail);
        if (cf->parsed()) {
            if (fix->observations.empty() && fix->images.empty())
                throw InputError("", "--observations", "give --observations, or --images with --pattern and --poses");
            return runFixture(*fix);
        }
        return static_cast<int>(ExitStatus::BadInput);
    };
}

} // namespace

HG_REGISTER_COMMAND("calibrate", addCalibrate);

} // namespace hg::cli
