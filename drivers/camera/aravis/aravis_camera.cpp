// GigE Vision backend over Aravis 0.8.
//
// - Opens by IP address (preferred on a line PC: no discovery, and as root a
//   name lookup can pick another interface) or by serial / device id.
// - Features by GenICam name for maintenance and for `camera.driver.features`.
// - Streams into a pool of `buffer_count` Aravis buffers allocated at
//   activate(); a Frame's cv::Mat is a view of the ArvBuffer memory and the
//   buffer is pushed back into the stream when the frame is released.
// - The stream socket gets a fixed receive buffer (default 4 MiB): without the
//   packet socket (non-root) the kernel default drops most packets of a frame.
// - Recovery: a grab that times out (or a failed trigger, or the heartbeat
//   thread's "control-lost") marks the link suspect; the next grab probes the
//   device with one GVCP read and, when it does not answer, closes it and
//   reopens it by address, re-applies settings and features and restarts the
//   stream. Failed reopen attempts back off exponentially.
#include "aravis_camera.h"

#include <algorithm>
#include <atomic>
#include <mutex>
#include <sstream>

#include <arv.h>
#include <opencv2/core.hpp>

#include "hullgauge/common/error.h"
#include "hullgauge/common/log.h"

namespace hg::drivers {
namespace {

using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

std::shared_ptr<spdlog::logger> logger() { return log::category("camera"); }

/// Takes a GError (if any) and turns it into text, freeing it.
std::string takeError(GError*& error, std::string_view fallback = "unknown error")
{
    if (!error) return std::string(fallback);
    std::string m = error->message ? error->message : std::string(fallback);
    g_clear_error(&error);
    return m;
}

/// GigE Vision bootstrap register CCP (Control Channel Privilege, GigE Vision 2.0
/// table 28-1): readable on every compliant device, so one read is a cheap probe.
constexpr guint64 kBootstrapCcpRegister = 0x0A00;

struct AravisConfig {
    std::string address;  ///< IPv4 address, or empty
    std::string serial;   ///< serial number or device id, or empty
    int bufferCount = 4;
    std::optional<int> packetSize;
    int socketBufferBytes = 4 * 1024 * 1024;
    bool packetSocket = true;
    std::optional<int> packetTimeoutMs;
    std::optional<int> frameRetentionMs;
    milliseconds reconnectMin{200};
    milliseconds reconnectMax{5000};
    std::vector<std::pair<std::string, std::string>> features;

    std::string id() const { return address.empty() ? serial : address; }
};

/// Buffers go back to the stream they came from; once that stream is retired
/// (stop, reopen) they are freed instead. Shared with every outstanding Frame.
struct BufferHome {
    std::mutex mutex;
    ArvStream* stream = nullptr;

    void give(ArvBuffer* buffer)
    {
        std::lock_guard lock(mutex);
        if (stream)
            arv_stream_push_buffer(stream, buffer);
        else
            g_object_unref(buffer);
    }
    void retire()
    {
        std::lock_guard lock(mutex);
        stream = nullptr;
    }
};

std::string describeBufferStatus(ArvBufferStatus s)
{
    switch (s) {
    case ARV_BUFFER_STATUS_SUCCESS: return "success";
    case ARV_BUFFER_STATUS_CLEARED: return "cleared";
    case ARV_BUFFER_STATUS_TIMEOUT: return "not all packets arrived in time";
    case ARV_BUFFER_STATUS_MISSING_PACKETS: return "missing packets";
    case ARV_BUFFER_STATUS_WRONG_PACKET_ID: return "wrong packet id";
    case ARV_BUFFER_STATUS_SIZE_MISMATCH: return "image larger than the buffer";
    case ARV_BUFFER_STATUS_FILLING: return "still filling";
    case ARV_BUFFER_STATUS_ABORTED: return "aborted";
    default: return "unknown buffer status";
    }
}

ArvPixelFormat arvPixelFormat(PixelFormat f)
{
    switch (f) {
    case PixelFormat::Mono8: return ARV_PIXEL_FORMAT_MONO_8;
    case PixelFormat::Mono12: return ARV_PIXEL_FORMAT_MONO_12;
    case PixelFormat::Mono16: return ARV_PIXEL_FORMAT_MONO_16;
    }
    return ARV_PIXEL_FORMAT_MONO_8;
}

class AravisCamera final : public Camera {
public:
    AravisCamera(std::string configPath, CameraSettings settings, AravisConfig config)
        : Camera(std::move(configPath), std::move(settings)), config_(std::move(config))
    {
    }

