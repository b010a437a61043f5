// The tests' station (docs/contracts.md §2): one station file, as text and
// as the parsed geometry::Station, with the parts tests vary as options.
// Unless told otherwise it is a 640 x 480 camera, f = 800 px, principal
// point (w/2, h/2), on the part's -y side 300 mm from the fixture origin, and
// a rotation/declination fixture turning [-180, 180] deg and tilting [0, 60] deg.
//
// Tests that assert the line of a key in an error message find it with
// lineOf() in the text stationYaml() returns; tests of a malformed station
// make it with replaced() from the standard text.
#pragma once

#include "hullgauge/geometry/station.h"

#include <opencv2/core.hpp>
#include <optional>
#include <string>

namespace hgtest {

/// Where the camera looks from (camera_from_fixture, t = (0, 0, distance)).
enum class CameraMount {
    /// From the part's -y side along +y, image x = part x, image down = part -z:
    /// X_cam = (x, -z, y + d). Positive declination raises the camera: its
    /// centre is (0, -d cos δ, d sin δ) at rotation 0, and rotation θ turns
    /// that point about z (rotation 90° puts it at -x).
    Side,
    /// Along the turntable axis (R = I): X_cam = X + (0, 0, d), the camera
    /// centre at (0, 0, -d) looking along +z.
    Axis,
};

struct StationOptions {
    cv::Size imageSize{640, 480};
    double focalPx = 800.0;
    /// Principal point in pixels; std::nullopt: (width / 2, height / 2).
    std::optional<cv::Point2d> principalPointPx{};
    /// Further camera keys, YAML lines indented by two spaces (dist, pixel_size_um, driver, ...).
    std::string cameraKeys{};
    CameraMount mount = CameraMount::Side;
    double distanceMm = 300.0;
    hg::geometry::FixtureType fixtureType = hg::geometry::FixtureType::RotationDeclination;
    hg::geometry::Range rotationRangeDeg{-180.0, 180.0};
    hg::geometry::Range declinationRangeDeg{0.0, 60.0};
    /// A rail fixture moves along part x within this range.
    hg::geometry::Range railRangeMm{-100.0, 100.0};
    /// Further fixture keys, YAML lines indented by two spaces (driver, ...).
    std::string fixtureKeys{};
    /// environment.floor_z_mm, written only when given.
    std::optional<double> floorZMm{};
    /// Further top-level sections appended to the file (lamps, plc, segmentation, ...).
    std::string sections{};
};

/// The text of the station file.
std::string stationYaml(const StationOptions& options = {});
/// The station that text describes, parsed as loadStation parses a file ("station.yaml").
hg::geometry::Station station(const StationOptions& options = {});

/// The 1-based line of the first line of `text` containing `key`; throws
/// std::invalid_argument when no line does.
int lineOf(const std::string& text, const std::string& key);
/// `text` with the first `from` replaced by `to`; throws std::invalid_argument
/// when `text` has no `from`.
std::string replaced(std::string text, const std::string& from, const std::string& to);

} // namespace hgtest
