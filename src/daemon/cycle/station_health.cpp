#include "cycle/station_health.h"

#include "hullgauge/calib/flat_field.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/log.h"
#include "hullgauge/store/result_reader.h"
#include "hullgauge/vision/segmentation.h"

#include <algorithm>
#include <cmath>
#include <spdlog/fmt/fmt.h>

namespace hg::daemon {
namespace {

using nlohmann::json;
using vision::HealthFigure;

json figureJson(double value)
{
    return std::isfinite(value) ? json(value) : json();
}

bool beyond(const HealthFigureRule& rule, const std::vector<HealthFigure>& warnings)
{
    return std::find(warnings.begin(), warnings.end(), rule.figure) != warnings.end();
}

} // namespace

const std::array<HealthFigureRule, 8>& healthFigureRules()
{
    using F = vision::HealthFigures;
    using L = vision::HealthLimits;
    // docs/health.md, "Figures" and "Limits": the backlight and the contrast
    // warn when they fall, the edge bias when it grows either way, the others when they grow.
    static const std::array<HealthFigureRule, 8> rules{{
        {HealthFigure::Backlight, "backlight", &F::backlight, &L::minBacklight, true, false, "backlight",
         "of the reference", 2},
        {HealthFigure::Uniformity, "uniformity", &F::uniformity, &L::maxUniformity, false, false, "uniformity",
         "worst departure of a block from the reference", 3},
        {HealthFigure::Dust, "dust_specks", &F::dustSpecks, &L::maxDustSpecks, false, false, "dust",
         "specks beyond the reference's", 0},
        {HealthFigure::Focus, "edge_width_px", &F::edgeWidthPx, &L::maxEdgeWidthPx, false, false, "focus: edge width",
         "px (10-90 %)", 2},
        {HealthFigure::Contrast, "contrast", &F::contrast, &L::minContrast, true, false, "contrast", "of full scale",
         2},
        {HealthFigure::Noise, "noise", &F::noise, &L::maxNoise, false, false, "noise", "of full scale", 4},
        {HealthFigure::EdgeBias, "edge_bias_px", &F::edgeBiasPx, &L::maxEdgeBiasPx, false, true, "edge bias",
         "px (silhouettes against the CAD outline)", 3},
        {HealthFigure::Capability, "capability", &F::capability, &L::maxCapability, false, false, "capability",
         "of the worst landmark's bound (4 U / zone)", 2},
    }};
    return rules;
}

std::string describeFigure(const HealthFigureRule& rule, const vision::HealthFigures& figures,
                           const vision::HealthLimits& limits)
{
    const double value = figures.*rule.value;
    if (!std::isfinite(value)) return std::string(rule.what) + " not measured";
    const double limit = limits.*rule.limit;
    if (rule.magnitude)
        return fmt::format("{} {:+.{}f} {} — {} limit ±{:.{}f}", rule.what, value, rule.digits, rule.unit,
                           std::abs(value) > limit ? "beyond" : "within", limit, rule.digits);
    const bool outside = rule.minimum ? value < limit : value > limit;
    return fmt::format("{} {:.{}f} {} — {} limit {:.{}f}", rule.what, value, rule.digits, rule.unit,
                       !outside       ? "within"
                       : rule.minimum ? "below"
                                      : "above",
                       limit, rule.digits);
}

json healthFiguresJson(const vision::HealthFigures& figures)
{
    json j;
    for (const auto& rule : healthFigureRules()) j[rule.key] = figureJson(figures.*rule.value);
    j["predicted_sigma_px"] = figureJson(figures.predictedSigmaPx);
    j["views"] = figures.views;
    j["probes"] = figures.probes;
    return j;
}

json healthWarningsJson(const std::vector<HealthFigure>& warnings)
{
    json j = json::array();
    for (const auto w : warnings) j.push_back(std::string(enumName(w)));
    return j;
}

json healthStatesJson(const vision::HealthFigures& figures, const vision::HealthLimits& limits)
{
    json states = json::array();
    const auto warnings = vision::healthWarnings(figures, limits);
    for (const auto& rule : healthFigureRules()) {
        const double value = figures.*rule.value;
        states.push_back({{"figure", std::string(enumName(rule.figure))},
                          {"key", rule.key},
                          {"value", figureJson(value)},
                          {"limit", limits.*rule.limit},
                          {"minimum", rule.minimum},
                          {"magnitude", rule.magnitude},
                          {"within", std::isfinite(value) ? json(!beyond(rule, warnings)) : json()},
                          {"sentence", describeFigure(rule, figures, limits)}});
    }
    return states;
}

json referenceJson(const std::optional<vision::FlatField>& reference, const std::filesystem::path& file)
{
    if (!reference || reference->empty()) return nullptr;
    return {{"taken_unix_ms", reference->takenUnixMs},
            {"time", store::formatUtc(reference->takenUnixMs)},
            {"file", file.string()},
            {"sensor", {reference->sensor.width, reference->sensor.height}},
            {"level_mean", cv::mean(reference->level)[0]},
            {"noise", reference->noise},
            {"dust_specks", reference->dustSpecks}};
}

void HealthJournal::report(const station::HealthRecord& health, const vision::HealthLimits& limits)
{
    auto log = hg::log::category("health");
    for (const auto& rule : healthFigureRules()) {
        const bool now = beyond(rule, health.warnings);
        const bool before = beyond_.count(rule.figure) > 0;
        // A figure this cycle could not measure leaves its state as it was.
        if (!std::isfinite(health.figures.*rule.value) || now == before) continue;
        if (now) {
            log->warn("station health: {}", describeFigure(rule, health.figures, limits));
            beyond_.insert(rule.figure);
        } else {
            log->info("station health: {}: back within its limit", describeFigure(rule, health.figures, limits));
            beyond_.erase(rule.figure);
        }
    }
}

Status FlatFieldAction::request(FlatFieldJob job, station::SequencerState state)
{
    if (job.frames < 1 || job.frames > 64)
        return Status::failure(StatusCode::NotAllowed, "frames: " + std::to_string(job.frames) + " is outside 1..64");
    return queue_.request(job, state, {{"frames", job.frames}});
}

FlatFieldAction::Taken FlatFieldAction::run(const FlatFieldJob& job, StationDevices& devices,
                                            const station::DaemonConfig& cfg, Clock& clock,
                                            const Simulation& simulation, const std::function<bool()>& cancelled)
{
    auto log = hg::log::category("health");
    Taken taken;
    taken.file = cfg.health.reference;
    queue_.update({{"state", "running"}, {"grabbed", 0}});
    // The simulated line empties its nest for the grab; on a real station the operator has.
    const bool simulated = simulation.showEmpty && simulation.showEmpty();
    if (simulation.showEmpty && !simulated)
        log->warn("flat-field: the simulated camera cannot show an empty fixture (sim-part none): it shows its part");
    // Whole frames: the reference covers the sensor, whatever region the last cycle left set.
    if (auto r = devices.setRegion({}); !r.ok()) log->warn("flat-field: whole frames asked: {}", r.message());
    std::vector<cv::Mat> frames;
    for (int k = 0; k < job.frames && taken.error.empty(); ++k) {
        if (cancelled()) {
            taken.error = "aborted after " + std::to_string(k) + " of " + std::to_string(job.frames) + " frames";
            break;
        }
        GrabbedFrame grabbed;
        if (auto r = devices.grab(cfg.sequencer.grabTimeout, grabbed); !r.ok()) {
            taken.error = "camera: " + r.message();
            taken.deviceFailed = true;
            break;
        }
        frames.push_back(vision::toGrey(grabbed.image).clone());
        queue_.update({{"grabbed", k + 1}});
    }
    if (simulated) simulation.restore();
    if (!taken.error.empty()) return taken;
    try {
        taken.reference = vision::buildFlatField(frames, clock.wallMs());
    } catch (const std::exception& e) {
        // Something in the fixture, a frame of another size: the reason names it (docs/health.md).
        taken.error = std::string("the reference was refused: ") + e.what();
        return taken;
    }
    try {
        calib::writeFlatField(taken.file, *taken.reference);
    } catch (const std::exception& e) {
        taken.reference.reset();
        taken.error = e.what();
    }
    return taken;
}

void FlatFieldAction::finish(const Taken& taken)
{
    auto log = hg::log::category("health");
    if (!taken.reference) {
        queue_.update({{"state", "failed"}, {"error", taken.error}});
        log->warn("flat-field reference not taken: {}", taken.error);
        return;
    }
    const json reference = referenceJson(taken.reference, taken.file);
    queue_.update({{"state", "done"}, {"file", taken.file.string()}, {"reference", reference}});
    log->info("flat-field reference taken ({} x {}, mean level {:.3f} of full scale, noise {:.4f}, {} specks) and "
              "written to {}; the station's health is judged against it from the next cycle",
              taken.reference->sensor.width, taken.reference->sensor.height, reference["level_mean"].get<double>(),
              taken.reference->noise, taken.reference->dustSpecks, taken.file.string());
}

} // namespace hg::daemon