    ~AravisCamera() override
    {
        stopStream(/*talkToDevice=*/!lost_);
        closeDevice();
    }

protected:
    Status doConfigure() override
    {
        if (Status s = openDevice(); !s) return s;
        if (Status s = applyAll(settings()); !s) {
            closeDevice();
            return s;
        }
        return Status::success();
    }

    Status doApplySettings(const CameraSettings& s) override { return applyAll(s); }

    Status doActivate() override
    {
        lost_ = false;
        suspect_ = false;
        return startStream();
    }

    Status doDeactivate() override
    {
        stopStream(/*talkToDevice=*/!lost_);
        return Status::success();
    }

    Status doCleanup() override
    {
        stopStream(/*talkToDevice=*/!lost_);
        closeDevice();
        return Status::success();
    }

    Frame doGrab(milliseconds timeout) override
    {
        const auto start = Clock::now();
        if (controlLost_.exchange(false)) {
            logger()->warn("camera {}: control of the device was lost (heartbeat)", config_.id());
            suspect_ = true;
        }
        if (suspect_ && !lost_) {
            GError* error = nullptr;
            guint32 value = 0;
            if (arv_device_read_register(arv_camera_get_device(camera_), kBootstrapCcpRegister, &value, &error)) {
                suspect_ = false;
            } else {
                const std::string why = takeError(error);
                logger()->warn("camera {}: not answering ({}); will reconnect", config_.id(), why);
                lost_ = true;
                // The reconnect waits for the next grab: one grab never pays for probe and reopen both.
                backoff_ = config_.reconnectMin;
                nextAttempt_ = Clock::now() + backoff_;
                return Frame::failed(FrameStatus::Error, "camera " + config_.id() + ": not answering (" + why +
                                                             "); reconnecting from the next grab");
            }
        }
        if (lost_) {
            if (Frame f = tryReconnect(); f.status != FrameStatus::Ok) return f;
        }

        drainStaleFrames();
        if (settings().trigger == TriggerMode::Software) {
            GError* error = nullptr;
            arv_camera_software_trigger(camera_, &error);
            if (error) {
                suspect_ = true;
                return Frame::failed(FrameStatus::Timeout, "camera " + config_.id() +
                                                               ": software trigger not acknowledged: " +
                                                               takeError(error));
            }
        }
        const auto remaining = std::max(timeout - std::chrono::duration_cast<milliseconds>(Clock::now() - start),
                                        milliseconds(0));
        ArvBuffer* buffer = arv_stream_timeout_pop_buffer(stream_, static_cast<guint64>(remaining.count()) * 1000);
        if (!buffer) {
            suspect_ = true;
            ++consecutiveTimeouts_;
            std::ostringstream m;
            m << "camera " << config_.id() << ": no frame within " << timeout.count() << " ms";
            if (consecutiveTimeouts_ > 1) m << " (" << consecutiveTimeouts_ << " timeouts in a row)";
            return Frame::failed(FrameStatus::Timeout, m.str());
        }
        consecutiveTimeouts_ = 0;
        return toFrame(buffer);
    }

    Result<std::vector<FeatureInfo>> doListFeatures() override
    {
        ArvGc* gc = arv_device_get_genicam(arv_camera_get_device(camera_));
        std::vector<FeatureInfo> out;
        std::vector<std::string> seen;
        collectFeatures(gc, "Root", out, seen, 0);
        return out;
    }

