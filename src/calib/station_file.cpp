#include "hullgauge/calib/station_file.h"

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <fstream>

#include "hullgauge/common/clock.h"
#include "hullgauge/common/config_node.h"
#include "hullgauge/common/durable_file.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/log.h"

namespace hg::calib {
namespace {

YAML::Node flowSequence(const std::vector<double>& values)
{
    YAML::Node n(YAML::NodeType::Sequence);
    n.SetStyle(YAML::EmitterStyle::Flow);
    for (double v : values) n.push_back(v);
    return n;
}

YAML::Node vec3(const geometry::Vec3& v)
{
    return flowSequence({v.x(), v.y(), v.z()});
}

YAML::Node mat3(const geometry::Mat3& M)
{
    YAML::Node rows(YAML::NodeType::Sequence);
    rows.SetStyle(YAML::EmitterStyle::Flow);
    for (int r = 0; r < 3; ++r) rows.push_back(flowSequence({M(r, 0), M(r, 1), M(r, 2)}));
    return rows;
}

/// A map child, created (as a map) when missing.
YAML::Node section(YAML::Node parent, const char* key)
{
    YAML::Node child = parent[key];
    if (!child.IsMap()) child = YAML::Node(YAML::NodeType::Map);
    return child;
}

/// `std_dev` of a calibration record: each parameter's one standard
/// deviation by name (docs/calibration.md).
YAML::Node stdDevMap(const std::vector<std::string>& names, const std::vector<double>& stdDev)
{
    YAML::Node sd(YAML::NodeType::Map);
    sd.SetStyle(YAML::EmitterStyle::Flow);
    for (std::size_t i = 0; i < names.size() && i < stdDev.size(); ++i) sd[names[i]] = stdDev[i];
    return sd;
}

YAML::Node imageSize(cv::Size size)
{
    YAML::Node node(YAML::NodeType::Sequence);
    node.SetStyle(YAML::EmitterStyle::Flow);
    node.push_back(size.width);
    node.push_back(size.height);
    return node;
}

std::string timestamp()
{
    std::time_t now = std::chrono::system_clock::to_time_t(Clock::steady().wallNow());
    std::tm tm{};
    gmtime_r(&now, &tm);
    char b[32];
    std::strftime(b, sizeof b, "%Y%m%dT%H%M%SZ", &tm);
    return b;
}

} // namespace

StationFileUpdate::StationFileUpdate(std::filesystem::path file) : file_(std::move(file))
{
    std::error_code ec;
    existed_ = std::filesystem::exists(file_, ec);
    if (existed_) {
        root_ = ConfigNode::loadFile(file_).raw();
        if (!root_.IsMap()) throw InputError(file_.string(), "(document)", "a station file must be a YAML map");
    } else {
        root_ = YAML::Node(YAML::NodeType::Map);
    }
}

void StationFileUpdate::setIntrinsics(const IntrinsicsResult& r, const std::string& method)
{
    YAML::Node cam = section(root_, "camera");
    const auto& in = r.intrinsics;
    cam["image_size"] = imageSize(in.imageSize);
    // The model the intrinsics are of (docs/telecentric.md); a pinhole
    // station's file keeps its form, `model` written only where it was.
    if (in.projection == geometry::Projection::Telecentric)
        cam["model"] = "telecentric";
    else if (cam["model"])
        cam["model"] = "pinhole";
    // K states what a data sheet's magnification, pixel pitch and principal point did.
    for (const char* key : {"magnification", "pixel_pitch_mm", "principal_point"}) cam.remove(key);
    cam["K"] = mat3(in.K);
    cam["dist"] = flowSequence(in.dist);
    cam.remove("kappa");
    if (in.distortionModel == geometry::DistortionModel::Division) {
        cam["distortion_model"] = "division";
        cam["kappa"] = in.kappa;
    } else if (cam["distortion_model"]) {
        cam["distortion_model"] = "opencv";
    }
    YAML::Node cal(YAML::NodeType::Map);
    cal["method"] = method;
    cal["rms_px"] = r.rmsPx;
    cal["views"] = static_cast<int>(r.viewNames.size());
    cal["std_dev"] = stdDevMap(intrinsicParameterNames(), r.stdDev);
    cal["date"] = timestamp();
    cam["calibration"] = cal;
    root_["camera"] = cam;
}

void StationFileUpdate::setRailIntrinsics(const RailCalibration& r, const std::string& field)
{
    YAML::Node cam = section(root_, "camera");
    if (!cam["image_size"])
        throw InputError(file_.string(), field,
                         "the station has no camera.image_size; add it (or run calibrate intrinsics) first");
    geometry::Mat3 K;
    K << r.fit.fx, 0.0, r.fit.cx, 0.0, r.fit.fy, r.fit.cy, 0.0, 0.0, 1.0;
    cam["K"] = mat3(K);
    cam["dist"] = flowSequence({0.0, 0.0, 0.0, 0.0, 0.0});
    YAML::Node cal(YAML::NodeType::Map);
    cal["method"] = "rail";
    cal["rms_px"] = r.fit.rmsPx;
    cal["views"] = r.fit.observations;
    cal["std_dev"] = stdDevMap({"fx", "fy", "cx", "cy"}, r.fit.stdDev);
    cal["date"] = timestamp();
    cam["calibration"] = cal;
    root_["camera"] = cam;
}

void StationFileUpdate::setTelecentricIntrinsics(const TelecentricCalibration& r, const std::string& method,
                                                 std::optional<double> pixelPitchMm)
{
    YAML::Node cam = section(root_, "camera");
    const auto& in = r.intrinsics;
    cam["model"] = "telecentric";
    cam["image_size"] = imageSize(in.imageSize);
    // One of the two forms of a telecentric camera section: the lens's
    // magnification through the sensor's pitch, or K (px per mm) alone.
    for (const char* key : {"K", "magnification", "pixel_pitch_mm", "principal_point"}) cam.remove(key);
    if (pixelPitchMm) {
        // The data sheet's horizontal pitch fixes the scale; the measured
        // aspect gives the vertical pitch: fx = m/Δp_h, fy = m/Δp_v.
        const double magnification = in.K(0, 0) * *pixelPitchMm;
        cam["magnification"] = magnification;
        cam["pixel_pitch_mm"] = flowSequence({*pixelPitchMm, magnification / in.K(1, 1)});
        cam["principal_point"] = flowSequence({in.K(0, 2), in.K(1, 2)});
    } else {
        cam["K"] = mat3(in.K);
    }
    cam["dist"] = flowSequence(in.dist);
    YAML::Node cal(YAML::NodeType::Map);
    cal["method"] = method;
    cal["model"] = "telecentric";
    cal["rms_px"] = r.rmsPx;
    cal["views"] = static_cast<int>(r.viewNames.size());
    cal["pixel_aspect"] = r.pixelAspect();
    cal["tilt_spread_deg"] = r.tiltSpreadDeg;
    cal["std_dev"] = stdDevMap(intrinsicParameterNames(), r.stdDev);
    cal["date"] = timestamp();
    cam["calibration"] = cal;
    root_["camera"] = cam;
}

void StationFileUpdate::setFixtureAxes(const FixtureAxesResult& r)
{
    YAML::Node fix = section(root_, "fixture");
    fix["type"] = std::string(enumName(geometry::FixtureType::RotationDeclination));
    YAML::Node cff(YAML::NodeType::Map);
    cff["R"] = mat3(r.cameraFromFixture.R);
    cff["t"] = vec3(r.cameraFromFixture.t);
    fix["camera_from_fixture"] = cff;
    fix["rotation_axis"] = vec3(r.rotationAxis);
    fix["declination_axis"] = vec3(r.declinationAxis);
    // Skew axes (a common perpendicular of non-zero length) are used by the
    // kinematics through these points (geometry/fixture.h).
    fix["rotation_axis_point"] = vec3(r.rotationAxisPoint);
    fix["declination_axis_point"] = vec3(r.declinationAxisPoint);
    YAML::Node cal(YAML::NodeType::Map);
    cal["axes_angle_deg"] = r.axesAngleDeg;
    cal["axes_distance_mm"] = r.axesDistanceMm;
    cal["rms_px"] = r.rmsPx;
    cal["rms_mm"] = r.rmsMm;
    cal["views"] = r.views;
    cal["date"] = timestamp();
    fix["calibration"] = cal;
    root_["fixture"] = fix;
}

std::optional<std::filesystem::path> StationFileUpdate::commit()
{
    YAML::Emitter out;
    out.SetDoublePrecision(12);
    out << root_;
    if (!out.good()) throw FaultError(file_.string() + ": cannot format the station: " + out.GetLastError());
    std::string text = std::string(out.c_str()) + "\n";

    std::optional<std::filesystem::path> backup;
    std::error_code ec;
    if (existed_ && std::filesystem::exists(file_, ec)) {
        // A time-stamped copy, never overwriting an earlier backup.
        std::filesystem::path b = file_;
        b += ".bak-" + timestamp();
        for (int i = 1; std::filesystem::exists(b, ec); ++i) {
            b = file_;
            b += ".bak-" + timestamp() + "-" + std::to_string(i);
        }
        std::filesystem::copy_file(file_, b, ec);
        if (ec) throw FaultError(file_.string() + ": cannot write backup " + b.string() + ": " + ec.message());
        backup = b;
    }
    replaceFileDurably(file_, text);
    hg::log::category("calib")->info("wrote {}{}", file_.string(), backup ? " (backup " + backup->string() + ")" : "");
    return backup;
}

namespace {

// A calibration record as JSON: numbers stay numbers, maps and lists nest.
nlohmann::json recordJson(const YAML::Node& node)
{
    if (!node || node.IsNull()) return nullptr;
    if (node.IsMap()) {
        auto out = nlohmann::json::object();
        for (const auto& kv : node) out[kv.first.as<std::string>()] = recordJson(kv.second);
        return out;
    }
    if (node.IsSequence()) {
        auto out = nlohmann::json::array();
        for (const auto& item : node) out.push_back(recordJson(item));
        return out;
    }
    double number = 0;
    if (YAML::convert<double>::decode(node, number)) return number;
    return node.as<std::string>();
}

StationCalibration readCalibration(const std::filesystem::path& file)
{
    StationCalibration c;
    c.file = file;
    try {
        const auto root = YAML::LoadFile(file.string());
        if (root["camera"]) c.camera = recordJson(root["camera"]["calibration"]);
        if (root["fixture"]) c.fixture = recordJson(root["fixture"]["calibration"]);
    } catch (const std::exception& e) {
        c.error = e.what();
    }
    return c;
}

} // namespace

std::vector<StationCalibration> calibrationHistory(const std::filesystem::path& stationFile, std::size_t max)
{
    std::vector<StationCalibration> history;
    if (max == 0) return history;
    history.push_back(readCalibration(stationFile));
    // Backups are named by their UTC time (%Y%m%dT%H%M%SZ) and, after the
    // first of one second, a number (-1, -2, ...): newest first is the time's
    // descending order, then the number's.
    std::vector<std::pair<std::pair<std::string, long>, std::filesystem::path>> backups;
    const auto prefix = stationFile.filename().string() + ".bak-";
    std::error_code ec;
    const auto folder = stationFile.has_parent_path() ? stationFile.parent_path() : std::filesystem::path(".");
    for (std::filesystem::directory_iterator it(folder, ec), end; !ec && it != end; it.increment(ec)) {
        const auto name = it->path().filename().string();
        if (name.rfind(prefix, 0) != 0 || !it->is_regular_file(ec)) continue;
        const auto stamp = name.substr(prefix.size());
        const auto dash = stamp.find('-');
        const long number = dash == std::string::npos ? 0 : std::strtol(stamp.c_str() + dash + 1, nullptr, 10);
        backups.push_back({{stamp.substr(0, dash), number}, it->path()});
    }
    std::sort(backups.begin(), backups.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
    for (const auto& b : backups) {
        if (history.size() >= max) break;
        history.push_back(readCalibration(b.second));
    }
    return history;
}

} // namespace hg::calib
