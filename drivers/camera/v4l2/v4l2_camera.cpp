// V4L2 backend: memory-mapped streaming (VIDIOC_REQBUFS/QBUF/DQBUF), format
// negotiation (GREY, Y12, Y16 viewed in place; YUYV converted to grey), poll()
// timeouts, V4L2 controls as features by name.
//
// V4L2 devices stream continuously; both trigger modes deliver the first frame
// completed after grab() was called (frames already queued are stale and are
// requeued). Exposure maps to V4L2_CID_EXPOSURE_ABSOLUTE (100 µs units); V4L2
// gain has no unit, so gain_db is refused and the raw control is set by name
// under `features`; a control value outside the control's range is refused
// (the kernel would clamp it silently). `device_format` pins the device format.
// Regions per grab crop with VIDIOC_S_SELECTION with the stream stopped, into
// the buffers of the configured ROI (docs/camera.md "Regions per grab").
#include "v4l2_camera.h"

#include <fcntl.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <mutex>
#include <sstream>
#include <utility>

#include <linux/videodev2.h>
#include <opencv2/core.hpp>

#include "hullgauge/common/log.h"
#include "v4l2_formats.h"

namespace hg::drivers {
namespace {

using std::chrono::milliseconds;

std::string errnoText(int e)
{
    return std::strerror(e);
}

/// ioctl that retries on EINTR.
int xioctl(int fd, unsigned long request, void* arg)
{
    int r;
    do {
        r = ::ioctl(fd, request, arg);
    } while (r == -1 && errno == EINTR);
    return r;
}

struct V4l2Config {
    std::string device;
    int bufferCount = 4;
    /// `device_format`: the device format pinned by the station, instead of
    /// the best one negotiated for the pixel format (std::nullopt).
    std::optional<std::uint32_t> deviceFormat;
    std::vector<std::pair<std::string, std::string>> features;
};

/// The mapped buffers of one streaming session. Outstanding frames share it,
/// so the mappings outlive a stop; requeueing happens only while its session
/// is streaming.
struct MappedPool {
    /// Where a buffer is: with the driver, viewed by a Frame, or with us (after STREAMOFF).
    enum class Where { Queued, Held, Idle };
    struct Slot {
        void* start = MAP_FAILED;
        std::size_t length = 0;
        cv::Mat grey; ///< conversion target for YUYV, of the configured size
        Where where = Where::Queued;
    };
    std::mutex mutex;
    int fd = -1; ///< -1 once the session ended
    std::vector<Slot> slots;

    ~MappedPool()
    {
        for (auto& s : slots)
            if (s.start != MAP_FAILED) ::munmap(s.start, s.length);
    }
    void requeue(unsigned index)
    {
        std::lock_guard lock(mutex);
        queueLocked(index);
    }
    void hold(unsigned index)
    {
        std::lock_guard lock(mutex);
        slots[index].where = Where::Held;
    }
    /// After STREAMOFF every buffer not viewed by a Frame is ours again.
    void streamedOff()
    {
        std::lock_guard lock(mutex);
        for (auto& s : slots)
            if (s.where == Where::Queued) s.where = Where::Idle;
    }
    /// Before STREAMON: the idle buffers go back to the driver.
    void queueIdle()
    {
        std::lock_guard lock(mutex);
        for (unsigned i = 0; i < slots.size(); ++i)
            if (slots[i].where == Where::Idle) queueLocked(i);
    }
    void queueLocked(unsigned index)
    {
        slots[index].where = Where::Idle;
        if (fd < 0) return;
        v4l2_buffer b{};
        b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
        b.memory = V4L2_MEMORY_MMAP;
        b.index = index;
        if (xioctl(fd, VIDIOC_QBUF, &b) == -1)
            log::category("camera")->warn("v4l2: requeue buffer {}: {}", index, errnoText(errno));
        else
            slots[index].where = Where::Queued;
    }
    void end()
    {
        std::lock_guard lock(mutex);
        fd = -1;
    }
};

class V4l2Camera final : public Camera {
  public:
    V4l2Camera(std::string configPath, CameraSettings settings, V4l2Config config, Clock& clock)
        : Camera(std::move(configPath), std::move(settings), clock), config_(std::move(config))
    {
    }
    ~V4l2Camera() override
    {
        stopStream();
        closeDevice();
    }