    Result<std::string> doGetFeature(const std::string& name) override
    {
        ArvGcFeatureNode* node = featureNode(name);
        if (!node) return Status::failure("camera " + config_.id() + ": no feature named '" + name + "'");
        GError* error = nullptr;
        const char* v = arv_gc_feature_node_get_value_as_string(node, &error);
        if (error) return Status::failure("camera " + config_.id() + ": cannot read " + name + ": " + takeError(error));
        return std::string(v ? v : "");
    }

    Status doSetFeature(const std::string& name, const std::string& value) override
    {
        ArvGcFeatureNode* node = featureNode(name);
        if (!node) return Status::failure("camera " + config_.id() + ": no feature named '" + name + "'");
        GError* error = nullptr;
        if (ARV_IS_GC_COMMAND(node))
            arv_gc_command_execute(ARV_GC_COMMAND(node), &error);
        else
            arv_gc_feature_node_set_value_from_string(node, value.c_str(), &error);
        if (error)
            return Status::failure("camera " + config_.id() + ": cannot set " + name + " = '" + value +
                                   "': " + takeError(error));
        return Status::success();
    }

    Result<CameraInfo> doInfo() override
    {
        CameraInfo info;
        info.backend = "aravis";
        GError* error = nullptr;
        auto text = [&](const char* s) { return std::string(s ? s : ""); };
        info.vendor = text(arv_camera_get_vendor_name(camera_, &error));
        info.model = text(arv_camera_get_model_name(camera_, &error));
        info.serial = text(arv_camera_get_device_serial_number(camera_, &error));
        arv_camera_get_sensor_size(camera_, &info.sensorWidth, &info.sensorHeight, &error);
        if (error) return Status::failure("camera " + config_.id() + ": " + takeError(error));
        info.address = config_.address.empty() ? deviceAddress() : config_.address;
        return info;
    }

private:
    // --- device --------------------------------------------------------------

    Status openDevice()
    {
        GError* error = nullptr;
        const std::string id = config_.id();
        camera_ = arv_camera_new(id.c_str(), &error);
        if (!camera_) {
            return Status::failure(configPath() + (config_.address.empty() ? ".serial" : ".address") +
                                   ": no GigE Vision camera answers at '" + id + "': " +
                                   takeError(error, "device not found"));
        }
        if (!arv_camera_is_gv_device(camera_)) {
            closeDevice();
            return Status::failure(configPath() + ": '" + id + "' is not a GigE Vision camera");
        }
        g_signal_connect(arv_camera_get_device(camera_), "control-lost", G_CALLBACK(&AravisCamera::onControlLost),
                         this);
        if (!config_.packetSocket)
            arv_camera_gv_set_stream_options(camera_, ARV_GV_STREAM_OPTION_PACKET_SOCKET_DISABLED);
        if (config_.packetSize) {
            arv_camera_gv_set_packet_size(camera_, *config_.packetSize, &error);
            if (error) {
                std::string m = takeError(error);
                closeDevice();
                return Status::failure(configPath() + ".packet_size: camera refused " +
                                       std::to_string(*config_.packetSize) + ": " + m);
            }
        }
        for (const auto& [name, value] : config_.features) {
            if (Status s = doSetFeature(name, value); !s) {
                closeDevice();
                return Status::failure(configPath() + ".features." + name + ": " + s.message());
            }
        }
        logger()->info("camera {}: opened ({} {}, serial {})", id, safe(arv_camera_get_vendor_name(camera_, nullptr)),
                       safe(arv_camera_get_model_name(camera_, nullptr)),
                       safe(arv_camera_get_device_serial_number(camera_, nullptr)));
        return Status::success();
    }

    void closeDevice()
    {
        if (!camera_) return;
        g_signal_handlers_disconnect_by_data(arv_camera_get_device(camera_), this);
        g_clear_object(&camera_);
    }

    static std::string safe(const char* s) { return s ? s : ""; }

