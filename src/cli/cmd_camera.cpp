// hullgauge camera list|get|set|grab — maintenance access to the camera named
// by the station's camera.driver section, from the camera backend table
// (GigE Vision through Aravis, V4L2, or the simulated twin; docs/camera.md). Results go to stdout as JSON; progress and
// errors to stderr. Exit status: 0 done, 2 bad station file or arguments,
// 3 camera fault (unreachable, refused value, no frame) (docs/contracts.md §5).
#include <chrono>
#include <iostream>
#include <memory>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "command.h"
#include "hullgauge/common/config_node.h"
#include "hullgauge/common/error.h"
#include "hullgauge/drivers/camera.h"

namespace hg::cli {
namespace {

struct CameraArgs {
    std::string station;
    std::vector<std::string> names;       // get
    std::vector<std::string> assignments; // set NAME=VALUE
    std::string out;                      // grab
    double timeoutS = 5.0;
};

/// Builds and opens the camera; configuration errors are InputError (exit 2),
/// an unreachable or refusing device is FaultError (exit 3).
std::unique_ptr<drivers::Camera> openCamera(const std::string& station)
{
    auto camera = drivers::makeCamera(ConfigNode::loadFile(station));
    if (auto s = camera->configure(); !s) throw FaultError(s.message());
    return camera;
}

nlohmann::json infoJson(drivers::Camera& camera)
{
    auto info = camera.info();
    if (!info) throw FaultError(info.message());
    const auto& i = info.value();
    return {{"backend", i.backend}, {"vendor", i.vendor},   {"model", i.model},
            {"serial", i.serial},   {"address", i.address}, {"sensor_size", {i.sensorWidth, i.sensorHeight}}};
}

int runList(const CameraArgs& a)
{
    auto camera = openCamera(a.station);
    auto features = camera->listFeatures();
    if (!features) throw FaultError(features.message());
    nlohmann::json j;
    j["camera"] = infoJson(*camera);
    j["features"] = nlohmann::json::array();
    for (const auto& f : features.value())
        j["features"].push_back({{"name", f.name}, {"type", f.type}, {"access", f.access}, {"value", f.value}});
    std::cout << j.dump(2) << '\n';
    (void)camera->cleanup();
    return 0;
}

int runGet(const CameraArgs& a)
{
    auto camera = openCamera(a.station);
    nlohmann::json j = nlohmann::json::object();
    for (const auto& name : a.names) {
        auto v = camera->getFeature(name);
        if (!v) throw FaultError(v.message());
        j[name] = v.value();
    }
    std::cout << j.dump(2) << '\n';
    (void)camera->cleanup();
    return 0;
}

int runSet(const CameraArgs& a)
{
    std::vector<std::pair<std::string, std::string>> pairs;
    for (const auto& s : a.assignments) {
        auto eq = s.find('=');
        if (eq == std::string::npos || eq == 0) throw InputError("", s, "expected NAME=VALUE");
        pairs.emplace_back(s.substr(0, eq), s.substr(eq + 1));
    }
    auto camera = openCamera(a.station);
    nlohmann::json j = nlohmann::json::object();
    for (const auto& [name, value] : pairs) {
        if (auto s = camera->setFeature(name, value); !s) throw FaultError(s.message());
        // Report what the device holds now (it may round).
        auto v = camera->getFeature(name);
        j[name] = v ? v.value() : std::string();
    }
    std::cout << j.dump(2) << '\n';
    (void)camera->cleanup();
    return 0;
}

int runGrab(const CameraArgs& a)
{
    auto camera = openCamera(a.station);
    if (auto s = camera->activate(); !s) throw FaultError(s.message());
    const auto timeout = std::chrono::milliseconds(static_cast<long>(a.timeoutS * 1000.0));
    auto frame = camera->grab(timeout);
    if (!frame.ok())
        throw FaultError("no usable frame (" + std::string(enumName(frame.status)) + "): " + frame.message);
    // PNG keeps 16-bit frames (Mono12/Mono16) at full depth.
    if (!cv::imwrite(a.out, frame.image)) throw FaultError(a.out + ": cannot write the image");
    nlohmann::json j{{"out", a.out},
                     {"frame_id", frame.frameId},
                     {"timestamp_ns", frame.timestamp.count()},
                     {"width", frame.image.cols},
                     {"height", frame.image.rows},
                     {"pixel_format", std::string(enumName(camera->settings().pixelFormat))}};
    frame.release();
    (void)camera->deactivate();
    (void)camera->cleanup();
    std::cout << j.dump(2) << '\n';
    return 0;
}

std::function<int()> addCamera(CLI::App& app)
{
    auto args = std::make_shared<CameraArgs>();
    auto* cmd = app.add_subcommand("camera", "camera maintenance: list features, get/set features, grab a frame");
    cmd->require_subcommand(1);
    auto stationOption = [&](CLI::App* sub) {
        sub->add_option("--station", args->station, "station YAML with a camera.driver section")
            ->required()
            ->check(CLI::ExistingFile);
    };
    auto* list = cmd->add_subcommand("list", "camera identity and all features with their values (JSON)");
    stationOption(list);
    auto* get = cmd->add_subcommand("get", "read features by name (JSON)");
    stationOption(get);
    get->add_option("names", args->names, "feature names (GenICam names, or V4L2 control names)")->required();
    auto* set = cmd->add_subcommand("set", "write features by name; prints the values the device holds after");
    stationOption(set);
    set->add_option("assignments", args->assignments, "NAME=VALUE ...")->required();
    auto* grab = cmd->add_subcommand("grab", "grab one frame with the station's camera settings and save it");
    stationOption(grab);
    grab->add_option("--out", args->out, "output image (PNG keeps 16-bit frames)")->required();
    grab->add_option("--timeout", args->timeoutS, "seconds to wait for the frame")->check(CLI::Range(0.01, 600.0));

    return [args, list, get, set, grab]() -> int {
        if (list->parsed()) return runList(*args);
        if (get->parsed()) return runGet(*args);
        if (set->parsed()) return runSet(*args);
        if (grab->parsed()) return runGrab(*args);
        return static_cast<int>(ExitStatus::BadInput);
    };
}

} // namespace

HG_REGISTER_COMMAND("camera", addCamera);

} // namespace hg::cli