  protected:
    HookResult onConfigure() override
    {
        fd_ = ::open(config_.device.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC);
        if (fd_ < 0)
            return Status::failure(configPath() + ".device: cannot open " + config_.device + ": " + errnoText(errno));
        v4l2_capability cap{};
        if (xioctl(fd_, VIDIOC_QUERYCAP, &cap) == -1) {
            int e = errno;
            closeDevice();
            return Status::failure(configPath() + ".device: " + config_.device +
                                   " is not a V4L2 device: " + errnoText(e));
        }
        const std::uint32_t caps = (cap.capabilities & V4L2_CAP_DEVICE_CAPS) ? cap.device_caps : cap.capabilities;
        if (!(caps & V4L2_CAP_VIDEO_CAPTURE) || !(caps & V4L2_CAP_STREAMING)) {
            closeDevice();
            return Status::failure(configPath() + ".device: " + config_.device +
                                   " cannot capture video by streaming I/O");
        }
        card_ = reinterpret_cast<const char*>(cap.card);
        driverName_ = reinterpret_cast<const char*>(cap.driver);
        busInfo_ = reinterpret_cast<const char*>(cap.bus_info);
        for (const auto& [name, value] : config_.features) {
            if (Status s = doSetFeature(name, value); !s) {
                closeDevice();
                return Status::failure(configPath() + ".features." + name + ": " + s.message());
            }
        }
        if (Status s = applyAll(settings()); !s) {
            closeDevice();
            return s;
        }
        allowRegions();
        readCropSupport();
        log::category("camera")->info("v4l2 {}: opened ({}, {}), {} {}x{}", config_.device, card_, driverName_,
                                      v4l2::fourccName(fourcc_), width_, height_);
        return Status::success();
    }

    Status doApplySettings(const CameraSettings& s) override { return applyAll(s); }

    RegionRules regionRules() const override { return {}; } // the driver adjusts the crop itself
    Roi configuredRegion() const override { return configured_; }

    /// VIDIOC_S_SELECTION (V4L2_SEL_TGT_CROP) with the stream stopped: the
    /// image size follows the crop, which the buffers of the configured ROI
    /// hold. A device that adjusts the crop to one not containing the region,
    /// or whose format does not follow it, is undone and gives whole frames.
    Result<Roi> doSetRegion(const Roi& aligned) override
    {
        const std::string where = "v4l2 " + config_.device + ": ";
        if (!cropUnsupported_.empty()) {
            fallBackToWholeFrames(fmt::format("{}cannot deliver region {}: {}", where, aligned, cropUnsupported_));
            return configured_;
        }
        if (aligned == region_) return region_;
        const Stopwatch watch(clock());
        v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
        xioctl(fd_, VIDIOC_STREAMOFF, &type);
        pool_->streamedOff();
        if (const Result<Roi> region = cropTo(aligned); !region.ok()) {
            // Back to the configured crop, which the buffers hold; a failure there is said too.
            const Result<Roi> restored = cropTo(configured_);
            fallBackToWholeFrames(
                fmt::format("{}region {} refused: {}{}", where, aligned, region.message(),
                            restored.ok() ? "" : "; the configured crop not restored: " + restored.message()));
        }
        pool_->queueIdle();
        if (xioctl(fd_, VIDIOC_STREAMON, &type) == -1)
            return fail(Status::failure(StatusCode::IoError, where + "cannot restart streaming: " + errnoText(errno)));
        regionChangeMs_ = watch.ms();
        return region_;
    }