    std::string deviceAddress() const
    {
        GSocketAddress* a = arv_gv_device_get_device_address(ARV_GV_DEVICE(arv_camera_get_device(camera_)));
        if (!a) return {};
        GInetAddress* inet = g_inet_socket_address_get_address(G_INET_SOCKET_ADDRESS(a));
        gchar* s = g_inet_address_to_string(inet);
        std::string out = s ? s : "";
        g_free(s);
        return out;
    }

    static void onControlLost(ArvGvDevice* /*device*/, gpointer self)
    {
        // Called on Aravis' heartbeat thread: only flag it.
        static_cast<AravisCamera*>(self)->controlLost_ = true;
    }

    /// Pixel format, ROI, exposure, gain and trigger, each read back.
    Status applyAll(const CameraSettings& s)
    {
        GError* error = nullptr;
        const std::string where = "camera " + config_.id() + ": ";

        arv_camera_set_pixel_format(camera_, arvPixelFormat(s.pixelFormat), &error);
        if (error)
            return Status::failure(where + "pixel format " + std::string(toString(s.pixelFormat)) +
                                   " refused: " + takeError(error));

        int x = s.roi.x, y = s.roi.y, w = s.roi.width, h = s.roi.height;
        int sensorW = 0, sensorH = 0;
        arv_camera_get_sensor_size(camera_, &sensorW, &sensorH, &error);
        if (error) return Status::failure(where + "cannot read the sensor size: " + takeError(error));
        if (s.roi.isFullSensor()) {
            w = sensorW;
            h = sensorH;
            x = y = 0;
        } else if (x + w > sensorW || y + h > sensorH) {
            // Not every device checks offset + size against the sensor: refuse here.
            std::ostringstream m;
            m << where << "ROI [" << x << ", " << y << ", " << w << ", " << h << "] exceeds the " << sensorW << "x"
              << sensorH << " sensor";
            return Status::failure(m.str());
        }
        // Offsets first to zero so a larger width fits, then the region.
        if (!error && arv_camera_is_region_offset_available(camera_, nullptr)) {
            arv_camera_set_integer(camera_, "OffsetX", 0, &error);
            if (!error) arv_camera_set_integer(camera_, "OffsetY", 0, &error);
        }
        if (!error) arv_camera_set_region(camera_, x, y, w, h, &error);
        if (error) return Status::failure(where + "ROI refused: " + takeError(error));
        int rx = 0, ry = 0, rw = 0, rh = 0;
        arv_camera_get_region(camera_, &rx, &ry, &rw, &rh, &error);
        if (error) return Status::failure(where + "cannot read the ROI back: " + takeError(error));
        if (rx != x || ry != y || rw != w || rh != h) {
            std::ostringstream m;
            m << where << "ROI [" << x << ", " << y << ", " << w << ", " << h << "] became [" << rx << ", " << ry
              << ", " << rw << ", " << rh << "] (camera increments or limits)";
            return Status::failure(m.str());
        }

        if (s.exposureUs) {
            if (arv_camera_is_exposure_auto_available(camera_, nullptr))
                arv_camera_set_exposure_time_auto(camera_, ARV_AUTO_OFF, nullptr);
            arv_camera_set_exposure_time(camera_, *s.exposureUs, &error);
            if (error) return Status::failure(where + "exposure refused: " + takeError(error));
        }
        if (s.gainDb) {
            // SFNC's Gain is in dB; GainRaw is in device units and is not accepted as dB.
            if (!ARV_IS_GC_FLOAT(arv_device_get_feature(arv_camera_get_device(camera_), "Gain")))
                return Status::failure(where + "the camera has no Gain feature in dB; set its raw gain by name "
                                                "under camera.driver.features instead of gain_db");
            if (arv_camera_is_gain_auto_available(camera_, nullptr))
                arv_camera_set_gain_auto(camera_, ARV_AUTO_OFF, nullptr);
            arv_camera_set_gain(camera_, *s.gainDb, &error);
            if (error) return Status::failure(where + "gain refused: " + takeError(error));
        }

        if (s.trigger == TriggerMode::Software) {
            if (!arv_camera_is_software_trigger_supported(camera_, nullptr))
                return Status::failure(where + "the camera has no software trigger");
            arv_camera_set_trigger(camera_, "Software", &error);
        } else {
            arv_camera_clear_triggers(camera_, &error);
            if (!error) arv_camera_set_acquisition_mode(camera_, ARV_ACQUISITION_MODE_CONTINUOUS, &error);
        }
        if (error) return Status::failure(where + "trigger mode refused: " + takeError(error));
        return Status::success();
    }

