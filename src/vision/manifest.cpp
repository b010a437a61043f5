#include "hullgauge/vision/manifest.h"

#include "hullgauge/common/error.h"
#include "hullgauge/common/file_kind.h"
#include "hullgauge/common/json.h"
#include "hullgauge/common/log.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <set>
#include <spdlog/fmt/fmt.h>
#include <sstream>
#include <stdexcept>

namespace hg::vision {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

/// The calibration's parameter names, in geometry::CalibrationUncertainty's order.
const std::array<std::string, 9> kIntrinsicNames = {"fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3"};

/// |RᵀR − I| and |det R − 1| of a product of rotations computed in doubles.
constexpr double kOrthonormalToRounding = 1e-12;

std::string typeName(const json& j)
{
    if (j.is_number()) return "a number";
    if (j.is_string()) return "a string";
    if (j.is_boolean()) return "a boolean";
    if (j.is_null()) return "null";
    if (j.is_array()) return "an array";
    return "an object";
}

/// Reads JSON values and names the manifest and the key path in every error.
class ManifestReader {
  public:
    explicit ManifestReader(std::string file) : file_(std::move(file)) {}

    [[noreturn]] void fail(const std::string& field, const std::string& problem) const
    {
        throw InputError(file_, field, problem);
    }

    double number(const json& j, const std::string& field) const
    {
        if (!j.is_number()) fail(field, "expected a number, found " + typeName(j));
        return j.get<double>();
    }

    std::string string(const json& j, const std::string& field) const
    {
        if (!j.is_string()) fail(field, "expected a string, found " + typeName(j));
        return j.get<std::string>();
    }

    bool boolean(const json& j, const std::string& field) const
    {
        if (!j.is_boolean()) fail(field, "expected true or false, found " + typeName(j));
        return j.get<bool>();
    }

    /// A matrix written as `rows` arrays of `cols` numbers.
    Eigen::MatrixXd matrix(const json& j, int rows, int cols, const std::string& field) const
    {
        const std::string shape = "expected " + std::to_string(rows) + " rows of " + std::to_string(cols) + " numbers";
        if (!j.is_array() || j.size() != static_cast<std::size_t>(rows)) fail(field, shape);
        Eigen::MatrixXd m(rows, cols);
        for (int r = 0; r < rows; ++r) {
            const json& row = j[static_cast<std::size_t>(r)];
            if (!row.is_array() || row.size() != static_cast<std::size_t>(cols)) fail(field, shape);
            for (int c = 0; c < cols; ++c) {
                const json& v = row[static_cast<std::size_t>(c)];
                if (!v.is_number()) fail(field, shape + " (row " + std::to_string(r) + " holds " + typeName(v) + ")");
                m(r, c) = v.get<double>();
            }
        }
        return m;
    }

    geometry::Vec3 vector3(const json& j, const std::string& field) const
    {
        if (!j.is_array() || j.size() != 3 ||
            !std::all_of(j.begin(), j.end(), [](const json& v) { return v.is_number(); }))
            fail(field, "expected 3 numbers");
        return {j[0].get<double>(), j[1].get<double>(), j[2].get<double>()};
    }

    std::vector<double> numbers(const json& j, const std::string& field) const
    {
        if (!j.is_array()) fail(field, "expected an array of numbers, found " + typeName(j));
        std::vector<double> out;
        for (std::size_t i = 0; i < j.size(); ++i) out.push_back(number(j[i], field + "[" + std::to_string(i) + "]"));
        return out;
    }

    void warnUnknownKeys(const json& object, std::initializer_list<std::string_view> known,
                         const std::string& where) const
    {
        for (const auto& [key, value] : object.items()) {
            if (std::find(known.begin(), known.end(), key) == known.end())
                log::category("vision")->warn("{}: {}{}: unknown key, ignored", file_, where.empty() ? "" : where + ".",
                                              key);
        }
    }

    geometry::Mat3 cameraMatrix(const json& j, const std::string& field) const
    {
        geometry::Mat3 K = matrix(j, 3, 3, field);
        if (!(K(0, 0) > 0.0) || !(K(1, 1) > 0.0)) fail(field, "fx and fy (K[0][0], K[1][1]) must be positive");
        if (K(1, 0) != 0.0 || K(2, 0) != 0.0 || K(2, 1) != 0.0 || K(2, 2) != 1.0)
            fail(field, "expected an upper triangular matrix [[fx, s, cx], [0, fy, cy], [0, 0, 1]]");
        return K;
    }