    HookResult onActivate() override
    {
        if (region_ != configured_) {
            // The last activation ended on another region: the buffers are sized from the configured one.
            if (const Result<Roi> restored = cropTo(configured_); !restored.ok())
                return Status::failure("v4l2 " + config_.device +
                                       ": cannot restore the configured crop: " + restored.message());
        }
        v4l2_requestbuffers req{};
        req.count = static_cast<std::uint32_t>(config_.bufferCount);
        req.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
        req.memory = V4L2_MEMORY_MMAP;
        if (xioctl(fd_, VIDIOC_REQBUFS, &req) == -1)
            return Status::failure("v4l2 " + config_.device + ": cannot allocate buffers: " + errnoText(errno));
        if (req.count < 2) return Status::failure("v4l2 " + config_.device + ": device granted fewer than 2 buffers");
        pool_ = std::make_shared<MappedPool>();
        pool_->slots.resize(req.count);
        for (unsigned i = 0; i < req.count; ++i) {
            v4l2_buffer b{};
            b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
            b.memory = V4L2_MEMORY_MMAP;
            b.index = i;
            if (xioctl(fd_, VIDIOC_QUERYBUF, &b) == -1) return failActivate("query buffer", errno);
            auto& slot = pool_->slots[i];
            slot.length = b.length;
            slot.start = ::mmap(nullptr, b.length, PROT_READ | PROT_WRITE, MAP_SHARED, fd_, b.m.offset);
            if (slot.start == MAP_FAILED) return failActivate("map buffer", errno);
            if (v4l2::needsConversion(fourcc_)) slot.grey.create(height_, width_, CV_8UC1);
            if (xioctl(fd_, VIDIOC_QBUF, &b) == -1) return failActivate("queue buffer", errno);
        }
        pool_->fd = fd_;
        v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
        if (xioctl(fd_, VIDIOC_STREAMON, &type) == -1) return failActivate("start streaming", errno);
        return Status::success();
    }

    HookResult onDeactivate() override
    {
        stopStream();
        return Status::success();
    }

    void onCleanup() override
    {
        stopStream();
        closeDevice();
    }

    Frame doGrab(milliseconds timeout) override
    {
        // Frames completed before this call are stale: requeue them.
        v4l2_buffer b{};
        while (dequeue(b)) pool_->requeue(b.index);
        // poll() waits in real time for the device: the timeout is the steady clock's, whatever
        // clock the driver was given (docs/drivers.md, "Clock").
        const Clock& steady = Clock::steady();
        const auto deadline = steady.now() + timeout;
        for (;;) {
            // poll() counts whole milliseconds: round up and re-check the
            // deadline, so a timeout is reported only once it has fully passed.
            const auto now = steady.now();
            if (now >= deadline) break;
            const auto left = std::chrono::ceil<milliseconds>(deadline - now).count();
            pollfd p{fd_, POLLIN, 0};
            int r = ::poll(&p, 1, static_cast<int>(left));
            if (r < 0 && errno == EINTR) continue;
            if (r < 0)
                return Frame::failed(FrameStatus::Error, "v4l2 " + config_.device + ": poll: " + errnoText(errno));
            if (r == 0) continue;
            if (p.revents & (POLLERR | POLLHUP))
                return Frame::failed(FrameStatus::Error, "v4l2 " + config_.device + ": device error or unplugged");
            if (dequeue(b)) return toFrame(b);
            if (errno != EAGAIN)
                return Frame::failed(FrameStatus::Error, "v4l2 " + config_.device + ": dequeue: " + errnoText(errno));
        }
        return Frame::failed(FrameStatus::Timeout,
                             "v4l2 " + config_.device + ": no frame within " + std::to_string(timeout.count()) + " ms");
    }

    Result<std::vector<FeatureInfo>> doListFeatures() override
    {
        std::vector<FeatureInfo> out;
        v4l2_queryctrl q{};
        q.id = V4L2_CTRL_FLAG_NEXT_CTRL;
        while (xioctl(fd_, VIDIOC_QUERYCTRL, &q) == 0) {
            if (!(q.flags & V4L2_CTRL_FLAG_DISABLED) && q.type != V4L2_CTRL_TYPE_CTRL_CLASS) {
                FeatureInfo f;
                f.name = reinterpret_cast<const char*>(q.name);
                f.type = q.type == V4L2_CTRL_TYPE_BOOLEAN  ? "Boolean"
                         : q.type == V4L2_CTRL_TYPE_MENU   ? "Enumeration"
                         : q.type == V4L2_CTRL_TYPE_BUTTON ? "Command"
                                                           : "Integer";
                f.access = (q.flags & V4L2_CTRL_FLAG_READ_ONLY)    ? "RO"
                           : (q.flags & V4L2_CTRL_FLAG_WRITE_ONLY) ? "WO"
                                                                   : "RW";
                if (f.type != "Command" && f.access != "WO") {
                    v4l2_control c{q.id, 0};
                    if (xioctl(fd_, VIDIOC_G_CTRL, &c) == 0) f.value = std::to_string(c.value);
                }
                out.push_back(std::move(f));
            }
            q.id |= V4L2_CTRL_FLAG_NEXT_CTRL;
        }
        return out;
    }