    // --- stream --------------------------------------------------------------

    Status startStream()
    {
        GError* error = nullptr;
        const std::string where = "camera " + config_.id() + ": ";
        const guint payload = arv_camera_get_payload(camera_, &error);
        if (error) return Status::failure(where + "cannot read the payload size: " + takeError(error));
        stream_ = arv_camera_create_stream(camera_, nullptr, nullptr, &error);
        if (!stream_) return Status::failure(where + "cannot open the stream: " + takeError(error));
        if (ARV_IS_GV_STREAM(stream_)) {
            g_object_set(stream_, "socket-buffer", ARV_GV_STREAM_SOCKET_BUFFER_FIXED, "socket-buffer-size",
                         config_.socketBufferBytes, nullptr);
            if (config_.packetTimeoutMs)
                g_object_set(stream_, "packet-timeout", static_cast<guint>(*config_.packetTimeoutMs * 1000), nullptr);
            if (config_.frameRetentionMs)
                g_object_set(stream_, "frame-retention", static_cast<guint>(*config_.frameRetentionMs * 1000),
                             nullptr);
        }
        home_ = std::make_shared<BufferHome>();
        home_->stream = stream_;
        for (int i = 0; i < config_.bufferCount; ++i) arv_stream_push_buffer(stream_, arv_buffer_new_allocate(payload));
        arv_camera_start_acquisition(camera_, &error);
        if (error) {
            std::string m = takeError(error);
            stopStream(false);
            return Status::failure(where + "cannot start acquisition: " + m);
        }
        logger()->debug("camera {}: streaming, payload {} bytes, {} buffers", config_.id(), payload,
                        config_.bufferCount);
        return Status::success();
    }

    void stopStream(bool talkToDevice)
    {
        if (!stream_) return;
        if (talkToDevice && camera_) {
            GError* error = nullptr;
            arv_camera_stop_acquisition(camera_, &error);
            if (error) logger()->warn("camera {}: stop acquisition: {}", config_.id(), takeError(error));
        }
        if (home_) home_->retire();
        home_.reset();
        g_clear_object(&stream_);  // frees the buffers still queued; frames out there free their own
    }

    /// Frames finished before this grab are stale (the part may have moved since).
    void drainStaleFrames()
    {
        while (ArvBuffer* stale = arv_stream_try_pop_buffer(stream_)) arv_stream_push_buffer(stream_, stale);
    }

    Frame toFrame(ArvBuffer* buffer)
    {
        const auto id = arv_buffer_get_frame_id(buffer);
        const auto status = arv_buffer_get_status(buffer);
        auto giveBack = [home = home_, buffer] { home->give(buffer); };
        if (status != ARV_BUFFER_STATUS_SUCCESS) {
            giveBack();
            Frame f = Frame::failed(FrameStatus::Incomplete, "camera " + config_.id() + ": frame " +
                                                                 std::to_string(id) + " " +
                                                                 describeBufferStatus(status));
            f.frameId = id;
            return f;
        }
        const int w = arv_buffer_get_image_width(buffer);
        const int h = arv_buffer_get_image_height(buffer);
        const ArvPixelFormat pf = arv_buffer_get_image_pixel_format(buffer);
        const PixelFormat want = settings().pixelFormat;
        size_t size = 0;
        const void* data = arv_buffer_get_image_data(buffer, &size);
        const std::size_t bytesPerPixel = want == PixelFormat::Mono8 ? 1 : 2;
        if (pf != arvPixelFormat(want) || !data || size < static_cast<std::size_t>(w) * h * bytesPerPixel) {
            giveBack();
            std::ostringstream m;
            m << "camera " << config_.id() << ": frame " << id << " has pixel format 0x" << std::hex << pf
              << std::dec << ", " << size << " bytes for " << w << "x" << h << " (expected "
              << toString(want) << ")";
            Frame f = Frame::failed(FrameStatus::Error, m.str());
            f.frameId = id;
            return f;
        }
        // The view aliases Aravis' buffer: no copy (the buffer is ours until given back).
        cv::Mat view(h, w, cvTypeOf(want), const_cast<void*>(data));
        logger()->trace("camera {}: frame {} {}x{}", config_.id(), id, w, h);
        return Frame::over(view, id, std::chrono::nanoseconds(arv_buffer_get_timestamp(buffer)), FrameStatus::Ok,
                           std::move(giveBack));
    }