    std::vector<double> distortion(const json& j, const std::string& field) const
    {
        std::vector<double> d = numbers(j, field);
        switch (d.size()) {
        case 0:
        case 4:
        case 5:
        case 8:
        case 12:
            return d;
        default:
            fail(field, "expected 4, 5, 8 or 12 OpenCV distortion coefficients, found " + std::to_string(d.size()));
        }
    }

    geometry::Mat3 rotation(const json& j, const std::string& field) const
    {
        geometry::Mat3 R = matrix(j, 3, 3, field);
        // Hand-written or rounded matrices are accepted to 1e-5 and made
        // exactly orthonormal; anything further off is a wrong matrix. One
        // orthonormal to rounding is kept bit for bit: a capture the daemon
        // archives then holds the very cameras it inspected with (docs/daemon.md).
        if (!geometry::isRotation(R, 1e-5)) fail(field, "not a rotation matrix (orthonormal with determinant +1)");
        return geometry::isRotation(R, kOrthonormalToRounding) ? R : geometry::nearestRotation(R);
    }

    cv::Size imageSize(const json& j, const std::string& field) const
    {
        const std::string shape = "expected [width, height] in pixels, two positive integers";
        if (!j.is_array() || j.size() != 2) fail(field, shape);
        int wh[2] = {0, 0};
        for (int i = 0; i < 2; ++i) {
            const json& v = j[static_cast<std::size_t>(i)];
            if (!v.is_number_integer() || v.get<long long>() <= 0 || v.get<long long>() > 1'000'000) fail(field, shape);
            wh[i] = static_cast<int>(v.get<long long>());
        }
        return {wh[0], wh[1]};
    }

    ManifestFixturePose fixturePose(const json& j, const std::string& field) const
    {
        if (!j.is_object()) fail(field, "expected an object {rotation_deg, declination_deg} or {rail_mm}");
        ManifestFixturePose p;
        if (j.contains("rail_mm")) {
            if (j.contains("rotation_deg") || j.contains("declination_deg"))
                fail(field, "give either rotation_deg/declination_deg or rail_mm, not both");
            p.type = geometry::FixtureType::Rail;
            p.pose.railMm = number(j["rail_mm"], field + ".rail_mm");
        } else {
            if (!j.contains("rotation_deg")) fail(field + ".rotation_deg", "missing");
            p.pose.rotationDeg = number(j["rotation_deg"], field + ".rotation_deg");
            if (j.contains("declination_deg"))
                p.pose.declinationDeg = number(j["declination_deg"], field + ".declination_deg");
        }
        warnUnknownKeys(j, {"rotation_deg", "declination_deg", "rail_mm"}, field);
        return p;
    }

    /// A region image's place on the sensor: whole pixels within image_size.
    cv::Point origin(const json& j, const std::string& at, cv::Size sensor) const
    {
        const std::string field = at + ".origin";
        if (!j.is_array() || j.size() != 2) fail(field, "expected [x, y] in sensor pixels");
        cv::Point p;
        int* xy[] = {&p.x, &p.y};
        for (int k = 0; k < 2; ++k) {
            const double value = number(j[static_cast<std::size_t>(k)], field);
            if (value != std::floor(value) || value < 0.0 || value > 1e6)
                fail(field, "expected whole non-negative pixels, found " + j[static_cast<std::size_t>(k)].dump());
            *xy[k] = static_cast<int>(value);
        }
        if (sensor.width <= 0) fail(field, "needs image_size, the sensor's size the region lies on");
        if (p.x >= sensor.width || p.y >= sensor.height)
            fail(field, "[" + std::to_string(p.x) + ", " + std::to_string(p.y) + "] lies outside the " +
                            std::to_string(sensor.width) + "x" + std::to_string(sensor.height) + " sensor");
        return p;
    }