    Result<std::string> doGetFeature(const std::string& name) override
    {
        auto q = findControl(name);
        if (!q) return Status::failure("v4l2 " + config_.device + ": no control named '" + name + "'");
        v4l2_control c{q->id, 0};
        if (xioctl(fd_, VIDIOC_G_CTRL, &c) == -1)
            return Status::failure("v4l2 " + config_.device + ": cannot read " + name + ": " + errnoText(errno));
        return std::to_string(c.value);
    }

    Status doSetFeature(const std::string& name, const std::string& value) override
    {
        auto q = findControl(name);
        if (!q) return Status::failure("v4l2 " + config_.device + ": no control named '" + name + "'");
        std::int32_t v = 0;
        std::istringstream in(value);
        if (value == "true" || value == "on")
            v = 1;
        else if (value == "false" || value == "off")
            v = 0;
        else if (!(in >> v) || !in.eof())
            return Status::failure("v4l2 " + config_.device + ": " + name + " needs an integer, got '" + value + "'");
        // The kernel clamps integer controls to their range instead of refusing:
        // check first, so a wrong value is an error rather than another value.
        const bool ranged = q->type == V4L2_CTRL_TYPE_INTEGER || q->type == V4L2_CTRL_TYPE_BOOLEAN ||
                            q->type == V4L2_CTRL_TYPE_MENU || q->type == V4L2_CTRL_TYPE_INTEGER_MENU;
        if (ranged && (v < q->minimum || v > q->maximum))
            return Status::failure("v4l2 " + config_.device + ": cannot set " + name + " = " + value +
                                   ": outside the control's range " + std::to_string(q->minimum) + ".." +
                                   std::to_string(q->maximum));
        if (q->type == V4L2_CTRL_TYPE_INTEGER && q->step > 1 && (v - q->minimum) % q->step != 0)
            return Status::failure("v4l2 " + config_.device + ": cannot set " + name + " = " + value +
                                   ": not a multiple of the step " + std::to_string(q->step) + " from " +
                                   std::to_string(q->minimum));
        v4l2_control c{q->id, v};
        if (xioctl(fd_, VIDIOC_S_CTRL, &c) == -1)
            return Status::failure("v4l2 " + config_.device + ": cannot set " + name + " = " + value + ": " +
                                   errnoText(errno));
        return Status::success();
    }

    Result<CameraInfo> doInfo() override
    {
        CameraInfo info;
        info.backend = "v4l2";
        info.vendor = driverName_;
        info.model = card_;
        info.serial = busInfo_;
        info.address = config_.device;
        info.sensorWidth = width_;
        info.sensorHeight = height_;
        return info;
    }

  private:
    /// Whether the device crops at all: it reports crop bounds.
    void readCropSupport()
    {
        v4l2_selection sel{};
        sel.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
        sel.target = V4L2_SEL_TGT_CROP_BOUNDS;
        cropUnsupported_.clear();
        if (xioctl(fd_, VIDIOC_G_SELECTION, &sel) == -1)
            cropUnsupported_ = "the device cannot crop (VIDIOC_G_SELECTION: " + errnoText(errno) + ")";
        configured_ = settings().roi.isFullSensor() ? Roi{0, 0, width_, height_} : settings().roi;
        region_ = configured_;
    }

