// The flat-field reference's file (docs/health.md, "Reference file").
#include "hullgauge/calib/flat_field.h"

#include "hullgauge/common/durable_file.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/json.h"
#include "hullgauge/common/log.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>

namespace hg::calib {
namespace {

using nlohmann::json;

constexpr const char* kFormat = "hullgauge flat field";
constexpr int kVersion = 1;

cv::Size blocksOf(cv::Size sensor, int cell)
{
    return {(sensor.width + cell - 1) / cell, (sensor.height + cell - 1) / cell};
}

std::string sizeText(cv::Size s)
{
    return "[" + std::to_string(s.width) + ", " + std::to_string(s.height) + "]";
}

// Reads the document's fields, naming the file and the field in every refusal.
class FieldReader {
  public:
    FieldReader(std::string file, const json& document) : file_(std::move(file)), document_(document) {}

    [[noreturn]] void fail(const std::string& field, const std::string& problem) const
    {
        throw InputError(file_, field, problem);
    }

    const json& at(const std::string& key) const
    {
        if (!document_.contains(key)) fail(key, "missing");
        return document_[key];
    }

    double number(const json& j, const std::string& field, double lowest, double highest) const
    {
        if (!j.is_number()) fail(field, "expected a number, found " + j.dump());
        const double v = j.get<double>();
        if (!(v >= lowest && v <= highest))
            fail(field, j.dump() + " is outside [" + json(lowest).dump() + ", " + json(highest).dump() + "]");
        return v;
    }

    long long integer(const json& j, const std::string& field, long long lowest, long long highest) const
    {
        if (!j.is_number_integer()) fail(field, "expected a whole number, found " + j.dump());
        const long long v = j.get<long long>();
        if (v < lowest || v > highest)
            fail(field, j.dump() + " is outside [" + std::to_string(lowest) + ", " + std::to_string(highest) + "]");
        return v;
    }

    cv::Size size(const std::string& key) const
    {
        const json& j = at(key);
        if (!j.is_array() || j.size() != 2) fail(key, "expected [width, height], found " + j.dump());
        return {static_cast<int>(integer(j[0], key + "[0]", 1, 1'000'000)),
                static_cast<int>(integer(j[1], key + "[1]", 1, 1'000'000))};
    }

    const json& array(const std::string& key) const
    {
        const json& j = at(key);
        if (!j.is_array()) fail(key, "expected an array");
        return j;
    }

  private:
    std::string file_;
    const json& document_;
};

vision::FlatField fromJson(const std::string& name, const json& document)
{
    const FieldReader read(name, document);
    if (!document.is_object()) read.fail("", "expected a JSON object");
    const json& format = read.at("format");
    if (format != kFormat) read.fail("format", "expected \"" + std::string(kFormat) + "\", found " + format.dump());
    const long long version = read.integer(read.at("version"), "version", 1, 1'000'000);
    if (version != kVersion)
        read.fail("version",
                  std::to_string(version) + " is not known (this build reads " + std::to_string(kVersion) + ")");
    vision::FlatField out;
    out.sensor = read.size("sensor");
    out.cell =
        static_cast<int>(read.integer(read.at("cell"), "cell", 1, std::min(out.sensor.width, out.sensor.height)));
    const cv::Size blocks = read.size("blocks"), expected = blocksOf(out.sensor, out.cell);
    if (blocks != expected)
        read.fail("blocks", sizeText(blocks) + " does not fit the sensor " + sizeText(out.sensor) + " in cells of " +
                                std::to_string(out.cell) + " px: expected " + sizeText(expected));
    const json& level = read.array("level");
    if (level.size() != static_cast<std::size_t>(blocks.area()))
        read.fail("level", "expected " + std::to_string(blocks.area()) + " numbers (the blocks' rows one after the " +
                               "other), found " + std::to_string(level.size()));
    out.level.create(blocks.height, blocks.width, CV_32FC1);
    for (std::size_t i = 0; i < level.size(); ++i) {
        // A level is a fraction of full scale; 0 would make every ratio to it infinite.
        const double v = read.number(level[i], "level[" + std::to_string(i) + "]", 1e-6, 1.0);
        out.level.at<float>(static_cast<int>(i) / blocks.width, static_cast<int>(i) % blocks.width) =
            static_cast<float>(v);
    }
    out.noise = read.number(read.at("noise"), "noise", 0.0, 1.0);
    const json& specks = read.array("dust_specks");
    for (std::size_t i = 0; i < specks.size(); ++i) {
        const std::string field = "dust_specks[" + std::to_string(i) + "]";
        if (!specks[i].is_array() || specks[i].size() != 2) read.fail(field, "expected [x, y] in sensor pixels");
        const double x = read.number(specks[i][0], field + "[0]", 0.0, out.sensor.width - 1.0);
        const double y = read.number(specks[i][1], field + "[1]", 0.0, out.sensor.height - 1.0);
        out.dustAt.emplace_back(static_cast<float>(x), static_cast<float>(y));
    }
    out.dustSpecks = static_cast<int>(out.dustAt.size());
    out.takenUnixMs = read.integer(read.at("taken_unix_ms"), "taken_unix_ms", 0, 1LL << 53);
    for (const auto& [key, value] : document.items())
        if (!std::set<std::string>{"format", "version", "sensor", "cell", "blocks", "level", "noise", "dust_specks",
                                   "taken_unix_ms"}
                 .contains(key))
            log::category("calib")->warn("{}: {}: unknown key, ignored", name, key);
    return out;
}

} // namespace

void writeFlatField(const std::filesystem::path& file, const vision::FlatField& reference)
{
    const cv::Size blocks = reference.cell >= 1 ? blocksOf(reference.sensor, reference.cell) : cv::Size();
    if (reference.empty() || reference.level.type() != CV_32FC1 || reference.level.size() != blocks)
        throw ArgumentError("writeFlatField: the reference's level must be CV_32FC1 of ceil(sensor / cell) blocks");
    nlohmann::ordered_json level = nlohmann::ordered_json::array();
    for (int by = 0; by < blocks.height; ++by)
        for (int bx = 0; bx < blocks.width; ++bx)
            level.push_back(static_cast<double>(reference.level.at<float>(by, bx)));
    nlohmann::ordered_json specks = nlohmann::ordered_json::array();
    for (const cv::Point2f& p : reference.dustAt)
        specks.push_back({static_cast<double>(p.x), static_cast<double>(p.y)});
    // The keys in the documented order (docs/health.md), for a person reading the file.
    const nlohmann::ordered_json document = {{"format", kFormat},
                                             {"version", kVersion},
                                             {"sensor", {reference.sensor.width, reference.sensor.height}},
                                             {"cell", reference.cell},
                                             {"blocks", {blocks.width, blocks.height}},
                                             {"level", level},
                                             {"noise", reference.noise},
                                             {"dust_specks", specks},
                                             {"taken_unix_ms", reference.takenUnixMs}};
    replaceFileDurably(file, document.dump(1) + "\n");
}

vision::FlatField readFlatField(const std::filesystem::path& file)
{
    const std::string name = file.string();
    std::ifstream in(file, std::ios::binary);
    if (!in) throw InputError(name, "", "cannot open file");
    std::ostringstream text;
    text << in.rdbuf();
    if (in.bad()) throw InputError(name, "", "cannot read file");
    return fromJson(name, parseJson(text.str(), name));
}

} // namespace hg::calib