    /// Reopen after the device was lost; the returned frame is Ok when the
    /// camera streams again, else an Error naming the reason and the next attempt.
    Frame tryReconnect()
    {
        const auto now = Clock::now();
        if (now < nextAttempt_) {
            auto wait = std::chrono::duration_cast<milliseconds>(nextAttempt_ - now).count();
            return Frame::failed(FrameStatus::Error, "camera " + config_.id() +
                                                         ": lost; next reconnect attempt in " +
                                                         std::to_string(wait) + " ms");
        }
        stopStream(/*talkToDevice=*/false);
        closeDevice();
        Status s = openDevice();
        if (s) s = applyAll(settings());
        if (s) s = startStream();
        if (!s) {
            stopStream(false);
            closeDevice();
            backoff_ = backoff_.count() == 0 ? config_.reconnectMin : std::min(backoff_ * 2, config_.reconnectMax);
            nextAttempt_ = Clock::now() + backoff_;
            logger()->warn("camera {}: reconnect failed ({}); next attempt in {} ms", config_.id(), s.message(),
                           backoff_.count());
            return Frame::failed(FrameStatus::Error, "camera " + config_.id() + ": lost; reconnect failed: " +
                                                         s.message());
        }
        logger()->info("camera {}: reconnected", config_.id());
        lost_ = false;
        suspect_ = false;
        controlLost_ = false;
        backoff_ = milliseconds(0);
        Frame ok;
        ok.status = FrameStatus::Ok;
        return ok;
    }

    // --- features ------------------------------------------------------------

    ArvGcFeatureNode* featureNode(const std::string& name)
    {
        ArvGc* gc = arv_device_get_genicam(arv_camera_get_device(camera_));
        ArvGcNode* node = arv_gc_get_node(gc, name.c_str());
        return ARV_IS_GC_FEATURE_NODE(node) ? ARV_GC_FEATURE_NODE(node) : nullptr;
    }

    void collectFeatures(ArvGc* gc, const char* name, std::vector<FeatureInfo>& out, std::vector<std::string>& seen,
                         int depth)
    {
        if (depth > 16 || std::find(seen.begin(), seen.end(), name) != seen.end()) return;
        seen.emplace_back(name);
        ArvGcNode* node = arv_gc_get_node(gc, name);
        if (ARV_IS_GC_CATEGORY(node)) {
            for (const GSList* it = arv_gc_category_get_features(ARV_GC_CATEGORY(node)); it; it = it->next)
                collectFeatures(gc, static_cast<const char*>(it->data), out, seen, depth + 1);
            return;
        }
        if (!ARV_IS_GC_FEATURE_NODE(node)) return;
        auto* feature = ARV_GC_FEATURE_NODE(node);
        if (!arv_gc_feature_node_is_implemented(feature, nullptr)) return;
        FeatureInfo info;
        info.name = name;
        info.type = ARV_IS_GC_COMMAND(node)       ? "Command"
                    : ARV_IS_GC_ENUMERATION(node) ? "Enumeration"
                    : ARV_IS_GC_BOOLEAN(node)     ? "Boolean"
                    : ARV_IS_GC_FLOAT(node)       ? "Float"
                    : ARV_IS_GC_INTEGER(node)     ? "Integer"
                    : ARV_IS_GC_STRING(node)      ? "String"
                                                  : "Other";
        switch (arv_gc_feature_node_get_actual_access_mode(feature)) {
        case ARV_GC_ACCESS_MODE_RO: info.access = "RO"; break;
        case ARV_GC_ACCESS_MODE_WO: info.access = "WO"; break;
        case ARV_GC_ACCESS_MODE_RW: info.access = "RW"; break;
        default: info.access = "?"; break;
        }
        if (info.type != "Command" && info.access != "WO") {
            GError* error = nullptr;
            const char* v = arv_gc_feature_node_get_value_as_string(feature, &error);
            info.value = error ? "(" + takeError(error) + ")" : safe(v);
        }
        out.push_back(std::move(info));
    }

