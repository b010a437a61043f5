// The backend-independent part of the camera driver: frames, the lifecycle
// bookkeeping around the backends' hooks, and parsing of `camera.driver`.
#include "hullgauge/drivers/camera.h"

#include <array>

#include <opencv2/core.hpp>

#include "aravis/aravis_camera.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/log.h"
#include "v4l2/v4l2_camera.h"

namespace hg::drivers {

namespace {
constexpr std::array<std::string_view, 3> kPixelFormatNames{"Mono8", "Mono12", "Mono16"};
}

std::string_view toString(PixelFormat f)
{
    return kPixelFormatNames[static_cast<int>(f)];
}

std::string_view toString(TriggerMode t)
{
    return t == TriggerMode::Software ? "software" : "free_run";
}

std::optional<PixelFormat> pixelFormatFromString(std::string_view name)
{
    for (std::size_t i = 0; i < kPixelFormatNames.size(); ++i)
        if (kPixelFormatNames[i] == name) return static_cast<PixelFormat>(i);
    return std::nullopt;
}

int cvTypeOf(PixelFormat f)
{
    return f == PixelFormat::Mono8 ? CV_8UC1 : CV_16UC1;
}

std::string_view toString(FrameStatus s)
{
    constexpr std::array<std::string_view, 4> names{"ok", "timeout", "incomplete", "error"};
    return names[static_cast<int>(s)];
}

// ---------------------------------------------------------------------------
// Frame

Frame::Frame(Frame&& other) noexcept
    : status(other.status), image(std::move(other.image)), frameId(other.frameId), timestamp(other.timestamp),
      message(std::move(other.message)), recycle_(std::move(other.recycle_))
{
    other.recycle_ = nullptr;
    other.image = cv::Mat();
}

Frame& Frame::operator=(Frame&& other) noexcept
{
    if (this != &other) {
        release();
        status = other.status;
        image = std::move(other.image);
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

Camera::Camera(std::string configPath, CameraSettings settings)
    : configPath_(std::move(configPath)), settings_(std::move(settings))
{
}

Status Camera::transition(Transition t, const std::function<Status()>& hook)
{
    if (!allowed(state_, t))
        return Status::failure("camera: cannot " +
                               std::string(t == Transition::Configure    ? "configure"
                                           : t == Transition::Activate   ? "activate"
                                           : t == Transition::Deactivate ? "deactivate"
                                                                         : "clean up") +
                               " while " + std::string(toString(state_)));
    Status s = hook();
    if (s.ok()) {
        state_ = nextState(state_, t);
    } else if (t != Transition::Cleanup) {
        // A failed open/start leaves the device in an unknown state: Failed, cleanup() to retry.
        state_ = nextState(state_, Transition::Error);
        log::category("camera")->error("{}", s.message());
    }
    return s;
}

Status Camera::configure()
{
    return transition(Transition::Configure, [this] { return doConfigure(); });
}
Status Camera::activate()
{
    return transition(Transition::Activate, [this] { return doActivate(); });
}
Status Camera::deactivate()
{
    return transition(Transition::Deactivate, [this] { return doDeactivate(); });
}

Status Camera::cleanup()
{
    Status s = transition(Transition::Cleanup, [this] { return doCleanup(); });
    // Closing never leaves a half-open device behind: the hook releases what it can.
    if (!s.ok() && (state_ == LifecycleState::Inactive || state_ == LifecycleState::Failed))
        state_ = LifecycleState::Unconfigured;
    return s;
}

Status Camera::setSettings(const CameraSettings& settings)
{
    switch (state_) {
    case LifecycleState::Unconfigured:
        settings_ = settings;
        return Status::success();
    case LifecycleState::Inactive: {
        Status s = doApplySettings(settings);
        if (s.ok()) settings_ = settings;
        return s;
    }
    default:
        return Status::failure("camera: settings can change only while not streaming (state " +
                               std::string(toString(state_)) + ")");
    }
}

Frame Camera::grab(std::chrono::milliseconds timeout)
{
    if (state_ != LifecycleState::Active)
        return Frame::failed(FrameStatus::Error,
                             "camera: grab needs an active camera (state " + std::string(toString(state_)) + ")");
    return doGrab(timeout);
}

namespace {
bool deviceOpen(LifecycleState s)
{
    return s == LifecycleState::Inactive || s == LifecycleState::Active;
}
std::string closedMessage(LifecycleState s)
{
    return "camera: the device is not open (state " + std::string(toString(s)) + "); configure it first";
}
} // namespace

Result<std::vector<FeatureInfo>> Camera::listFeatures()
{
    if (!deviceOpen(state_)) return Status::failure(closedMessage(state_));
    return doListFeatures();
}

Result<std::string> Camera::getFeature(const std::string& name)
{
    if (!deviceOpen(state_)) return Status::failure(closedMessage(state_));
    return doGetFeature(name);
}

Status Camera::setFeature(const std::string& name, const std::string& value)
{
    if (!deviceOpen(state_)) return Status::failure(closedMessage(state_));
    return doSetFeature(name, value);
}

Result<CameraInfo> Camera::info()
{
    if (!deviceOpen(state_)) return Status::failure(closedMessage(state_));
    return doInfo();
}

// ---------------------------------------------------------------------------
// Configuration

CameraSettings parseCameraSettings(const ConfigNode& driver)
{
    CameraSettings s;
    if (auto n = driver.optional("pixel_format")) {
        auto f = pixelFormatFromString(n->asString());
        if (!f) n->fail("unknown pixel format '" + n->asString() + "' (expected Mono8, Mono12 or Mono16)");
        s.pixelFormat = *f;
    }
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
    if (auto n = driver.optional("trigger")) {
        auto t = n->asString();
        if (t == "software")
            s.trigger = TriggerMode::Software;
        else if (t == "free_run")
            s.trigger = TriggerMode::FreeRun;
        else
            n->fail("unknown trigger '" + t + "' (expected software or free_run)");
    }
    return s;
}

std::unique_ptr<Camera> makeCamera(const ConfigNode& root)
{
    ConfigNode driver = root["camera"]["driver"];
    require(driver.isMap(), driver, "expected a map with at least 'backend'");
    ConfigNode backendNode = driver["backend"];
    std::string backend = backendNode.asString();
    if (backend == "aravis") return makeAravisCamera(driver);
    if (backend == "v4l2") return makeV4l2Camera(driver);
    if (backend == "sim")
        backendNode.fail("the sim backend renders the part at the fixture pose and is built with the station "
                         "(hg::drivers::makeSimCamera), not from the driver section alone");
    backendNode.fail("unknown camera backend '" + backend + "' (expected aravis, v4l2 or sim)");
}

} // namespace hg::drivers
