// The camera interface every backend implements (docs/style.md: one small interface
// per device kind, in domain types; no ArvCamera* or V4L2 handle crosses it).
//
// Lifecycle (lifecycle.h, docs/drivers.md): constructing a camera from
// `camera.driver` only parses and validates (throws hg::InputError naming the
// key); configure() opens the device and applies the settings; activate()
// starts streaming; grab() returns one frame; deactivate() stops streaming;
// cleanup() closes. Every call after construction returns an hg::Status (or a
// Frame) and never throws: the capture loop decides what a failure means.
//
// Frames are views of driver-owned buffers from a pool preallocated at
// activate() (no copy between the network/DMA buffer and the cv::Mat). A Frame
// holds its buffer until it is released or destroyed; holding more frames than
// `buffer_count` starves the pool and later grabs time out. A frame may outlive
// stop/cleanup/recovery safely: its buffer is then freed instead of requeued.
#pragma once

#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <iosfwd>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "hullgauge/common/config_node.h"
#include "hullgauge/common/format.h"
#include "hullgauge/drivers/lifecycle.h"
#include "hullgauge/geometry/fixture.h"
#include "hullgauge/model/mesh.h"

namespace hg::drivers {

/// Pixel formats of the station (PFNC names). Mono12 is delivered unpacked:
/// 12 significant bits in the low bits of a 16-bit word (CV_16UC1).
enum class PixelFormat { Mono8, Mono12, Mono16 };
constexpr auto nameTable(PixelFormat)
{
    using enum PixelFormat;
    return std::to_array<EnumName<PixelFormat>>({{Mono8, "Mono8"}, {Mono12, "Mono12"}, {Mono16, "Mono16"}});
}
enum class TriggerMode { Software, FreeRun };
constexpr auto nameTable(TriggerMode)
{
    using enum TriggerMode;
    return std::to_array<EnumName<TriggerMode>>({{Software, "software"}, {FreeRun, "free_run"}});
}

/// OpenCV element type of a frame in this format (CV_8UC1 or CV_16UC1).
int cvTypeOf(PixelFormat f);

/// Region of interest on the sensor in pixels; width/height 0 = the whole sensor.
struct Roi {
    int x = 0;
    int y = 0;
    int width = 0;
    int height = 0;
    bool isFullSensor() const { return width == 0 && height == 0; }
    bool operator==(const Roi&) const = default;
};

/// The region as fmt's "{}" writes it, for gtest's messages.
std::ostream& operator<<(std::ostream& out, const Roi& roi);

/// How a device lets one axis of its region be set: GenICam's OffsetX/Width
/// (OffsetY/Height) take Min + k * Inc, each between its Min and Max.
struct RegionAxisRules {
    int offsetMin = 0;
    int offsetInc = 1;
    int sizeMin = 1;
    int sizeInc = 1;
};
struct RegionRules {
    RegionAxisRules x;
    RegionAxisRules y;
};

/// The region a camera delivers when asked for `requested` (sensor pixels),
/// docs/camera.md "Regions per grab": Roi{} is `bounds` itself; otherwise the
/// request is clamped to `bounds` (the configured ROI, on the device's
/// increments) and rounded OUTWARD to the increments, so the answer always
/// contains the part of the request inside `bounds` and lies within `bounds`.
/// Where no such box exists on an axis, that axis takes the whole of `bounds`.
/// NotAllowed for a negative or half-empty size, or a request that does not
/// overlap `bounds` at all (the message names both boxes).
Result<Roi> alignRegion(const Roi& requested, const Roi& bounds, const RegionRules& rules);

/// What configure() applies to the device.
struct CameraSettings {
    PixelFormat pixelFormat = PixelFormat::Mono8;
    std::optional<double> exposureUs; ///< µs; unset = leave the device's value
    std::optional<double> gainDb;     ///< dB; unset = leave the device's value
    Roi roi;
    TriggerMode trigger = TriggerMode::Software;
};

enum class FrameStatus {
    Ok,         ///< complete image
    Timeout,    ///< no frame within the timeout (camera silent, unplugged, not triggered)
    Incomplete, ///< a frame arrived but with missing packets / wrong size; pixels unreliable
    Error,      ///< the driver could not grab (wrong state, device lost and not yet back)
};
constexpr auto nameTable(FrameStatus)
{
    using enum FrameStatus;
    return std::to_array<EnumName<FrameStatus>>(
        {{Ok, "ok"}, {Timeout, "timeout"}, {Incomplete, "incomplete"}, {Error, "error"}});
}

/// One grabbed frame. `image` is a view of the driver's buffer (no copy); the
/// buffer goes back to the pool on release() or destruction. Move-only.
class Frame {
  public:
    Frame() = default;
    Frame(Frame&& other) noexcept;
    Frame& operator=(Frame&& other) noexcept;
    Frame(const Frame&) = delete;
    Frame& operator=(const Frame&) = delete;
    ~Frame();