    AravisConfig config_;
    ArvCamera* camera_ = nullptr;
    ArvStream* stream_ = nullptr;
    std::shared_ptr<BufferHome> home_;
    std::atomic<bool> controlLost_{false};
    bool suspect_ = false;
    bool lost_ = false;
    int consecutiveTimeouts_ = 0;
    milliseconds backoff_{0};
    Clock::time_point nextAttempt_{};
};

}  // namespace

std::unique_ptr<Camera> makeAravisCamera(const ConfigNode& driver)
{
    driver.allowOnlyKeys({"backend", "pixel_format", "exposure_us", "gain_db", "roi", "trigger", "address", "serial",
                          "buffer_count", "packet_size", "socket_buffer_bytes", "packet_socket", "packet_timeout_ms",
                          "frame_retention_ms", "reconnect_backoff_ms", "features"});
    AravisConfig c;
    auto address = driver.optional("address");
    auto serial = driver.optional("serial");
    if (address && serial) serial->fail("give either address or serial, not both");
    if (!address && !serial)
        driver.fail("an aravis camera needs 'address' (IPv4, preferred) or 'serial' (serial number or device id)");
    if (address) {
        c.address = address->asString();
        GInetAddress* inet = g_inet_address_new_from_string(c.address.c_str());
        const bool ipv4 = inet && g_inet_address_get_family(inet) == G_SOCKET_FAMILY_IPV4;
        if (inet) g_object_unref(inet);
        if (!ipv4) address->fail("'" + c.address + "' is not an IPv4 address");
    }
    if (serial) {
        c.serial = serial->asString();
        if (c.serial.empty()) serial->fail("empty serial");
    }
    if (auto n = driver.optional("buffer_count")) c.bufferCount = static_cast<int>(n->asIntIn(2, 64));
    if (auto n = driver.optional("packet_size")) c.packetSize = static_cast<int>(n->asIntIn(576, 16384));
    if (auto n = driver.optional("socket_buffer_bytes"))
        c.socketBufferBytes = static_cast<int>(n->asIntIn(64 * 1024, 256 * 1024 * 1024));
    if (auto n = driver.optional("packet_socket")) c.packetSocket = n->asBool();
    if (auto n = driver.optional("packet_timeout_ms")) c.packetTimeoutMs = static_cast<int>(n->asIntIn(1, 10000));
    if (auto n = driver.optional("frame_retention_ms")) c.frameRetentionMs = static_cast<int>(n->asIntIn(1, 60000));
    if (auto n = driver.optional("reconnect_backoff_ms")) {
        auto v = n->asDoubles(2);
        if (v[0] < 1 || v[1] < v[0] || v[1] > 600000)
            n->fail("expected [min, max] in ms with 1 <= min <= max <= 600000");
        c.reconnectMin = milliseconds(static_cast<long>(v[0]));
        c.reconnectMax = milliseconds(static_cast<long>(v[1]));
    }
    if (auto n = driver.optional("features")) {
        require(n->isMap(), *n, "expected a map of GenICam feature names to values");
        for (const auto& key : n->keys()) c.features.emplace_back(key, (*n)[key].asString());
    }
    return std::make_unique<AravisCamera>(driver.path(), parseCameraSettings(driver), std::move(c));
}

}  // namespace hg::drivers