    ManifestView view(const json& j, std::size_t index, const fs::path& folder) const
    {
        const std::string at = "views[" + std::to_string(index) + "]";
        if (!j.is_object()) fail(at, "expected an object, found " + typeName(j));
        ManifestView v;
        if (!j.contains("id")) fail(at + ".id", "missing");
        v.id = string(j["id"], at + ".id");
        if (v.id.empty()) fail(at + ".id", "must not be empty");
        if (!j.contains("image")) fail(at + ".image", "missing");
        const std::string image = string(j["image"], at + ".image");
        if (image.empty()) fail(at + ".image", "must not be empty");
        v.image = fs::path(image).is_absolute() ? fs::path(image) : folder / image;

        geometry::Intrinsics in;
        if (j.contains("image_size")) in.imageSize = imageSize(j["image_size"], at + ".image_size");
        projection(j, at, in);
        if (j.contains("P")) {
            if (in.projection == geometry::Projection::Telecentric ||
                in.distortionModel != geometry::DistortionModel::OpenCV)
                fail(at + ".P", "a telecentric view, or one with the division model, gives K, R and t "
                                "(docs/telecentric.md), not P");
            for (const char* key : {"K", "R", "t", "dist"})
                if (j.contains(key)) fail(at + "." + key, "a view gives either P or K, R, t (+ dist), not both");
            const Eigen::Matrix<double, 3, 4> P = matrix(j["P"], 3, 4, at + ".P");
            if (std::abs(P.leftCols<3>().determinant()) < 1e-12 * std::pow(P.leftCols<3>().norm(), 3))
                fail(at + ".P", "the left 3x3 block is singular: not a perspective camera");
            try {
                v.camera = geometry::CameraModel::fromProjectionMatrix(P, in.imageSize);
            } catch (const ArgumentError& e) {
                fail(at + ".P", e.what());
            }
            v.fromProjectionMatrix = true;
        } else {
            for (const char* key : {"K", "R", "t"})
                if (!j.contains(key)) fail(at + "." + key, "missing (a view needs K, R and t, or P)");
            in.K = cameraMatrix(j["K"], at + ".K");
            if (j.contains("dist")) in.dist = distortion(j["dist"], at + ".dist");
            geometry::RigidTransform pose;
            pose.R = rotation(j["R"], at + ".R");
            pose.t = vector3(j["t"], at + ".t");
            // Magnitudes as the station file bounds them (docs/config-reference.md, "Plausibility"): a 1e308
            // is a typo, not a camera.
            if (pose.t.cwiseAbs().maxCoeff() > 1e5)
                fail(at + ".t", "values must lie within ±1e5 mm (a station is not that large)");
            if (in.imageSize.width > 0) {
                try {
                    in.validate();
                } catch (const ArgumentError& e) {
                    fail(at, e.what());
                }
            } else if (in.K.cwiseAbs().maxCoeff() > 1e7) {
                fail(at + ".K", "values must lie within ±1e7 px");
            }
            v.camera = geometry::CameraModel(in, pose);
        }
        if (j.contains("fixture_pose")) v.fixturePose = fixturePose(j["fixture_pose"], at + ".fixture_pose");
        if (j.contains("origin")) v.origin = origin(j["origin"], at, in.imageSize);
        warnUnknownKeys(j,
                        {"id", "image", "model", "working_distance_mm", "distortion_model", "kappa", "K", "dist", "R",
                         "t", "P", "image_size", "fixture_pose", "origin"},
                        at);
        return v;
    }

    /// `model` (pinhole, the default, or telecentric), the division model's
    /// `distortion_model` and `kappa`, and a telecentric view's
    /// `working_distance_mm` (docs/telecentric.md).
    void projection(const json& j, const std::string& at, geometry::Intrinsics& in) const
    {
        if (j.contains("model")) {
            const std::string model = string(j["model"], at + ".model");
            if (model == "telecentric")
                in.projection = geometry::Projection::Telecentric;
            else if (model != "pinhole")
                fail(at + ".model", "expected pinhole or telecentric, found '" + model + "'");
        }
        if (j.contains("distortion_model")) {
            const std::string model = string(j["distortion_model"], at + ".distortion_model");
            if (model == "division")
                in.distortionModel = geometry::DistortionModel::Division;
            else if (model != "opencv")
                fail(at + ".distortion_model", "expected opencv or division, found '" + model + "'");
        }
        if (j.contains("kappa")) {
            if (in.distortionModel != geometry::DistortionModel::Division)
                fail(at + ".kappa", "only the division model (distortion_model: division) has kappa");
            in.kappa = number(j["kappa"], at + ".kappa");
        }
        if (!j.contains("working_distance_mm")) return;
        if (in.projection != geometry::Projection::Telecentric)
            fail(at + ".working_distance_mm", "only a telecentric view (model: telecentric) has a working distance");
        in.workingDistanceMm = number(j["working_distance_mm"], at + ".working_distance_mm");
        if (!(in.workingDistanceMm > 0.0) || in.workingDistanceMm > 1e5)
            fail(at + ".working_distance_mm", "expected a positive distance within 1e5 mm");
    }