    /// A failed frame (no image) with the reason.
    static Frame failed(FrameStatus status, std::string message);
    /// A frame over a driver buffer; `recycle` gives the buffer back (called once).
    static Frame over(cv::Mat view, std::uint64_t frameId, std::chrono::nanoseconds timestamp, FrameStatus status,
                      std::function<void()> recycle, std::string message = {});

    FrameStatus status = FrameStatus::Error;
    /// CV_8UC1 (Mono8) or CV_16UC1 (Mono12/Mono16), of the region's size.
    cv::Mat image;
    /// Where `image` lies on the sensor (sensor pixels, never Roi{}): image
    /// pixel (u, v) is sensor pixel (region.x + u, region.y + v), so the
    /// full-sensor camera model applies after that shift (docs/camera.md).
    Roi region;
    /// Bytes of image payload the frame carried from the camera (GVSP data, V4L2 bytesused, the sim's image).
    std::size_t payloadBytes = 0;
    /// ms the camera took to apply the region change this frame is the first of; 0 when the region did not change.
    double regionChangeMs = 0.0;
    /// Camera frame counter (GVSP block id, V4L2 sequence, or the driver's own count).
    std::uint64_t frameId = 0;
    /// Camera timestamp (device clock, ns) where the device has one, else the host's monotonic clock.
    std::chrono::nanoseconds timestamp{0};
    /// Why the status is not Ok.
    std::string message;

    bool ok() const { return status == FrameStatus::Ok; }
    /// Gives the buffer back to the pool now; `image` becomes empty.
    void release();

  private:
    std::function<void()> recycle_;
};

/// Identity of an open camera, for logs and `hullgauge camera list`.
struct CameraInfo {
    std::string backend;
    std::string vendor;
    std::string model;
    std::string serial;
    std::string address; ///< IP address, device node or "sim"
    int sensorWidth = 0;
    int sensorHeight = 0;
};

/// One device feature as the maintenance tool shows it.
struct FeatureInfo {
    std::string name;
    std::string type;   ///< Integer, Float, Enumeration, Boolean, String, Command
    std::string value;  ///< current value as text (empty for commands and unreadable features)
    std::string access; ///< RO, WO, RW
};

/// The abstract camera: the lifecycle of Device around the backends' hooks,
/// and state checks around the cyclic and maintenance calls.
class Camera : public Device {
  public:
    const CameraSettings& settings() const { return settings_; }
    /// "camera.driver" section this camera was built from (for messages).
    const std::string& configPath() const { return configPath_; }

    /// Replaces the settings; applied to the device now when Inactive, at configure() when Unconfigured.
    /// Refused while Active (stop first: ROI and format change the payload).
    Status setSettings(const CameraSettings& settings);

    /// Active only. Software trigger: triggers one exposure and waits for it; free
    /// run: waits for the next frame. Never longer than `timeout`, also when the
    /// device is lost: backends recover in the background (see docs/camera.md).
    [[nodiscard]] Frame grab(std::chrono::milliseconds timeout);

