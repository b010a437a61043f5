// The backend-independent part of the camera driver: frames, the lifecycle
// bookkeeping around the backends' hooks, and parsing of `camera.driver`.
#include "hullgauge/drivers/camera.h"

#include <algorithm>
#include <array>
#include <ostream>

#include <opencv2/core.hpp>

#include "../backend_table.h"
#include "aravis/aravis_camera.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/log.h"
#include "sim/sim_camera.h"
#include "v4l2/v4l2_camera.h"

namespace hg::drivers {

int cvTypeOf(PixelFormat f)
{
    return f == PixelFormat::Mono8 ? CV_8UC1 : CV_16UC1;
}

// ---------------------------------------------------------------------------
// Regions

std::ostream& operator<<(std::ostream& out, const Roi& roi)
{
    return out << fmt::format("{}", roi);
}

namespace {

/// Largest `min + k * inc` <= v (any sign).
int floorToStep(int v, int min, int inc)
{
    const int k = (v - min) >= 0 ? (v - min) / inc : -((min - v + inc - 1) / inc);
    return min + k * inc;
}

/// Smallest `min + k * inc` >= v, k >= 0.
int ceilToStep(int v, int min, int inc)
{
    return v <= min ? min : min + (v - min + inc - 1) / inc * inc;
}

/// One axis of alignRegion: [a, b) inside [lo, hi) grown to the device's
/// steps; [lo, hi) itself when no aligned span inside it contains [a, b).
std::pair<int, int> alignAxis(int a, int b, int lo, int hi, const RegionAxisRules& r)
{
    const int offsetInc = std::max(1, r.offsetInc);
    int offset = floorToStep(a, r.offsetMin, offsetInc);
    const int size = ceilToStep(b - offset, std::max(1, r.sizeMin), std::max(1, r.sizeInc));
    if (offset + size > hi) offset -= (offset + size - hi + offsetInc - 1) / offsetInc * offsetInc;
    if (offset < lo || offset + size > hi || offset + size < b) return {lo, hi - lo};
    return {offset, size};
}

} // namespace

Result<Roi> alignRegion(const Roi& requested, const Roi& bounds, const RegionRules& rules)
{
    if (requested.isFullSensor()) return bounds;
    if (requested.width <= 0 || requested.height <= 0)
        return Status::failure(StatusCode::NotAllowed, fmt::format("region {}: width and height must both be positive "
                                                                   "(or both 0 for the configured region)",
                                                                   requested));
    const int x0 = std::max(requested.x, bounds.x);
    const int y0 = std::max(requested.y, bounds.y);
    const int x1 = std::min(requested.x + requested.width, bounds.x + bounds.width);
    const int y1 = std::min(requested.y + requested.height, bounds.y + bounds.height);
    if (x0 >= x1 || y0 >= y1)
        return Status::failure(
            StatusCode::NotAllowed,
            fmt::format("region {} lies outside the sensor region {} the camera delivers", requested, bounds));
    const auto [x, width] = alignAxis(x0, x1, bounds.x, bounds.x + bounds.width, rules.x);
    const auto [y, height] = alignAxis(y0, y1, bounds.y, bounds.y + bounds.height, rules.y);
    return Roi{x, y, width, height};
}

// ---------------------------------------------------------------------------
// Frame

Frame::Frame(Frame&& other) noexcept
{
    *this = std::move(other);
}

Frame& Frame::operator=(Frame&& other) noexcept
{
    if (this != &other) {
        release();
        status = other.status;
        image = std::move(other.image);
        region = other.region;
        payloadBytes = other.payloadBytes;
        regionChangeMs = other.regionChangeMs;
        frameId = other.frameId;
        timestamp = other.timestamp;
        message = std::move(other.message);
        recycle_ = std::move(other.recycle_);
        other.recycle_ = nullptr;
        other.image = cv::Mat();
    }
    return *this;
}

Frame::~Frame()
{
    release();
}

void Frame::release()
{
    // The view must die before its buffer goes back to the pool.
    image = cv::Mat();
    if (recycle_) {
        auto recycle = std::move(recycle_);
        recycle_ = nullptr;
        recycle();
    }
}

Frame Frame::failed(FrameStatus status, std::string message)
{
    Frame f;
    f.status = status;
    f.message = std::move(message);
    return f;
}

Frame Frame::over(cv::Mat view, std::uint64_t frameId, std::chrono::nanoseconds timestamp, FrameStatus status,
                  std::function<void()> recycle, std::string message)
{
    Frame f;
    f.status = status;
    f.image = std::move(view);
    f.frameId = frameId;
    f.timestamp = timestamp;
    f.recycle_ = std::move(recycle);
    f.message = std::move(message);
    return f;
}

// ---------------------------------------------------------------------------
// Camera: state checks around the hooks (libcamera's isAccessAllowed pattern).

Camera::Camera(std::string configPath, CameraSettings settings, Clock& clock)
    : Device("camera", clock), configPath_(std::move(configPath)), settings_(std::move(settings))
{
}

Status Camera::setSettings(const CameraSettings& settings)
{
    std::lock_guard lock(mutex());
    if (auto s = require({LifecycleState::Unconfigured, LifecycleState::Inactive}, "changing settings"); !s) return s;
    if (state() == LifecycleState::Inactive)
        if (Status s = doApplySettings(settings); !s) return s;
    settings_ = settings;
    return Status::success();
}

Frame Camera::grab(std::chrono::milliseconds timeout)
{
    if (auto s = require({LifecycleState::Active}, "grab"); !s) return Frame::failed(FrameStatus::Error, s.message());
    return doGrab(timeout);
}

Result<Roi> Camera::setRegion(const Roi& requested)
{
    std::lock_guard lock(mutex());
    if (auto s = require({LifecycleState::Active}, "setting the region"); !s) return s;
    const Roi bounds = configuredRegion();
    auto aligned = alignRegion(requested, bounds, regionRules());
    if (!aligned) return aligned.status().prefixed(kind() + ": ");
    if (wholeFramesOnly()) return bounds;
    return doSetRegion(aligned.value());
}

void Camera::fallBackToWholeFrames(const std::string& why)
{
    if (!wholeFramesOnly_.exchange(true))
        log::category("camera")->warn("{}; delivering whole frames ({}) from now on", why, configuredRegion());
}

Status Camera::requireOpen(std::string_view call) const
{
    return require({LifecycleState::Inactive, LifecycleState::Active}, call);
}

Result<std::vector<FeatureInfo>> Camera::listFeatures()
{
    if (auto s = requireOpen("listing features"); !s) return s;
    return doListFeatures();
}

Result<std::string> Camera::getFeature(const std::string& name)
{
    if (auto s = requireOpen("reading " + name); !s) return s;
    return doGetFeature(name);
}

Status Camera::setFeature(const std::string& name, const std::string& value)
{
    if (auto s = requireOpen("setting " + name); !s) return s;
    return doSetFeature(name, value);
}

Result<CameraInfo> Camera::info()
{
    if (auto s = requireOpen("info"); !s) return s;
    return doInfo();
}

// ---------------------------------------------------------------------------
// Configuration

CameraSettings parseCameraSettings(const ConfigNode& driver)
{
    CameraSettings s;
    if (auto n = driver.optional("pixel_format")) s.pixelFormat = n->asEnum<PixelFormat>("pixel format");
    if (auto n = driver.optional("exposure_us")) s.exposureUs = n->asDoubleIn(1.0, 60e6);
    if (auto n = driver.optional("gain_db")) s.gainDb = n->asDoubleIn(-20.0, 60.0);
    if (auto n = driver.optional("roi")) {
        auto v = n->asDoubles(4);
        for (double x : v)
            if (x < 0 || x != static_cast<double>(static_cast<int>(x)))
                n->fail("expected [x, y, width, height] as non-negative whole pixels");
        s.roi = Roi{static_cast<int>(v[0]), static_cast<int>(v[1]), static_cast<int>(v[2]), static_cast<int>(v[3])};
        if ((s.roi.width == 0) != (s.roi.height == 0))
            n->fail("width and height must both be positive, or both 0 for the whole sensor");
    }
    if (auto n = driver.optional("trigger")) s.trigger = n->asEnum<TriggerMode>("trigger");
    return s;
}

using CameraFactory = std::unique_ptr<Camera> (*)(const ConfigNode& root, CameraEnvironment& environment, Clock& clock);

/// The camera backends (docs/camera.md); the simulated twin is always built.
constexpr Backend<CameraFactory> kCameraBackends[] = {
    {"aravis", [](const ConfigNode& root, CameraEnvironment&,
                  Clock& clock) { return makeAravisCamera(root["camera"]["driver"], clock); }},
    {"v4l2", [](const ConfigNode& root, CameraEnvironment&,
                Clock& clock) { return makeV4l2Camera(root["camera"]["driver"], clock); }},
    {"sim", makeSimCamera},
};

std::unique_ptr<Camera> makeCamera(const ConfigNode& root, CameraEnvironment environment, Clock& clock)
{
    ConfigNode driver = root["camera"]["driver"];
    require(driver.isMap(), driver, "expected a map with at least 'backend'");
    return chooseBackend(kCameraBackends, driver["backend"], "camera")(root, environment, clock);
}

} // namespace hg::drivers

fmt::format_context::iterator fmt::formatter<hg::drivers::Roi>::format(const hg::drivers::Roi& roi,
                                                                       fmt::format_context& ctx) const
{
    return fmt::format_to(ctx.out(), "[{}, {}, {}, {}]", roi.x, roi.y, roi.width, roi.height);
}
