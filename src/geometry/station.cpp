#include "hullgauge/geometry/station.h"
#include "hullgauge/geometry/fixture_motion.h"

#include <cmath>
#include <stdexcept>

#include "hullgauge/common/error.h"

namespace hg::geometry {
namespace {

/// Lengths and angles of a station lie within 10^5 (100 m, or 277 turns): a
/// value past that is a typo, named here rather than blamed on the part later.
constexpr double kMaxMagnitude = 1e5;

void checkMagnitude(const ConfigNode& node, const Eigen::VectorXd& v, const char* unit)
{
    if (v.cwiseAbs().maxCoeff() > kMaxMagnitude)
        node.fail(std::string("values must lie within ±1e5 ") + unit + " (a station is not that large)");
}

Vec3 parsePosition(const ConfigNode& node)
{
    Vec3 p = node.asVector3();
    checkMagnitude(node, p, "mm");
    return p;
}

Range parseRange(const ConfigNode& node)
{
    auto v = node.asDoubles(2);
    checkMagnitude(node, Eigen::Vector2d(v[0], v[1]), "mm or degrees");
    if (!(v[0] <= v[1])) node.fail("range [min, max] must have min <= max");
    return {v[0], v[1]};
}

Vec3 parseAxis(const ConfigNode& node)
{
    Vec3 a = node.asVector3();
    if (a.norm() < 1e-9) node.fail("axis must not be the zero vector");
    return a.normalized();
}

Projection parseProjection(const ConfigNode& cam)
{
    const auto model = cam.optional("model");
    if (!model || model->asString() == "pinhole") return Projection::Pinhole;
    if (model->asString() == "telecentric") return Projection::Telecentric;
    model->fail("unknown camera model '" + model->asString() + "' (pinhole or telecentric)");
    return Projection::Pinhole;
}

/// A telecentric lens's K from its data sheet (docs/telecentric.md): fx =
/// magnification / pixel pitch (px per mm of object), the principal point
/// given or the image's centre. `K` states the same, as calibration writes it.
Mat3 telecentricK(const ConfigNode& cam, cv::Size imageSize)
{
    if (cam.has("K")) {
        for (const char* key : {"magnification", "pixel_pitch_mm", "principal_point"})
            if (auto n = cam.optional(key))
                n->fail("give either K or magnification, pixel_pitch_mm and principal_point");
        return cam["K"].asMatrix3();
    }
    const double magnification = cam["magnification"].asDoubleIn(1e-6, 1e6);
    const auto pitchNode = cam["pixel_pitch_mm"];
    Vec2 pitch;
    if (pitchNode.isSequence()) {
        const auto v = pitchNode.asDoubles(2);
        pitch = Vec2(v[0], v[1]);
    } else {
        pitch = Vec2::Constant(pitchNode.asDoubleIn(0.0, 1.0));
    }
    if (!(pitch.minCoeff() > 0 && pitch.maxCoeff() <= 1.0)) pitchNode.fail("the pixel pitch must lie in (0, 1] mm");
    Vec2 c((imageSize.width - 1) / 2.0, (imageSize.height - 1) / 2.0);
    if (auto pp = cam.optional("principal_point")) {
        const auto v = pp->asDoubles(2);
        c = Vec2(v[0], v[1]);
    }
    Mat3 K;
    K << magnification / pitch.x(), 0, c.x(), 0, magnification / pitch.y(), c.y(), 0, 0, 1;
    return K;
}

/// `distortion_model` (opencv, the default, or division) and the division
/// model's `kappa` (docs/telecentric.md, "The division model").
void parseDistortionModel(const ConfigNode& cam, Intrinsics& in)
{
    if (auto m = cam.optional("distortion_model")) {
        if (m->asString() == "division")
            in.distortionModel = DistortionModel::Division;
        else if (m->asString() != "opencv")
            m->fail("unknown distortion model '" + m->asString() + "' (opencv or division)");
    }
    if (auto k = cam.optional("kappa")) {
        if (in.distortionModel != DistortionModel::Division)
            k->fail("only the division model (distortion_model: division) has kappa");
        in.kappa = k->asDoubleIn(-1e6, 1e6);
    }
    if (in.distortionModel == DistortionModel::Division)
        for (double d : in.dist)
            if (d != 0.0) cam["dist"].fail("the division model takes kappa, not OpenCV's coefficients");
}

Intrinsics parseCamera(const ConfigNode& cam)
{
    // `regions` is the daemon's (docs/daemon.md, "Regions per view").
    cam.allowOnlyKeys({"model", "image_size", "K", "dist", "pixel_size_um", "depth_of_field_mm", "driver",
                       "calibration", "image_quality", "regions", "grab_s", "magnification", "pixel_pitch_mm",
                       "principal_point", "telecentric_field_mm", "working_distance_mm", "distortion_model", "kappa"});
    Intrinsics in;
    in.projection = parseProjection(cam);
    if (in.projection == Projection::Pinhole)
        for (const char* key :
             {"magnification", "pixel_pitch_mm", "principal_point", "telecentric_field_mm", "working_distance_mm"})
            if (auto n = cam.optional(key))
                n->fail("only a telecentric camera (camera.model: telecentric) has this key");
    auto sizeNode = cam["image_size"];
    auto size = sizeNode.items();
    if (size.size() != 2) sizeNode.fail("expected [width, height] in pixels");
    in.imageSize = cv::Size(static_cast<int>(size[0].asIntIn(1, 65535)), static_cast<int>(size[1].asIntIn(1, 65535)));
    auto kNode = in.projection == Projection::Telecentric && !cam.has("K") ? cam["magnification"] : cam["K"];
    in.K = in.projection == Projection::Telecentric ? telecentricK(cam, in.imageSize) : kNode.asMatrix3();
    if (auto w = cam.optional("working_distance_mm")) in.workingDistanceMm = w->asDoubleIn(1e-3, kMaxMagnitude);
    if (auto d = cam.optional("dist")) {
        in.dist = d->asDoubles();
    }
    parseDistortionModel(cam, in);
    try {
        in.validate();
    } catch (const ArgumentError& e) {
        // Intrinsics::validate names the key first: the value read from that key is bad input (docs/style.md
        // point 4).
        std::string what = e.what();
        (what.rfind("dist", 0) == 0 ? cam["dist"]
         : what.rfind("K", 0) == 0  ? kNode
                                    : sizeNode)
            .fail(what.substr(what.find(':') + 2));
    }
    return in;
}

FixtureKinematics parseFixture(const ConfigNode& fix)
{
    fix.allowOnlyKeys({"type", "camera_from_fixture", "rotation_axis", "declination_axis", "rotation_range_deg",
                       "declination_range_deg", "rail_axis", "rail_range_mm", "rotation_axis_point",
                       "declination_axis_point", "driver", "calibration", "motion"});
    FixtureKinematics k;
    auto typeNode = fix["type"];
    const auto type = parseEnum<FixtureType>(typeNode.asString());
    if (!type)
        typeNode.fail("unknown fixture type '" + typeNode.asString() + "' (" + enumNameList<FixtureType>(", ", " or ") +
                      ")");
    k.type = *type;

    auto cff = fix["camera_from_fixture"];
    cff.allowOnlyKeys({"R", "t"});
    auto rNode = cff["R"];
    Mat3 R = rNode.asMatrix3();
    // Values typed into YAML carry rounding; accept near-rotations and
    // re-orthonormalise, reject anything that is not a rotation.
    if (!isRotation(R, 1e-4)) rNode.fail("not a rotation matrix (must be orthonormal with determinant +1)");
    k.cameraFromFixture.R = nearestRotation(R);
    k.cameraFromFixture.t = parsePosition(cff["t"]);

    if (auto n = fix.optional("rotation_axis")) k.rotationAxis = parseAxis(*n);
    if (auto n = fix.optional("declination_axis")) k.declinationAxis = parseAxis(*n);
    if (auto n = fix.optional("rotation_axis_point")) k.rotationAxisPoint = parsePosition(*n);
    if (auto n = fix.optional("declination_axis_point")) k.declinationAxisPoint = parsePosition(*n);
    if (auto n = fix.optional("rotation_range_deg")) k.rotationRangeDeg = parseRange(*n);
    if (auto n = fix.optional("declination_range_deg")) k.declinationRangeDeg = parseRange(*n);
    if (auto n = fix.optional("rail_axis")) k.railAxis = parseAxis(*n);
    if (auto n = fix.optional("rail_range_mm")) k.railRangeMm = parseRange(*n);
    return k;
}

/// The calibration records' uncertainty (docs/calibration.md): written by
/// `hullgauge calibrate`; only the figures the budget uses are read.
CalibrationUncertainty parseCalibrationUncertainty(const ConfigNode& cam, const ConfigNode& fix)
{
    CalibrationUncertainty u;
    if (auto cal = cam.optional("calibration"))
        if (auto sd = cal->optional("std_dev")) {
            static const char* names[] = {"fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3"};
            for (std::size_t i = 0; i < u.intrinsicsStdDev.size(); ++i)
                if (auto n = sd->optional(names[i])) u.intrinsicsStdDev[i] = n->asDoubleIn(0.0, kMaxMagnitude);
        }
    if (auto cal = fix.optional("calibration"))
        if (auto n = cal->optional("rms_mm")) u.fixtureRmsMm = n->asDoubleIn(0.0, kMaxMagnitude);
    return u;
}

ImageQuality parseImageQuality(const ConfigNode& node)
{
    node.allowOnlyKeys({"noise_grey", "contrast_grey", "blur_sigma_px"});
    ImageQuality q;
    q.noiseGrey = node["noise_grey"].asDoubleIn(0.0, 65535.0);
    q.contrastGrey = node["contrast_grey"].asDoubleIn(0.0, 65535.0);
    if (auto blur = node.optional("blur_sigma_px")) q.blurSigmaPx = blur->asDoubleIn(0.0, 50.0);
    if (!(q.contrastGrey > 0.0)) node["contrast_grey"].fail("the backlight's contrast must be positive");
    q.given = true;
    return q;
}

/// Pinhole: [near, far] from the camera. Telecentric: the same range of
/// camera-frame depths, or one figure, the depth of field centred on the
/// plane of best focus (z = 0, docs/telecentric.md).
Range parseDepthOfField(const ConfigNode& n, const Intrinsics& camera)
{
    if (camera.projection == Projection::Telecentric) {
        if (n.isScalar()) {
            const double depth = n.asDoubleIn(1e-3, kMaxMagnitude);
            return {-depth / 2.0, depth / 2.0};
        }
        const Range r = parseRange(n);
        if (!(r.min > -camera.workingDistanceMm)) n.fail("depth of field must lie beyond the lens's front");
        return r;
    }
    auto r = parseRange(n);
    if (!(r.min > 0)) n.fail("depth of field must lie in front of the camera (near > 0)");
    return r;
}

} // namespace

bool CalibrationUncertainty::recorded() const
{
    if (fixtureRmsMm > 0.0) return true;
    for (double s : intrinsicsStdDev)
        if (s > 0.0) return true;
    return false;
}

CameraModel Station::cameraAt(const FixturePose& pose) const
{
    return CameraModel(camera, fixture.cameraFromPart(pose));
}

Intrinsics parseCameraSection(const ConfigNode& camera)
{
    return parseCamera(camera);
}

Station parseStation(const ConfigNode& root)
{
    Station s;
    auto cam = root["camera"];
    s.camera = parseCamera(cam);
    if (auto n = cam.optional("pixel_size_um")) {
        auto v = n->asDoubles(2);
        if (!(v[0] > 0 && v[1] > 0)) n->fail("pixel size must be positive");
        s.pixelSizeUm = Vec2(v[0], v[1]);
    }
    if (auto n = cam.optional("depth_of_field_mm")) s.depthOfFieldMm = parseDepthOfField(*n, s.camera);
    if (auto n = cam.optional("telecentric_field_mm")) s.telecentricFieldMm = n->asDoubleIn(1e-3, kMaxMagnitude);
    s.fixture = parseFixture(root["fixture"]);
    s.fixture.cameraProjection = s.camera.projection;
    // The motion model (`fixture.motion`, `camera.grab_s`, and the driver's
    // simulator section it falls back to) is checked here, so a typo in it is
    // named when the station is loaded; the planner reads it with stationMotion().
    (void)parseFixtureMotion(root["fixture"], cam, s.fixture.type);
    s.calibration = parseCalibrationUncertainty(cam, root["fixture"]);
    if (auto n = cam.optional("image_quality")) s.imageQuality = parseImageQuality(*n);
    if (auto env = root.optional("environment")) {
        env->allowOnlyKeys({"floor_z_mm"});
        if (auto f = env->optional("floor_z_mm")) s.floorZMm = f->asDoubleIn(-kMaxMagnitude, kMaxMagnitude);
    }
    s.document = root;
    return s;
}

Station loadStation(const std::filesystem::path& file)
{
    return parseStation(ConfigNode::loadFile(file));
}

std::vector<FixturePose> loadPoses(const std::filesystem::path& file, const FixtureKinematics* fixture)
{
    auto root = ConfigNode::loadFile(file);
    if (!root.isSequence()) root.fail("expected a list of fixture poses");
    std::vector<FixturePose> poses;
    for (const auto& item : root.items()) {
        item.allowOnlyKeys({"rotation_deg", "declination_deg", "rail_mm"});
        FixturePose p;
        bool rail = item.has("rail_mm");
        bool angles = item.has("rotation_deg") || item.has("declination_deg");
        if (rail == angles) item.fail("a pose gives either rotation_deg/declination_deg or rail_mm");
        if (rail) {
            p.railMm = item["rail_mm"].asDoubleIn(-kMaxMagnitude, kMaxMagnitude);
        } else {
            if (auto r = item.optional("rotation_deg")) p.rotationDeg = r->asDoubleIn(-kMaxMagnitude, kMaxMagnitude);
            if (auto d = item.optional("declination_deg"))
                p.declinationDeg = d->asDoubleIn(-kMaxMagnitude, kMaxMagnitude);
        }
        if (fixture) {
            bool railFixture = fixture->type == FixtureType::Rail;
            if (rail != railFixture)
                item.fail(railFixture ? "the station's fixture is a rail: give rail_mm"
                                      : "the station's fixture turns and tilts: give rotation_deg/declination_deg");
            if (!fixture->reachable(p))
                item.fail(fmt::format("pose {} is outside the fixture's range", PoseOn{p, fixture->type}));
        }
        poses.push_back(p);
    }
    return poses;
}

} // namespace hg::geometry