    /// Active only. The region of the sensor the following grabs deliver
    /// (docs/camera.md "Regions per grab"): `requested` aligned by
    /// alignRegion() to the device's increments within the configured ROI;
    /// Roi{} returns to the configured ROI. Answers the region the frames will
    /// cover, or NotAllowed for a request alignRegion() refuses. A device that
    /// cannot set the region delivers whole frames (the configured ROI) from
    /// then on, after one warning; Frame::region always tells what a frame covers.
    /// The change may complete in the background (aravis): grab() waits for it.
    Result<Roi> setRegion(const Roi& requested);
    /// The configured ROI on the sensor: what a whole frame covers, the most
    /// any region holds (the daemon's frame pool is sized by it). Inactive or Active.
    Roi wholeRegion() const { return configuredRegion(); }

    /// Maintenance: device features by name (Inactive or Active).
    Result<std::vector<FeatureInfo>> listFeatures();
    Result<std::string> getFeature(const std::string& name);
    Status setFeature(const std::string& name, const std::string& value);
    Result<CameraInfo> info();

  protected:
    Camera(std::string configPath, CameraSettings settings, Clock& clock);

    // Lifecycle hooks (Device): onConfigure opens the device and applies
    // settings(); onActivate allocates the pool and starts streaming;
    // onDeactivate stops streaming; onCleanup closes the device.
    virtual Status doApplySettings(const CameraSettings& settings) = 0;
    virtual Frame doGrab(std::chrono::milliseconds timeout) = 0;
    /// `aligned` is already checked and aligned (never Roi{}); answers the region the frames will cover.
    virtual Result<Roi> doSetRegion(const Roi& aligned) = 0;
    /// The device's region rules and the configured ROI on the sensor, valid while Inactive or Active.
    virtual RegionRules regionRules() const = 0;
    virtual Roi configuredRegion() const = 0;

    /// From now until allowRegions(): whole frames (the configured ROI) only;
    /// logs `why` as a warning the first time only.
    void fallBackToWholeFrames(const std::string& why);
    bool wholeFramesOnly() const { return wholeFramesOnly_.load(); }
    /// A freshly configured device may set regions again.
    void allowRegions() { wholeFramesOnly_ = false; }
    virtual Result<std::vector<FeatureInfo>> doListFeatures() = 0;
    virtual Result<std::string> doGetFeature(const std::string& name) = 0;
    virtual Status doSetFeature(const std::string& name, const std::string& value) = 0;
    virtual Result<CameraInfo> doInfo() = 0;

  private:
    Status requireOpen(std::string_view call) const;

    std::string configPath_;
    CameraSettings settings_;
    std::atomic<bool> wholeFramesOnly_{false};
};

/// Parses the settings keys shared by every backend (pixel_format, exposure_us,
/// gain_db, roi, trigger) from a `camera.driver` map.
CameraSettings parseCameraSettings(const ConfigNode& driver);

struct SimulationControls;

/// The fixture's current pose, or std::nullopt while it is unknown (moving, faulted).
using PoseSource = std::function<std::optional<geometry::FixturePose>()>;

/// What a backend may need besides its configuration section. Only the
/// simulated camera uses it: it renders `parts` at the pose `poseSource`
/// reports, through the station calibration of the document.
struct CameraEnvironment {
    /// Where the fixture is; unset: the sim renders at the zero pose.
    PoseSource poseSource;
    /// Parts that can be under test, by name: "nominal" and defect variants (part frame, mm).
    std::vector<std::pair<std::string, model::TriangleMesh>> parts;
    /// Where the simulated camera publishes its controls (simulation.h); may be null.
    SimulationControls* simulation = nullptr;
};

/// Builds the camera named by `camera.driver.backend` from the backend table
/// (aravis | v4l2 | sim; docs/camera.md). `root` is the whole station
/// document; `clock` the one the driver times and waits on (docs/drivers.md).
/// Only parses and validates: throws hg::InputError naming the key (unknown
/// backend -> camera.driver.backend).
std::unique_ptr<Camera> makeCamera(const ConfigNode& root, CameraEnvironment environment = {},
                                   Clock& clock = Clock::steady());

} // namespace hg::drivers

/// A region as "[x, y, width, height]": fmt::format("region {}", roi).
template <> struct fmt::formatter<hg::drivers::Roi> : hg::ValueFormatter {
    fmt::format_context::iterator format(const hg::drivers::Roi& roi, fmt::format_context& ctx) const;
};