    SegmentationSettings segmentation(const json& j) const
    {
        const std::string at = "segmentation";
        if (!j.is_object()) fail(at, "expected an object, found " + typeName(j));
        SegmentationSettings s;
        if (j.contains("method")) {
            const std::string name = string(j["method"], at + ".method");
            const auto method = parseEnum<SegmentationMethod>(name);
            if (!method)
                fail(at + ".method",
                     "expected " + enumNameList<SegmentationMethod>(", ", " or ") + ", found '" + name + "'");
            s.method = *method;
        }
        if (j.contains("threshold")) {
            s.threshold = number(j["threshold"], at + ".threshold");
            if (s.threshold < 0.0 || s.threshold > kMaxThreshold)
                fail(at + ".threshold", "expected a grey level within [0, 65535]");
        } else if (s.method == SegmentationMethod::Fixed) {
            fail(at + ".threshold", "missing (method 'fixed' needs a threshold)");
        }
        if (j.contains("object_is_dark")) s.objectIsDark = boolean(j["object_is_dark"], at + ".object_is_dark");
        warnUnknownKeys(j, {"method", "threshold", "object_is_dark"}, at);
        return s;
    }

    geometry::CalibrationUncertainty calibration(const json& j) const
    {
        const std::string at = "calibration_uncertainty";
        if (!j.is_object()) fail(at, "expected an object, found " + typeName(j));
        geometry::CalibrationUncertainty u;
        if (j.contains("intrinsics_std_dev")) {
            const json& sd = j["intrinsics_std_dev"];
            const std::string sdAt = at + ".intrinsics_std_dev";
            if (!sd.is_object()) fail(sdAt, "expected an object {fx, fy, cx, cy, k1, k2, p1, p2, k3}");
            for (std::size_t i = 0; i < kIntrinsicNames.size(); ++i)
                if (sd.contains(kIntrinsicNames[i]))
                    u.intrinsicsStdDev[i] = nonNegative(sd[kIntrinsicNames[i]], sdAt + "." + kIntrinsicNames[i]);
            warnUnknownKeys(sd, {"fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3"}, sdAt);
        }
        if (j.contains("fixture_rms_mm")) u.fixtureRmsMm = nonNegative(j["fixture_rms_mm"], at + ".fixture_rms_mm");
        warnUnknownKeys(j, {"intrinsics_std_dev", "fixture_rms_mm"}, at);
        return u;
    }

    geometry::ImageQuality imageQuality(const json& j) const
    {
        const std::string at = "image_quality";
        if (!j.is_object()) fail(at, "expected an object {noise_grey, contrast_grey}");
        geometry::ImageQuality q;
        if (!j.contains("noise_grey")) fail(at + ".noise_grey", "missing");
        if (!j.contains("contrast_grey")) fail(at + ".contrast_grey", "missing");
        q.noiseGrey = nonNegative(j["noise_grey"], at + ".noise_grey");
        q.contrastGrey = nonNegative(j["contrast_grey"], at + ".contrast_grey");
        if (!(q.contrastGrey > 0.0)) fail(at + ".contrast_grey", "the backlight's contrast must be positive");
        q.given = true;
        warnUnknownKeys(j, {"noise_grey", "contrast_grey"}, at);
        return q;
    }

  private:
    double nonNegative(const json& j, const std::string& field) const
    {
        const double v = number(j, field);
        if (!(v >= 0.0) || v > 1e6) fail(field, "expected a number within [0, 1e6]");
        return v;
    }

    std::string file_;
};

json matrixJson(const Eigen::MatrixXd& m)
{
    json rows = json::array();
    for (Eigen::Index r = 0; r < m.rows(); ++r) {
        json row = json::array();
        for (Eigen::Index c = 0; c < m.cols(); ++c) row.push_back(m(r, c));
        rows.push_back(row);
    }
    return rows;
}

/// `image` as written in a manifest stored in `folder`: relative when it lies
/// below the folder's tree, absolute otherwise.
std::string relativeImagePath(const fs::path& image, const fs::path& folder)
{
    const fs::path abs = fs::absolute(image).lexically_normal();
    const fs::path rel = abs.lexically_relative(fs::absolute(folder).lexically_normal());
    return rel.empty() ? abs.generic_string() : rel.generic_string();
}

} // namespace

const ManifestView* CaptureManifest::find(const std::string& id) const
{
    for (const ManifestView& v : views)
        if (v.id == id) return &v;
    return nullptr;
}