    /// Sets the crop (stream stopped) to a rectangle containing `want`
    /// (V4L2_SEL_FLAG_GE) and takes the format it implies. The region
    /// delivered, or a failure saying why (the driver boundary does not
    /// throw, docs/style.md point 4).
    Result<Roi> cropTo(const Roi& want)
    {
        v4l2_selection sel{};
        sel.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
        sel.target = V4L2_SEL_TGT_CROP;
        sel.flags = V4L2_SEL_FLAG_GE;
        sel.r = {want.x, want.y, static_cast<std::uint32_t>(want.width), static_cast<std::uint32_t>(want.height)};
        if (xioctl(fd_, VIDIOC_S_SELECTION, &sel) == -1)
            return Status::failure(StatusCode::IoError, "VIDIOC_S_SELECTION: " + errnoText(errno));
        const Roi chosen{sel.r.left, sel.r.top, static_cast<int>(sel.r.width), static_cast<int>(sel.r.height)};
        auto region = v4l2::acceptedCrop(want, chosen, configured_);
        if (!region) return Status::failure(StatusCode::NotAllowed, fmt::format("the device cropped to {}", chosen));
        v4l2_format fmt{};
        fmt.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
        if (xioctl(fd_, VIDIOC_G_FMT, &fmt) == -1)
            return Status::failure(StatusCode::IoError, "VIDIOC_G_FMT: " + errnoText(errno));
        const bool fits = !pool_ || std::all_of(pool_->slots.begin(), pool_->slots.end(),
                                                [&](const auto& slot) { return slot.length >= fmt.fmt.pix.sizeimage; });
        if (static_cast<int>(fmt.fmt.pix.width) != region->width ||
            static_cast<int>(fmt.fmt.pix.height) != region->height || !fits)
            return Status::failure(StatusCode::NotAllowed,
                                   fmt::format("the image became {}x{} ({} bytes) for the crop {}", fmt.fmt.pix.width,
                                               fmt.fmt.pix.height, fmt.fmt.pix.sizeimage, *region));
        width_ = region->width;
        height_ = region->height;
        bytesPerLine_ = fmt.fmt.pix.bytesperline;
        region_ = *region;
        return *region;
    }

    /// The control whose name (as VIDIOC_QUERYCTRL reports it) is `name`.
    std::optional<v4l2_queryctrl> findControl(const std::string& name)
    {
        v4l2_queryctrl q{};
        q.id = V4L2_CTRL_FLAG_NEXT_CTRL;
        while (xioctl(fd_, VIDIOC_QUERYCTRL, &q) == 0) {
            if (name == reinterpret_cast<const char*>(q.name)) return q;
            q.id |= V4L2_CTRL_FLAG_NEXT_CTRL;
        }
        return std::nullopt;
    }

