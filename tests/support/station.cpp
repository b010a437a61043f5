#include "hgtest/station.h"

#include "hullgauge/common/config_node.h"
#include "hullgauge/common/format.h"

#include <stdexcept>

namespace hgtest {

namespace {

std::string pair(double a, double b)
{
    return "[" + hg::formatNumber(a) + ", " + hg::formatNumber(b) + "]";
}

std::string cameraSection(const StationOptions& o)
{
    const cv::Point2d c = o.principalPointPx.value_or(cv::Point2d(o.imageSize.width / 2.0, o.imageSize.height / 2.0));
    const std::string f = hg::formatNumber(o.focalPx);
    return "camera:\n  image_size: [" + std::to_string(o.imageSize.width) + ", " + std::to_string(o.imageSize.height) +
           "]\n  K: [[" + f + ", 0, " + hg::formatNumber(c.x) + "], [0, " + f + ", " + hg::formatNumber(c.y) +
           "], [0, 0, 1]]\n" + o.cameraKeys;
}

std::string fixtureSection(const StationOptions& o)
{
    const bool rail = o.fixtureType == hg::geometry::FixtureType::Rail;
    const char* rotation =
        o.mount == CameraMount::Side ? "[[1, 0, 0], [0, 0, -1], [0, 1, 0]]" : "[[1, 0, 0], [0, 1, 0], [0, 0, 1]]";
    std::string s = std::string("fixture:\n  type: ") + (rail ? "rail" : "rotation_declination") +
                    "\n  camera_from_fixture: {R: " + rotation + ", t: [0, 0, " + hg::formatNumber(o.distanceMm) +
                    "]}\n";
    if (rail)
        s += "  rail_axis: [1, 0, 0]\n  rail_range_mm: " + pair(o.railRangeMm.min, o.railRangeMm.max) + "\n";
    else
        s += "  rotation_axis: [0, 0, 1]\n  declination_axis: [1, 0, 0]\n  rotation_range_deg: " +
             pair(o.rotationRangeDeg.min, o.rotationRangeDeg.max) +
             "\n  declination_range_deg: " + pair(o.declinationRangeDeg.min, o.declinationRangeDeg.max) + "\n";
    return s + o.fixtureKeys;
}

} // namespace

std::string stationYaml(const StationOptions& o)
{
    std::string text = cameraSection(o) + fixtureSection(o);
    if (o.floorZMm) text += "environment:\n  floor_z_mm: " + hg::formatNumber(*o.floorZMm) + "\n";
    return text + o.sections;
}

hg::geometry::Station station(const StationOptions& o)
{
    return hg::geometry::parseStation(hg::ConfigNode::parse(stationYaml(o), "station.yaml"));
}

int lineOf(const std::string& text, const std::string& key)
{
    const auto at = text.find(key);
    if (at == std::string::npos) throw std::invalid_argument("no line holds '" + key + "'");
    int line = 1;
    for (std::size_t i = 0; i < at; ++i)
        if (text[i] == '\n') ++line;
    return line;
}

std::string replaced(std::string text, const std::string& from, const std::string& to)
{
    const auto at = text.find(from);
    if (at == std::string::npos) throw std::invalid_argument("the text holds no '" + from + "'");
    return text.replace(at, from.size(), to);
}

} // namespace hgtest