CaptureManifest readManifest(const fs::path& file)
{
    const std::string name = file.string();
    std::ifstream in(file, std::ios::binary);
    if (!in) throw InputError(name, "", "cannot open file");
    std::stringstream ss;
    ss << in.rdbuf();
    const std::string text = ss.str();

    // Duplicate keys, numbers past double range and syntax errors name the file, key and line.
    const json root = parseJson(text, name);

    ManifestReader reader(name);
    if (!root.is_object()) reader.fail("(document)", "expected a JSON object with 'views'");
    if (!root.contains("views")) reader.fail("views", "missing");
    const json& views = root["views"];
    if (!views.is_array()) reader.fail("views", "expected an array of views, found " + typeName(views));
    if (views.empty()) reader.fail("views", "expected at least one view");

    CaptureManifest manifest;
    manifest.file = file;
    const fs::path folder = file.parent_path();
    std::set<std::string> ids;
    for (std::size_t i = 0; i < views.size(); ++i) {
        ManifestView v = reader.view(views[i], i, folder);
        if (!ids.insert(v.id).second) reader.fail("views[" + std::to_string(i) + "].id", "duplicate id '" + v.id + "'");
        manifest.views.push_back(std::move(v));
    }
    if (root.contains("segmentation") && !root["segmentation"].is_null())
        manifest.segmentation = reader.segmentation(root["segmentation"]);
    if (root.contains("calibration_uncertainty") && !root["calibration_uncertainty"].is_null())
        manifest.calibration = reader.calibration(root["calibration_uncertainty"]);
    if (root.contains("image_quality") && !root["image_quality"].is_null())
        manifest.imageQuality = reader.imageQuality(root["image_quality"]);
    // "simulation": the true seat `hullgauge simulate --seat` rendered with, for the reader, not the model.
    reader.warnUnknownKeys(root, {"views", "segmentation", "simulation", "calibration_uncertainty", "image_quality"},
                           "");
    return manifest;
}

std::string manifestJson(const CaptureManifest& manifest, const fs::path& folder)
{
    json views = json::array();
    for (const ManifestView& v : manifest.views) {
        const geometry::Intrinsics& in = v.camera.intrinsics();
        const geometry::RigidTransform& pose = v.camera.cameraFromPart();
        json j;
        j["id"] = v.id;
        j["image"] = relativeImagePath(v.image, folder);
        // A pinhole view's manifest stays as it always was: `model` only for a telecentric one.
        if (in.projection == geometry::Projection::Telecentric) {
            j["model"] = "telecentric";
            if (std::isfinite(in.workingDistanceMm)) j["working_distance_mm"] = in.workingDistanceMm;
        }
        if (in.distortionModel == geometry::DistortionModel::Division) {
            j["distortion_model"] = "division";
            j["kappa"] = in.kappa;
        }
        j["K"] = matrixJson(in.K);
        j["dist"] = in.dist.empty() ? std::vector<double>(5, 0.0) : in.dist;
        j["R"] = matrixJson(pose.R);
        j["t"] = std::vector<double>{pose.t.x(), pose.t.y(), pose.t.z()};
        if (in.imageSize.width > 0 && in.imageSize.height > 0)
            j["image_size"] = {in.imageSize.width, in.imageSize.height};
        if (v.origin) j["origin"] = {v.origin->x, v.origin->y};
        if (v.fixturePose) {
            const geometry::FixturePose& p = v.fixturePose->pose;
            if (v.fixturePose->type == geometry::FixtureType::Rail)
                j["fixture_pose"] = {{"rail_mm", p.railMm}};
            else
                j["fixture_pose"] = {{"rotation_deg", p.rotationDeg}, {"declination_deg", p.declinationDeg}};
        }
        views.push_back(std::move(j));
    }
    json seg;
    seg["method"] = enumName(manifest.segmentation.method);
    if (manifest.segmentation.method == SegmentationMethod::Fixed) seg["threshold"] = manifest.segmentation.threshold;
    seg["object_is_dark"] = manifest.segmentation.objectIsDark;
    json root = {{"views", views}, {"segmentation", seg}};
    if (manifest.calibration.recorded()) {
        json sd;
        for (std::size_t i = 0; i < kIntrinsicNames.size(); ++i)
            sd[kIntrinsicNames[i]] = manifest.calibration.intrinsicsStdDev[i];
        root["calibration_uncertainty"] = {{"intrinsics_std_dev", sd},
                                           {"fixture_rms_mm", manifest.calibration.fixtureRmsMm}};
    }
    if (manifest.imageQuality)
        root["image_quality"] = {{"noise_grey", manifest.imageQuality->noiseGrey},
                                 {"contrast_grey", manifest.imageQuality->contrastGrey}};
    return root.dump(2) + '\n';
}