    Status applyAll(const CameraSettings& s)
    {
        const std::string where = "v4l2 " + config_.device + ": ";
        if (s.gainDb)
            return Status::failure(where + "V4L2 gain has no unit; leave gain_db unset and set the device's gain "
                                           "control by name under camera.driver.features");
        // Formats the device offers.
        std::vector<std::uint32_t> offered;
        v4l2_fmtdesc d{};
        d.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
        while (xioctl(fd_, VIDIOC_ENUM_FMT, &d) == 0) {
            offered.push_back(d.pixelformat);
            ++d.index;
        }
        std::optional<std::uint32_t> chosen;
        if (config_.deviceFormat) {
            const auto fits = v4l2::candidateFourccs(s.pixelFormat);
            if (std::find(fits.begin(), fits.end(), *config_.deviceFormat) == fits.end())
                return Status::failure(configPath() + ".device_format: " + v4l2::fourccName(*config_.deviceFormat) +
                                       " cannot deliver " + std::string(enumName(s.pixelFormat)));
            if (std::find(offered.begin(), offered.end(), *config_.deviceFormat) != offered.end())
                chosen = config_.deviceFormat;
        } else {
            chosen = v4l2::negotiate(s.pixelFormat, offered);
        }
        if (!chosen) {
            std::string list;
            for (auto f : offered) list += (list.empty() ? "" : ", ") + v4l2::fourccName(f);
            std::string want;
            if (config_.deviceFormat)
                want = v4l2::fourccName(*config_.deviceFormat) + " (device_format)";
            else
                for (auto f : v4l2::candidateFourccs(s.pixelFormat))
                    want += (want.empty() ? "" : " or ") + v4l2::fourccName(f);
            return Status::failure(where + std::string(enumName(s.pixelFormat)) + " needs " + want +
                                   "; the device offers " + (list.empty() ? "nothing" : list));
        }
        v4l2_format fmt{};
        fmt.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
        if (xioctl(fd_, VIDIOC_G_FMT, &fmt) == -1)
            return Status::failure(where + "cannot read the format: " + errnoText(errno));
        if (!s.roi.isFullSensor()) {
            // The capture crop is the ROI; the image size follows it (no scaling).
            v4l2_selection sel{};
            sel.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
            sel.target = V4L2_SEL_TGT_CROP;
            sel.r = {s.roi.x, s.roi.y, static_cast<std::uint32_t>(s.roi.width),
                     static_cast<std::uint32_t>(s.roi.height)};
            if (xioctl(fd_, VIDIOC_S_SELECTION, &sel) == -1 || sel.r.left != s.roi.x || sel.r.top != s.roi.y ||
                static_cast<int>(sel.r.width) != s.roi.width || static_cast<int>(sel.r.height) != s.roi.height)
                return Status::failure(where + "the device cannot crop to the ROI");
            fmt.fmt.pix.width = static_cast<std::uint32_t>(s.roi.width);
            fmt.fmt.pix.height = static_cast<std::uint32_t>(s.roi.height);
        }
        fmt.fmt.pix.pixelformat = *chosen;
        fmt.fmt.pix.field = V4L2_FIELD_NONE;
        if (xioctl(fd_, VIDIOC_S_FMT, &fmt) == -1)
            return Status::failure(where + "format refused: " + errnoText(errno));
        if (fmt.fmt.pix.pixelformat != *chosen)
            return Status::failure(where + "asked for " + v4l2::fourccName(*chosen) + ", the device chose " +
                                   v4l2::fourccName(fmt.fmt.pix.pixelformat));
        fourcc_ = *chosen;
        width_ = static_cast<int>(fmt.fmt.pix.width);
        height_ = static_cast<int>(fmt.fmt.pix.height);
        bytesPerLine_ = fmt.fmt.pix.bytesperline;
        if (s.exposureUs) {
            // Webcams and test devices often have no absolute exposure at all:
            // say so rather than pass on the ioctl's bare EINVAL.
            v4l2_queryctrl q{};
            q.id = V4L2_CID_EXPOSURE_ABSOLUTE;
            if (xioctl(fd_, VIDIOC_QUERYCTRL, &q) == -1 || (q.flags & V4L2_CTRL_FLAG_DISABLED))
                return Status::failure(where + "exposure_us is set but the device has no absolute exposure control "
                                               "(V4L2_CID_EXPOSURE_ABSOLUTE); leave exposure_us unset");
            v4l2_control manual{V4L2_CID_EXPOSURE_AUTO, V4L2_EXPOSURE_MANUAL};
            xioctl(fd_, VIDIOC_S_CTRL, &manual); // absent on many devices; the absolute value decides
            v4l2_control c{V4L2_CID_EXPOSURE_ABSOLUTE, static_cast<std::int32_t>(*s.exposureUs / 100.0 + 0.5)};
            if (xioctl(fd_, VIDIOC_S_CTRL, &c) == -1)
                return Status::failure(where + "exposure refused: " + errnoText(errno));
        }
        return Status::success();
    }

    Status failActivate(const char* what, int e)
    {
        stopStream();
        return Status::failure("v4l2 " + config_.device + ": cannot " + what + ": " + errnoText(e));
    }

    bool dequeue(v4l2_buffer& b)
    {
        b = {};
        b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
        b.memory = V4L2_MEMORY_MMAP;
        return xioctl(fd_, VIDIOC_DQBUF, &b) == 0;
    }

    Frame toFrame(const v4l2_buffer& b)
    {
        auto pool = pool_;
        const unsigned index = b.index;
        auto& slot = pool->slots[index];
        auto recycle = [pool, index] { pool->requeue(index); };
        const auto ts = std::chrono::seconds(b.timestamp.tv_sec) + std::chrono::microseconds(b.timestamp.tv_usec);
        const FrameStatus status = (b.flags & V4L2_BUF_FLAG_ERROR) ? FrameStatus::Incomplete : FrameStatus::Ok;
        const std::string message =
            status == FrameStatus::Ok ? "" : "v4l2 " + config_.device + ": frame marked corrupt";
        const auto* data = static_cast<const std::uint8_t*>(slot.start);
        if (b.bytesused < static_cast<std::size_t>(bytesPerLine_) * (height_ - 1)) {
            pool->requeue(index);
            return Frame::failed(FrameStatus::Incomplete, "v4l2 " + config_.device + ": short frame (" +
                                                              std::to_string(b.bytesused) + " bytes)");
        }
        cv::Mat view;
        if (v4l2::needsConversion(fourcc_)) {
            // The region's grey image in the front of the slot's (configured-size) conversion target.
            view = cv::Mat(height_, width_, CV_8UC1, slot.grey.data);
            v4l2::yuyvToGrey(data, bytesPerLine_, width_, height_, view);
        } else {
            // GREY/Y12/Y16 are the frame itself: a strided view of the mapped buffer.
            view = cv::Mat(height_, width_, cvTypeOf(settings().pixelFormat), slot.start, bytesPerLine_);
        }
        pool->hold(index);
        Frame f = Frame::over(view, b.sequence, ts, status, std::move(recycle), message);
        f.region = region_;
        f.payloadBytes = b.bytesused;
        f.regionChangeMs = std::exchange(regionChangeMs_, 0.0);
        return f;
    }

    void stopStream()
    {
        if (!pool_) return;
        pool_->end();
        if (fd_ >= 0) {
            v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
            xioctl(fd_, VIDIOC_STREAMOFF, &type);
        }
        pool_.reset(); // mappings go when the last frame does; REQBUFS 0 needs them gone, so it waits for reopen
    }

    void closeDevice()
    {
        if (fd_ >= 0) ::close(fd_);
        fd_ = -1;
    }

    V4l2Config config_;
    int fd_ = -1;
    std::string card_, driverName_, busInfo_;
    std::uint32_t fourcc_ = 0;
    int width_ = 0;
    int height_ = 0;
    std::size_t bytesPerLine_ = 0;
    std::shared_ptr<MappedPool> pool_;
    Roi configured_;              ///< the configured ROI on the sensor (the whole image unless roi is set)
    Roi region_;                  ///< the crop frames cover now
    std::string cropUnsupported_; ///< why the device cannot crop; empty when it can
    double regionChangeMs_ = 0.0; ///< the last crop change's duration, for the next frame
};

} // namespace

std::unique_ptr<Camera> makeV4l2Camera(const ConfigNode& driver, Clock& clock)
{
    driver.allowOnlyKeys({"backend", "pixel_format", "exposure_us", "gain_db", "roi", "trigger", "device",
                          "device_format", "buffer_count", "features"});
    V4l2Config c;
    c.device = driver["device"].asString();
    if (c.device.empty()) driver["device"].fail("empty device path");
    if (auto n = driver.optional("buffer_count")) c.bufferCount = static_cast<int>(n->asIntIn(2, 32));
    if (auto n = driver.optional("features")) {
        require(n->isMap(), *n, "expected a map of V4L2 control names to values");
        for (const auto& key : n->keys()) c.features.emplace_back(key, (*n)[key].asString());
    }
    CameraSettings s = parseCameraSettings(driver);
    if (auto n = driver.optional("device_format")) {
        const std::string name = n->asString();
        std::string fits;
        for (auto f : v4l2::candidateFourccs(s.pixelFormat)) {
            if (v4l2::fourccName(f) == name) c.deviceFormat = f;
            fits += (fits.empty() ? "" : " or ") + v4l2::fourccName(f);
        }
        if (!c.deviceFormat)
            n->fail("'" + name + "' cannot deliver " + std::string(enumName(s.pixelFormat)) + "; expected " + fits);
    }
    if (s.gainDb) driver["gain_db"].fail("V4L2 gain has no unit; set the device's gain control under 'features'");
    return std::make_unique<V4l2Camera>(driver.path(), s, std::move(c), clock);
}

} // namespace hg::drivers