void writeManifest(const CaptureManifest& manifest, const fs::path& file)
{
    std::ofstream out(file, std::ios::binary | std::ios::trunc);
    if (!out) throw FaultError("cannot write manifest " + file.string());
    out << manifestJson(manifest, file.parent_path());
    out.close();
    if (!out) throw FaultError("cannot write manifest " + file.string());
}

namespace {

// 2^28 pixels: sixteen times a 16-megapixel camera's frame.
constexpr std::uint64_t kMaxImagePixels = std::uint64_t{1} << 28;

/// A PNG's width and height from its IHDR chunk (bytes 16..23), read before
/// any decoder allocates the frame; nullopt for anything but a PNG.
std::optional<std::pair<std::uint64_t, std::uint64_t>> pngSize(const fs::path& file)
{
    std::ifstream in(file, std::ios::binary);
    unsigned char head[24] = {};
    if (!in.read(reinterpret_cast<char*>(head), sizeof head)) return std::nullopt;
    static constexpr unsigned char kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
    if (!std::equal(kSignature, kSignature + 8, head) || std::string(head + 12, head + 16) != "IHDR")
        return std::nullopt;
    auto be32 = [&](int at) {
        return (std::uint64_t{head[at]} << 24) | (std::uint64_t{head[at + 1]} << 16) |
               (std::uint64_t{head[at + 2]} << 8) | std::uint64_t{head[at + 3]};
    };
    return std::pair{be32(16), be32(20)};
}

} // namespace

cv::Mat readViewImage(const CaptureManifest& manifest, std::size_t index)
{
    if (index >= manifest.views.size())
        throw ArgumentError("readViewImage: index: no view " + std::to_string(index) + " (the manifest has " +
                            std::to_string(manifest.views.size()) + ")");
    const ManifestView& v = manifest.views[index];
    const std::string name = manifest.file.string();
    const std::string field = "views[" + std::to_string(index) + "].image";
    std::error_code ec;
    if (auto problem = notARegularFile(v.image); !problem.empty())
        throw InputError(name, field,
                         problem == "no such file" ? "no such image file '" + v.image.string() + "'"
                                                   : "image file '" + v.image.string() + "' is " + problem);
    if (auto size = pngSize(v.image); size && size->first * size->second > kMaxImagePixels)
        throw InputError(name, field,
                         fmt::format("image '{}' claims {}x{} pixels, past the {} a frame may hold", v.image.string(),
                                     size->first, size->second, kMaxImagePixels));
    cv::Mat frame;
    try {
        frame = cv::imread(v.image.string(), cv::IMREAD_ANYDEPTH | cv::IMREAD_ANYCOLOR);
    } catch (const cv::Exception& e) {
        throw InputError(name, field, "cannot read image '" + v.image.string() + "': " + e.what());
    }
    if (frame.empty()) throw InputError(name, field, "cannot read image '" + v.image.string() + "'");
    cv::Mat grey;
    try {
        grey = toGrey(frame);
    } catch (const ArgumentError& e) {
        throw InputError(name, field, "'" + v.image.string() + "': " + e.what());
    }
    const cv::Size expected = v.camera.imageSize();
    if (v.origin) {
        const cv::Rect placed(*v.origin, grey.size());
        if ((placed & cv::Rect(cv::Point(0, 0), expected)) != placed)
            throw InputError(name, field,
                             "image '" + v.image.string() + "' is " + std::to_string(grey.cols) + "x" +
                                 std::to_string(grey.rows) + " at origin [" + std::to_string(v.origin->x) + ", " +
                                 std::to_string(v.origin->y) + "]: it leaves the " + std::to_string(expected.width) +
                                 "x" + std::to_string(expected.height) + " sensor of image_size");
        return grey;
    }
    if (expected.width > 0 && expected.height > 0 && grey.size() != expected) {
        throw InputError(name, field,
                         "image '" + v.image.string() + "' is " + std::to_string(grey.cols) + "x" +
                             std::to_string(grey.rows) + " but image_size says " + std::to_string(expected.width) +
                             "x" + std::to_string(expected.height));
    }
    return grey;
}

} // namespace hg::vision
