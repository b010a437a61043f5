// GigE Vision backend over Aravis 0.8.
//
// - Opens by IP address (preferred on a line PC: no discovery, and as root a
//   name lookup can pick another interface) or by serial / device id. By
//   address the device is opened directly (arv_gv_device_new with the local
//   interface address the kernel routes to the camera), never by discovery.
// - Features by GenICam name for maintenance and for `camera.driver.features`.
// - Streams into a pool of `buffer_count` Aravis buffers allocated at
//   activate(); a Frame's cv::Mat is a view of the ArvBuffer memory and the
//   buffer is pushed back into the stream when the frame is released.
// - The stream socket gets a fixed receive buffer (default 4 MiB): without the
//   packet socket (non-root) the kernel default drops most packets of a frame.
// - Recovery runs on a link worker thread owned by the driver (started by
//   activate(), joined by deactivate()/cleanup()), because every GVCP command
//   to a dead camera blocks for Aravis' fixed control-channel timeout (~2.5 s)
//   and a reopen for longer. The worker sends the software triggers, probes
//   the device with one GVCP read when the link is suspect (a grab timed out,
//   a trigger was not acknowledged, the heartbeat reported "control-lost"),
//   and, when the device does not answer, reopens it with exponential backoff
//   and restarts the stream. grab() only pops frames and waits on the
//   worker's verdict, never longer than its own timeout.
// - Regions per grab (docs/camera.md "Regions per grab"): setRegion() hands
//   the aligned region to the same worker, which writes OffsetX/OffsetY/
//   Width/Height in the SFNC-safe order (acquisition stopped for a new size)
//   before the next trigger; the pool stays sized for the configured ROI and
//   every frame's region comes from its GVSP image leader.
#include "aravis_camera.h"

#include "hullgauge/common/error.h"
#include "hullgauge/common/log.h"
#include "hullgauge/common/worker.h"

#include <algorithm>
#include <arpa/inet.h>
#include <arv.h>
#include <atomic>
#include <cerrno>
#include <condition_variable>
#include <cstring>
#include <mutex>
#include <netinet/in.h>
#include <opencv2/core.hpp>
#include <sstream>
#include <sys/socket.h>
#include <unistd.h>
#include <utility>

namespace hg::drivers {
namespace {

using std::chrono::milliseconds;

std::shared_ptr<spdlog::logger> logger()
{
    return log::category("camera");
}

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
/// GVCP's UDP port (GigE Vision 2.0 section 7.3); only used to ask the kernel's route.
constexpr guint16 kGvcpPort = 3956;

struct AravisConfig {
    std::string address; ///< IPv4 address, or empty
    std::string serial;  ///< serial number or device id, or empty
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

/// The local address the kernel would send from to reach `device` (IPv4): a
/// connected UDP socket's own address. No packet is sent. A failure with the
/// reason otherwise (the driver boundary does not throw, docs/style.md point 4).
Result<std::string> interfaceAddressFor(const std::string& device)
{
    sockaddr_in peer{};
    peer.sin_family = AF_INET;
    peer.sin_port = htons(kGvcpPort);
    if (::inet_pton(AF_INET, device.c_str(), &peer.sin_addr) != 1)
        return Status::failure("'" + device + "' is not an IPv4 address");
    const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    if (fd < 0) return Status::failure(std::string("socket: ") + std::strerror(errno));
    sockaddr_in local{};
    socklen_t length = sizeof local;
    Status failed;
    std::string out;
    if (::connect(fd, reinterpret_cast<const sockaddr*>(&peer), sizeof peer) != 0)
        failed = Status::failure(std::string("no route to ") + device + ": " + std::strerror(errno));
    else if (::getsockname(fd, reinterpret_cast<sockaddr*>(&local), &length) != 0)
        failed = Status::failure(std::string("getsockname: ") + std::strerror(errno));
    else {
        char text[INET_ADDRSTRLEN] = {};
        if (::inet_ntop(AF_INET, &local.sin_addr, text, sizeof text))
            out = text;
        else
            failed = Status::failure(std::string("inet_ntop: ") + std::strerror(errno));
    }
    ::close(fd);
    if (!failed.ok()) return failed;
    return out;
}

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

/// One open connection to the device: the camera object and, while
/// streaming, its stream and buffer home. Shared (a grab holds it while it
/// waits for a frame) so that the link worker can replace it at any time; the
/// last holder closes it.
struct Link {
    ArvCamera* camera = nullptr;
    ArvStream* stream = nullptr;
    std::shared_ptr<BufferHome> home;
    gpointer signalOwner = nullptr;
    /// Size of every pool buffer: the payload of the configured ROI, the largest region.
    std::size_t bufferBytes = 0;

    Link() = default;
    Link(const Link&) = delete;
    Link& operator=(const Link&) = delete;
    ~Link()
    {
        dropStream();
        if (camera) {
            if (signalOwner) g_signal_handlers_disconnect_by_data(arv_camera_get_device(camera), signalOwner);
            g_clear_object(&camera);
        }
    }

    /// Forgets the stream without talking to the device (it may be gone).
    void dropStream()
    {
        if (!stream) return;
        if (home) home->retire();
        home.reset();
        g_clear_object(&stream); // frees the buffers still queued; frames out there free their own
    }
};

std::string describeBufferStatus(ArvBufferStatus s)
{
    switch (s) {
    case ARV_BUFFER_STATUS_SUCCESS:
        return "success";
    case ARV_BUFFER_STATUS_CLEARED:
        return "cleared";
    case ARV_BUFFER_STATUS_TIMEOUT:
        return "not all packets arrived in time";
    case ARV_BUFFER_STATUS_MISSING_PACKETS:
        return "missing packets";
    case ARV_BUFFER_STATUS_WRONG_PACKET_ID:
        return "wrong packet id";
    case ARV_BUFFER_STATUS_SIZE_MISMATCH:
        return "image larger than the buffer";
    case ARV_BUFFER_STATUS_FILLING:
        return "still filling";
    case ARV_BUFFER_STATUS_ABORTED:
        return "aborted";
    default:
        return "unknown buffer status";
    }
}

ArvPixelFormat arvPixelFormat(PixelFormat f)
{
    switch (f) {
    case PixelFormat::Mono8:
        return ARV_PIXEL_FORMAT_MONO_8;
    case PixelFormat::Mono12:
        return ARV_PIXEL_FORMAT_MONO_12;
    case PixelFormat::Mono16:
        return ARV_PIXEL_FORMAT_MONO_16;
    }
    return ARV_PIXEL_FORMAT_MONO_8;
}

/// The region a frame covers on the sensor, from its GVSP image leader.
Roi regionOf(ArvBuffer* buffer)
{
    return Roi{static_cast<int>(arv_buffer_get_image_x(buffer)), static_cast<int>(arv_buffer_get_image_y(buffer)),
               arv_buffer_get_image_width(buffer), arv_buffer_get_image_height(buffer)};
}

/// A GVCP command that got no answer: the device is gone, not refusing.
bool isTimeout(const GError* error)
{
    return error && g_error_matches(error, ARV_DEVICE_ERROR, ARV_DEVICE_ERROR_TIMEOUT);
}

long long msUntil(const Clock& clock, Clock::time_point t)
{
    return std::max<long long>(0, std::chrono::duration_cast<milliseconds>(t - clock.now()).count());
}

/// Whole milliseconds of a stopwatch, for the log.
long long wholeMs(const Stopwatch& watch)
{
    return static_cast<long long>(watch.ms());
}

class AravisCamera final : public Camera {
  public:
    AravisCamera(std::string configPath, CameraSettings settings, AravisConfig config, Clock& clock)
        : Camera(std::move(configPath), std::move(settings), clock), config_(std::move(config))
    {
    }

    ~AravisCamera() override
    {
        stopWorker();
        closeAll();
    }

  protected:
    HookResult onConfigure() override
    {
        allowRegions();
        auto link = std::make_shared<Link>();
        if (Status s = openDevice(*link); !s) return s;
        if (Status s = applyAll(*link, settings()); !s) return s;
        if (Status s = readRegionSetup(*link); !s) return s;
        std::lock_guard lock(mutex_);
        link_ = std::move(link);
        health_ = Health::Streaming;
        return Status::success();
    }

    Status doApplySettings(const CameraSettings& s) override
    {
        auto link = currentLink();
        if (!link) return Status::failure(lostMessage());
        if (Status status = applyAll(*link, s); !status) return status;
        return readRegionSetup(*link);
    }

    HookResult onActivate() override
    {
        std::shared_ptr<Link> link;
        {
            std::lock_guard lock(mutex_);
            if (health_ != Health::Lost) link = link_;
            link_.reset();
        }
        if (!link) {
            // Lost while it was last active and not back then: open it again now.
            link = std::make_shared<Link>();
            Status s = openDevice(*link);
            if (s) s = applyAll(*link, settings());
            if (!s) return HookResult::error(s); // the device is closed now
        }
        // The last activation may have left a smaller region on the device: the
        // pool is sized from the configured ROI's payload.
        auto current = readRegion(*link);
        Status s = current.status();
        if (s) s = writeRegion(*link, current.value(), configured_);
        if (s) s = startStream(*link);
        if (!s) return HookResult::error(s);
        {
            std::lock_guard lock(mutex_);
            wantedRegion_ = deviceRegion_ = configured_;
            reportChange_ = false;
            link_ = std::move(link);
            health_ = Health::Streaming;
            triggerPending_ = false;
            consecutiveTimeouts_ = 0;
            controlLost_ = false;
        }
        worker_.start([this](std::stop_token stop) { linkWorker(stop); }, wakeOn(mutex_, wakeup_));
        return Status::success();
    }

    HookResult onDeactivate() override
    {
        const bool healthy = stopWorker();
        auto link = currentLink();
        const Stopwatch watch(clock());
        if (link) stopStream(*link, /*talkToDevice=*/healthy);
        logger()->debug("camera {}: stream stopped in {} ms{}", config_.id(), wholeMs(watch),
                        healthy ? "" : " (device not answering: not told)");
        return Status::success();
    }

    void onCleanup() override
    {
        stopWorker();
        closeAll();
    }

    Frame doGrab(milliseconds timeout) override
    {
        // The timeout bounds the caller's real wait for frames that come over the wire (Aravis'
        // stream waits in real time): the steady clock's, whatever clock the driver was given;
        // the link worker's schedule is on the driver's (docs/drivers.md, "Clock").
        const auto deadline = Clock::steady().now() + timeout;
        GrabTicket ticket = awaitLink(timeout, deadline);
        if (!ticket.link) return std::move(ticket.refusal);
        Link& link = *ticket.link;

        drainStaleFrames(link);
        std::uint64_t trigger = 0;
        if (settings().trigger == TriggerMode::Software) {
            std::lock_guard lock(mutex_);
            triggerPending_ = true;
            trigger = ++triggersRequested_;
        }
        if (trigger) wakeup_.notify_all();
        ArvBuffer* buffer = popFrameOf(link, ticket.region, deadline);
        if (buffer) {
            std::lock_guard lock(mutex_);
            consecutiveTimeouts_ = 0;
        } else {
            std::ostringstream m;
            m << "camera " << config_.id() << ": no frame within " << timeout.count() << " ms";
            std::lock_guard lock(mutex_);
            ++consecutiveTimeouts_;
            if (consecutiveTimeouts_ > 1) m << " (" << consecutiveTimeouts_ << " timeouts in a row)";
            if (trigger && triggerFailed_ == trigger) m << "; software trigger not acknowledged: " << triggerError_;
            if (health_ == Health::Streaming && link_ == ticket.link) {
                health_ = Health::Suspect;
                reason_ = "no frame within " + std::to_string(timeout.count()) + " ms";
                wakeup_.notify_all();
            }
            Frame f = Frame::failed(FrameStatus::Timeout, m.str());
            f.regionChangeMs = ticket.regionChangeMs;
            return f;
        }
        Frame f = toFrame(link, buffer);
        f.regionChangeMs = ticket.regionChangeMs;
        return f;
    }

    Result<std::vector<FeatureInfo>> doListFeatures() override
    {
        auto link = currentLink();
        if (!link) return Status::failure(lostMessage());
        ArvGc* gc = arv_device_get_genicam(arv_camera_get_device(link->camera));
        std::vector<FeatureInfo> out;
        std::vector<std::string> seen;
        collectFeatures(gc, "Root", out, seen, 0);
        return out;
    }

    Result<std::string> doGetFeature(const std::string& name) override
    {
        auto link = currentLink();
        if (!link) return Status::failure(lostMessage());
        ArvGcFeatureNode* node = featureNode(*link, name);
        if (!node) return Status::failure("camera " + config_.id() + ": no feature named '" + name + "'");
        GError* error = nullptr;
        const char* v = arv_gc_feature_node_get_value_as_string(node, &error);
        if (error) return Status::failure("camera " + config_.id() + ": cannot read " + name + ": " + takeError(error));
        return std::string(v ? v : "");
    }

    Status doSetFeature(const std::string& name, const std::string& value) override
    {
        auto link = currentLink();
        if (!link) return Status::failure(lostMessage());
        return setFeatureOn(*link, name, value);
    }

    Result<CameraInfo> doInfo() override
    {
        auto link = currentLink();
        if (!link) return Status::failure(lostMessage());
        ArvCamera* camera = link->camera;
        CameraInfo info;
        info.backend = "aravis";
        // GLib forbids passing a set GError on: each read is checked before the
        // next, and the first that fails ends them (a device that stopped answering
        // would otherwise cost every read its GVCP timeout).
        GError* error = nullptr;
        using Read = const char* (*)(ArvCamera*, GError**);
        const std::pair<Read, std::string*> strings[] = {{arv_camera_get_vendor_name, &info.vendor},
                                                         {arv_camera_get_model_name, &info.model},
                                                         {arv_camera_get_device_serial_number, &info.serial}};
        for (const auto& [read, out] : strings) {
            const char* value = read(camera, &error);
            if (error) return Status::failure("camera " + config_.id() + ": " + takeError(error));
            *out = value ? value : "";
        }
        arv_camera_get_sensor_size(camera, &info.sensorWidth, &info.sensorHeight, &error);
        if (error) return Status::failure("camera " + config_.id() + ": " + takeError(error));
        info.address = config_.address.empty() ? deviceAddress(*link) : config_.address;
        return info;
    }

    RegionRules regionRules() const override { return rules_; }
    Roi configuredRegion() const override { return configured_; }

    /// Hands the region to the link worker, which applies it before the next
    /// trigger (every GVCP command of an active camera is the worker's, see the
    /// header); grab() waits for it.
    Result<Roi> doSetRegion(const Roi& aligned) override
    {
        if (!regionsUnsupported_.empty()) {
            fallBackToWholeFrames(
                fmt::format("camera {}: cannot deliver region {}: {}", config_.id(), aligned, regionsUnsupported_));
            return configured_;
        }
        {
            std::lock_guard lock(mutex_);
            wantedRegion_ = aligned;
        }
        wakeup_.notify_all();
        return aligned;
    }

  private:
    /// What the link worker knows of the device while the camera is active.
    enum class Health {
        Streaming, ///< answering; grabs pop frames
        Suspect,   ///< a grab timed out, a trigger failed or the heartbeat lost control: probing
        Lost,      ///< not answering: reopening with backoff
    };

    std::shared_ptr<Link> currentLink()
    {
        std::lock_guard lock(mutex_);
        return link_;
    }

    std::string lostMessage() const
    {
        return "camera " + config_.id() +
               ": not connected (lost and not reopened yet; while active the driver "
               "reconnects by itself, else clean up and configure again)";
    }

    /// What a grab needs before it triggers: the link and the region its frame must cover.
    struct GrabTicket {
        std::shared_ptr<Link> link; ///< null: `refusal` answers the grab
        Frame refusal;
        Roi region;
        double regionChangeMs = 0.0;
    };

    /// Waits, never past `deadline`, while the worker checks or restores the
    /// link or puts the region asked for on the device.
    GrabTicket awaitLink(milliseconds timeout, Clock::time_point deadline)
    {
        GrabTicket t;
        std::unique_lock lock(mutex_);
        wakeup_.wait_until(lock, deadline,
                           [&] { return health_ == Health::Streaming && wantedRegion_ == deviceRegion_; });
        const std::string id = "camera " + config_.id();
        if (health_ == Health::Suspect) {
            t.refusal = Frame::failed(FrameStatus::Timeout, id + ": no frame within " +
                                                                std::to_string(timeout.count()) + " ms: " + reason_ +
                                                                "; checking whether the camera still answers");
        } else if (health_ == Health::Lost) {
            t.refusal =
                Frame::failed(FrameStatus::Error,
                              id + ": lost (" + reason_ + "); " +
                                  (link_ || closing_ ? std::string("closing the old connection, then reconnecting")
                                                     : "reconnecting in the background, next attempt in " +
                                                           std::to_string(msUntil(clock(), nextAttempt_)) + " ms"));
        } else if (wantedRegion_ != deviceRegion_) {
            t.refusal = Frame::failed(FrameStatus::Timeout, fmt::format("{}: region {} not applied within {} ms", id,
                                                                        wantedRegion_, timeout.count()));
        } else {
            t.link = link_;
            t.region = deviceRegion_;
            if (reportChange_) t.regionChangeMs = regionChangeMs_;
            reportChange_ = false;
        }
        return t;
    }

    /// The next frame of `region`, or null at the deadline. In free run frames
    /// of the region before a change may still arrive: they go back to the pool.
    ArvBuffer* popFrameOf(Link& link, const Roi& region, Clock::time_point deadline)
    {
        for (;;) {
            ArvBuffer* buffer = arv_stream_timeout_pop_buffer(
                link.stream, static_cast<guint64>(msUntil(Clock::steady(), deadline)) * 1000);
            if (!buffer || arv_buffer_get_status(buffer) != ARV_BUFFER_STATUS_SUCCESS || regionOf(buffer) == region)
                return buffer;
            logger()->trace("camera {}: dropped frame {} of region {} (now {})", config_.id(),
                            arv_buffer_get_frame_id(buffer), regionOf(buffer), region);
            arv_stream_push_buffer(link.stream, buffer);
            if (Clock::steady().now() >= deadline) return nullptr;
        }
    }

    // --- device --------------------------------------------------------------

    /// Opens the device into `link` (no stream): by address directly, by serial through discovery.
    Status openDevice(Link& link)
    {
        GError* error = nullptr;
        const std::string id = config_.id();
        const std::string key = configPath() + (config_.address.empty() ? ".serial" : ".address");
        if (!config_.address.empty()) {
            const Result<std::string> route = interfaceAddressFor(config_.address);
            if (!route.ok()) return Status::failure(key + ": cannot reach '" + id + "': " + route.message());
            const std::string& local = route.value();
            GInetAddress* interfaceAddress = g_inet_address_new_from_string(local.c_str());
            GInetAddress* deviceAddress = g_inet_address_new_from_string(config_.address.c_str());
            ArvDevice* device = arv_gv_device_new(interfaceAddress, deviceAddress, &error);
            g_object_unref(interfaceAddress);
            g_object_unref(deviceAddress);
            if (!device)
                return Status::failure(key + ": no GigE Vision camera answers at '" + id + "' (from " + local +
                                       "): " + takeError(error, "device not found"));
            link.camera = arv_camera_new_with_device(device, &error); // takes its own reference
            g_object_unref(device);
        } else {
            link.camera = arv_camera_new(id.c_str(), &error);
        }
        if (!link.camera) {
            return Status::failure(key + ": no GigE Vision camera answers at '" + id +
                                   "': " + takeError(error, "device not found"));
        }
        if (!arv_camera_is_gv_device(link.camera))
            return Status::failure(configPath() + ": '" + id + "' is not a GigE Vision camera");
        g_signal_connect(arv_camera_get_device(link.camera), "control-lost", G_CALLBACK(&AravisCamera::onControlLost),
                         this);
        link.signalOwner = this;
        if (!config_.packetSocket)
            arv_camera_gv_set_stream_options(link.camera, ARV_GV_STREAM_OPTION_PACKET_SOCKET_DISABLED);
        if (config_.packetSize) {
            arv_camera_gv_set_packet_size(link.camera, *config_.packetSize, &error);
            if (error)
                return Status::failure(configPath() + ".packet_size: camera refused " +
                                       std::to_string(*config_.packetSize) + ": " + takeError(error));
        }
        for (const auto& [name, value] : config_.features) {
            if (Status s = setFeatureOn(link, name, value); !s)
                return Status::failure(configPath() + ".features." + name + ": " + s.message());
        }
        logger()->info("camera {}: opened ({} {}, serial {})", id,
                       safe(arv_camera_get_vendor_name(link.camera, nullptr)),
                       safe(arv_camera_get_model_name(link.camera, nullptr)),
                       safe(arv_camera_get_device_serial_number(link.camera, nullptr)));
        return Status::success();
    }

    /// Stops the worker (bounded: it finishes the GVCP command or reopen
    /// attempt in progress) and returns whether the device was answering.
    bool stopWorker()
    {
        if (worker_.running()) {
            const Stopwatch watch(clock());
            worker_.stop();
            logger()->debug("camera {}: link worker stopped in {} ms", config_.id(), wholeMs(watch));
        }
        std::lock_guard lock(mutex_);
        return health_ == Health::Streaming;
    }

    void closeAll()
    {
        std::shared_ptr<Link> link;
        bool healthy = false;
        {
            std::lock_guard lock(mutex_);
            link = std::move(link_);
            link_.reset();
            healthy = health_ == Health::Streaming;
        }
        if (!link) return;
        const Stopwatch watch(clock());
        stopStream(*link, /*talkToDevice=*/healthy);
        link.reset();
        logger()->debug("camera {}: closed in {} ms", config_.id(), wholeMs(watch));
    }

    static std::string safe(const char* s) { return s ? s : ""; }

    static std::string deviceAddress(const Link& link)
    {
        GSocketAddress* a = arv_gv_device_get_device_address(ARV_GV_DEVICE(arv_camera_get_device(link.camera)));
        if (!a) return {};
        GInetAddress* inet = g_inet_socket_address_get_address(G_INET_SOCKET_ADDRESS(a));
        gchar* s = g_inet_address_to_string(inet);
        std::string out = s ? s : "";
        g_free(s);
        return out;
    }

    static void onControlLost(ArvGvDevice* /*device*/, gpointer self)
    {
        // Called on Aravis' heartbeat thread: flag it and wake the worker (no lock taken here).
        auto* camera = static_cast<AravisCamera*>(self);
        camera->controlLost_ = true;
        camera->wakeup_.notify_all();
    }

    // --- link worker ---------------------------------------------------------

    /// The worker's loop: triggers, probes and reconnections, each a blocking
    /// GVCP exchange that must not hold up grab(). Ends when the stop is
    /// requested, after the exchange in progress (bounded by Aravis' GVCP timeouts).
    void linkWorker(std::stop_token stop)
    {
        std::unique_lock lock(mutex_);
        while (!stop.stop_requested()) {
            if (controlLost_.exchange(false) && health_ == Health::Streaming) {
                health_ = Health::Suspect;
                reason_ = "control of the device was lost (heartbeat)";
                logger()->warn("camera {}: {}", config_.id(), reason_);
            }
            switch (health_) {
            case Health::Streaming:
                if (wantedRegion_ != deviceRegion_) {
                    applyRegion(lock);
                } else if (triggerPending_) {
                    sendTrigger(lock);
                } else {
                    // Bounded wait: a heartbeat flag set without the lock is seen within 100 ms.
                    wakeup_.wait_for(lock, milliseconds(100));
                }
                break;
            case Health::Suspect:
                probe(lock);
                break;
            case Health::Lost:
                if (link_)
                    closeDeadLink(lock);
                else if (clock().now() < nextAttempt_)
                    // The back-off, on the driver's clock: only the stop ends it early.
                    clock().waitUntil(lock, wakeup_, nextAttempt_, [&] { return stop.stop_requested(); });
                else
                    reconnect(lock);
                break;
            }
        }
    }

    void sendTrigger(std::unique_lock<std::mutex>& lock)
    {
        triggerPending_ = false;
        const std::uint64_t trigger = triggersRequested_;
        auto link = link_;
        lock.unlock();
        GError* error = nullptr;
        arv_camera_software_trigger(link->camera, &error);
        // A command that timed out already is the probe's answer: no second GVCP timeout to learn it.
        const bool timedOut = error && g_error_matches(error, ARV_DEVICE_ERROR, ARV_DEVICE_ERROR_TIMEOUT);
        const std::string why = error ? takeError(error) : std::string();
        link.reset();
        lock.lock();
        if (why.empty()) return;
        logger()->debug("camera {}: trigger {} failed ({}{})", config_.id(), trigger, why,
                        timedOut ? ", timed out" : "");
        triggerFailed_ = trigger;
        triggerError_ = why;
        if (timedOut && health_ != Health::Lost) {
            declareLost("software trigger not acknowledged: " + why);
        } else if (health_ == Health::Streaming) {
            health_ = Health::Suspect;
            reason_ = "software trigger refused: " + why;
        }
        wakeup_.notify_all();
    }

    /// The device does not answer: reopen it after the first backoff step.
    void declareLost(const std::string& why)
    {
        logger()->warn("camera {}: not answering ({}); reconnecting", config_.id(), why);
        health_ = Health::Lost;
        reason_ = "not answering: " + why;
        backoff_ = config_.reconnectMin;
        nextAttempt_ = clock().now() + backoff_;
    }

    void probe(std::unique_lock<std::mutex>& lock)
    {
        auto link = link_;
        lock.unlock();
        GError* error = nullptr;
        guint32 value = 0;
        const bool answers =
            arv_device_read_register(arv_camera_get_device(link->camera), kBootstrapCcpRegister, &value, &error);
        const std::string why = answers ? std::string() : takeError(error);
        link.reset();
        lock.lock();
        if (answers) {
            logger()->debug("camera {}: answers ({}); streaming on", config_.id(), reason_);
            health_ = Health::Streaming;
        } else {
            declareLost(why);
        }
        wakeup_.notify_all();
    }

    /// One reopen attempt: a fresh link (device by address, settings, stream).
    void reconnect(std::unique_lock<std::mutex>& lock)
    {
        lock.unlock();
        auto fresh = std::make_shared<Link>();
        Status s = openDevice(*fresh);
        if (s) s = applyAll(*fresh, settings());
        if (s) s = startStream(*fresh);
        if (!s) fresh.reset(); // closed here, on the worker
        lock.lock();
        if (!s) {
            backoff_ = std::min(backoff_ * 2, config_.reconnectMax);
            nextAttempt_ = clock().now() + backoff_;
            reason_ = "reconnect failed: " + s.message();
            logger()->warn("camera {}: reconnect failed ({}); next attempt in {} ms", config_.id(), s.message(),
                           backoff_.count());
            return;
        }
        logger()->info("camera {}: reconnected", config_.id());
        link_ = std::move(fresh);
        deviceRegion_ = configured_; // applyAll put it back; the region asked for follows
        health_ = Health::Streaming;
        consecutiveTimeouts_ = 0;
        controlLost_ = false;
        triggerPending_ = false;
        backoff_ = milliseconds(0);
        wakeup_.notify_all();
    }

    /// Closes the connection to a device that stopped answering, before any
    /// reopen: Aravis then tells the device to stop streaming and to release
    /// control, each GVCP command waiting for its timeout (~10 s in all while
    /// the device is away). Done here, off the grab path, and before the new
    /// connection exists, so that the old one's release of control can never
    /// reach the camera once it is back and controlled by the new one.
    void closeDeadLink(std::unique_lock<std::mutex>& lock)
    {
        if (link_.use_count() > 1) {
            // A grab still waits on the old stream; it lets go within its timeout.
            wakeup_.wait_for(lock, milliseconds(20));
            return;
        }
        auto dead = std::move(link_);
        link_.reset();
        closing_ = true;
        lock.unlock();
        const Stopwatch watch(clock());
        dead.reset();
        const auto took = wholeMs(watch);
        lock.lock();
        closing_ = false;
        logger()->debug("camera {}: closed the connection that stopped answering in {} ms", config_.id(), took);
    }

    // --- regions (docs/camera.md "Regions per grab") ---------------------------

    /// Puts wantedRegion_ on the device (worker thread). A GVCP timeout means
    /// the device is gone (reconnect); any other failure is a refusal: whole
    /// frames from now on, after one warning.
    void applyRegion(std::unique_lock<std::mutex>& lock)
    {
        const Roi want = wantedRegion_;
        const Roi from = deviceRegion_;
        auto link = link_;
        lock.unlock();
        const Stopwatch watch(clock());
        Status s = changeRegion(*link, from, want);
        const double ms = watch.ms();
        link.reset();
        lock.lock();
        if (s.code() == StatusCode::Timeout) {
            declareLost("region change: " + s.message());
        } else if (!s) {
            fallBackToWholeFrames(fmt::format("camera {}: region {} refused: {}", config_.id(), want, s.message()));
            wantedRegion_ = deviceRegion_ = configured_;
        } else {
            deviceRegion_ = want;
            logger()->debug("camera {}: region {} -> {} in {:.1f} ms", config_.id(), from, want, ms);
        }
        regionChangeMs_ = ms;
        reportChange_ = true;
        wakeup_.notify_all();
    }

    /// From region `from` to `want` on a streaming device. A new size changes
    /// the payload, which GigE Vision cameras lock while acquiring (SFNC
    /// TLParamsLocked; Aravis' fake camera keeps sending the payload size it
    /// started with): acquisition is stopped around it. A move of the same size
    /// is written live where the offsets are not locked. A refused region is
    /// undone (the configured ROI put back) before the answer.
    Status changeRegion(Link& link, const Roi& from, const Roi& want)
    {
        const bool live = want.width == from.width && want.height == from.height && !isLocked(link, "OffsetX") &&
                          !isLocked(link, "OffsetY");
        GError* error = nullptr;
        if (!live) {
            arv_camera_stop_acquisition(link.camera, &error);
            if (error) return deviceFailure(error, "cannot stop acquisition");
        }
        Status s = writeRegion(link, from, want);
        if (s) s = checkRegion(link, want);
        if (!s && s.code() != StatusCode::Timeout) {
            auto now = readRegion(link);
            Status undone = now ? writeRegion(link, now.value(), configured_) : now.status();
            if (!undone)
                return undone.code() == StatusCode::Timeout
                           ? undone
                           : Status::failure(s.message() +
                                             "; and the configured ROI could not be restored: " + undone.message());
        }
        if (!live && s.code() != StatusCode::Timeout) {
            arv_camera_start_acquisition(link.camera, &error);
            if (error) return deviceFailure(error, "cannot restart acquisition");
        }
        return s;
    }

    /// The device holds `want` exactly and its payload fits the pool's buffers.
    Status checkRegion(Link& link, const Roi& want)
    {
        auto held = readRegion(link);
        if (!held) return held.status();
        if (held.value() != want)
            return Status::failure(StatusCode::NotAllowed, fmt::format("it became {}", held.value()));
        GError* error = nullptr;
        const guint payload = arv_camera_get_payload(link.camera, &error);
        if (error) return deviceFailure(error, "cannot read the payload size");
        if (payload > link.bufferBytes)
            return Status::failure(StatusCode::NotAllowed, "its payload of " + std::to_string(payload) +
                                                               " bytes exceeds the pool's buffers of " +
                                                               std::to_string(link.bufferBytes) + " bytes");
        return Status::success();
    }

    /// Writes the region in an order every intermediate state of which the
    /// device accepts (SFNC: OffsetX + Width <= the sensor's width at all
    /// times): per axis, a larger offset after the size, a smaller one before.
    /// Values the device holds already are not written.
    Status writeRegion(Link& link, const Roi& from, const Roi& want)
    {
        auto axis = [&](const char* offsetName, const char* sizeName, int offset0, int size0, int offset, int size) {
            Status s;
            if (offset > offset0) {
                if (size != size0) s = writeInteger(link, sizeName, size);
                if (s) s = writeInteger(link, offsetName, offset);
            } else {
                if (offset != offset0) s = writeInteger(link, offsetName, offset);
                if (s && size != size0) s = writeInteger(link, sizeName, size);
            }
            return s;
        };
        Status s = axis("OffsetX", "Width", from.x, from.width, want.x, want.width);
        if (s) s = axis("OffsetY", "Height", from.y, from.height, want.y, want.height);
        return s;
    }

    /// One integer feature, refused (NotAllowed) when it is missing or read-only.
    Status writeInteger(Link& link, const char* name, int value)
    {
        ArvGcFeatureNode* node = featureNode(link, name);
        if (!node || !arv_gc_feature_node_is_implemented(node, nullptr))
            return Status::failure(StatusCode::NotAllowed, std::string("the camera has no ") + name);
        if (arv_gc_feature_node_get_actual_access_mode(node) == ARV_GC_ACCESS_MODE_RO)
            return Status::failure(StatusCode::NotAllowed, std::string(name) + " is not writable");
        GError* error = nullptr;
        arv_camera_set_integer(link.camera, name, value, &error);
        if (error) return deviceFailure(error, std::string(name) + " = " + std::to_string(value) + " refused");
        return Status::success();
    }

    bool isLocked(Link& link, const char* name)
    {
        ArvGcFeatureNode* node = featureNode(link, name);
        return !node || arv_gc_feature_node_is_locked(node, nullptr);
    }

    Result<Roi> readRegion(Link& link)
    {
        Roi r;
        GError* error = nullptr;
        arv_camera_get_region(link.camera, &r.x, &r.y, &r.width, &r.height, &error);
        if (error) return deviceFailure(error, "cannot read the region");
        return r;
    }

    /// `what` and the error's text; code Timeout when the device did not answer, else NotAllowed.
    static Status deviceFailure(GError*& error, const std::string& what)
    {
        const StatusCode code = isTimeout(error) ? StatusCode::Timeout : StatusCode::NotAllowed;
        return Status::failure(code, what + ": " + takeError(error));
    }

    /// The configured ROI on the sensor, the device's increments and whether
    /// it can set a region at all (all four features present and writable).
    /// Read at configure: the same device is reopened on reconnection.
    Status readRegionSetup(Link& link)
    {
        auto held = readRegion(link);
        if (!held) return Status::failure("camera " + config_.id() + ": " + held.message());
        configured_ = held.value();
        GError* error = nullptr;
        auto axis = [&](const char* offsetName, const char* sizeName) {
            RegionAxisRules r;
            gint64 min = 0, max = 0;
            r.offsetInc = static_cast<int>(arv_camera_get_integer_increment(link.camera, offsetName, &error));
            if (!error) arv_camera_get_integer_bounds(link.camera, offsetName, &min, &max, &error);
            r.offsetMin = static_cast<int>(min);
            if (!error) r.sizeInc = static_cast<int>(arv_camera_get_integer_increment(link.camera, sizeName, &error));
            if (!error) arv_camera_get_integer_bounds(link.camera, sizeName, &min, &max, &error);
            r.sizeMin = static_cast<int>(std::max<gint64>(1, min));
            r.offsetInc = std::max(1, r.offsetInc);
            r.sizeInc = std::max(1, r.sizeInc);
            return r;
        };
        regionsUnsupported_.clear();
        for (const char* name : {"OffsetX", "OffsetY", "Width", "Height"}) {
            ArvGcFeatureNode* node = featureNode(link, name);
            if (!node || !arv_gc_feature_node_is_implemented(node, nullptr))
                regionsUnsupported_ = std::string("the camera has no ") + name;
            else if (arv_gc_feature_node_get_actual_access_mode(node) == ARV_GC_ACCESS_MODE_RO)
                regionsUnsupported_ = std::string(name) + " is not writable";
            if (!regionsUnsupported_.empty()) return Status::success();
        }
        rules_.x = axis("OffsetX", "Width");
        if (!error) rules_.y = axis("OffsetY", "Height");
        if (error) regionsUnsupported_ = "cannot read the region's increments: " + takeError(error);
        return Status::success();
    }

    /// Pixel format, ROI, exposure, gain and trigger, each read back.
    Status applyAll(Link& link, const CameraSettings& s)
    {
        ArvCamera* camera = link.camera;
        GError* error = nullptr;
        const std::string where = "camera " + config_.id() + ": ";

        arv_camera_set_pixel_format(camera, arvPixelFormat(s.pixelFormat), &error);
        if (error)
            return Status::failure(where + "pixel format " + std::string(enumName(s.pixelFormat)) +
                                   " refused: " + takeError(error));

        int x = s.roi.x, y = s.roi.y, w = s.roi.width, h = s.roi.height;
        int sensorW = 0, sensorH = 0;
        arv_camera_get_sensor_size(camera, &sensorW, &sensorH, &error);
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
        const Roi want{x, y, w, h};
        auto held = readRegion(link);
        Status written = held ? writeRegion(link, held.value(), want) : held.status();
        if (!written) return Status::failure(where + "ROI refused: " + written.message());
        held = readRegion(link);
        if (!held) return Status::failure(where + "cannot read the ROI back: " + held.message());
        if (held.value() != want)
            return Status::failure(
                fmt::format("{}ROI {} became {} (camera increments or limits)", where, want, held.value()));

        if (s.exposureUs) {
            if (arv_camera_is_exposure_auto_available(camera, nullptr))
                arv_camera_set_exposure_time_auto(camera, ARV_AUTO_OFF, nullptr);
            arv_camera_set_exposure_time(camera, *s.exposureUs, &error);
            if (error) return Status::failure(where + "exposure refused: " + takeError(error));
        }
        if (s.gainDb) {
            // SFNC's Gain is in dB; GainRaw is in device units and is not accepted as dB.
            if (!ARV_IS_GC_FLOAT(arv_device_get_feature(arv_camera_get_device(camera), "Gain")))
                return Status::failure(where + "the camera has no Gain feature in dB; set its raw gain by name "
                                               "under camera.driver.features instead of gain_db");
            if (arv_camera_is_gain_auto_available(camera, nullptr))
                arv_camera_set_gain_auto(camera, ARV_AUTO_OFF, nullptr);
            arv_camera_set_gain(camera, *s.gainDb, &error);
            if (error) return Status::failure(where + "gain refused: " + takeError(error));
        }

        if (s.trigger == TriggerMode::Software) {
            if (!arv_camera_is_software_trigger_supported(camera, nullptr))
                return Status::failure(where + "the camera has no software trigger");
            arv_camera_set_trigger(camera, "Software", &error);
        } else {
            arv_camera_clear_triggers(camera, &error);
            if (!error) arv_camera_set_acquisition_mode(camera, ARV_ACQUISITION_MODE_CONTINUOUS, &error);
        }
        if (error) return Status::failure(where + "trigger mode refused: " + takeError(error));
        return Status::success();
    }

    // --- stream --------------------------------------------------------------

    Status startStream(Link& link)
    {
        GError* error = nullptr;
        const std::string where = "camera " + config_.id() + ": ";
        const guint payload = arv_camera_get_payload(link.camera, &error);
        if (error) return Status::failure(where + "cannot read the payload size: " + takeError(error));
        link.stream = arv_camera_create_stream(link.camera, nullptr, nullptr, &error);
        if (!link.stream) return Status::failure(where + "cannot open the stream: " + takeError(error));
        if (ARV_IS_GV_STREAM(link.stream)) {
            g_object_set(link.stream, "socket-buffer", ARV_GV_STREAM_SOCKET_BUFFER_FIXED, "socket-buffer-size",
                         config_.socketBufferBytes, nullptr);
            if (config_.packetTimeoutMs)
                g_object_set(link.stream, "packet-timeout", static_cast<guint>(*config_.packetTimeoutMs * 1000),
                             nullptr);
            if (config_.frameRetentionMs)
                g_object_set(link.stream, "frame-retention", static_cast<guint>(*config_.frameRetentionMs * 1000),
                             nullptr);
        }
        // Sized once, from the configured ROI's payload: every region lies within it.
        link.bufferBytes = payload;
        link.home = std::make_shared<BufferHome>();
        link.home->stream = link.stream;
        for (int i = 0; i < config_.bufferCount; ++i)
            arv_stream_push_buffer(link.stream, arv_buffer_new_allocate(payload));
        arv_camera_start_acquisition(link.camera, &error);
        if (error) {
            std::string m = takeError(error);
            link.dropStream();
            return Status::failure(where + "cannot start acquisition: " + m);
        }
        logger()->debug("camera {}: streaming, payload {} bytes, {} buffers", config_.id(), payload,
                        config_.bufferCount);
        return Status::success();
    }

    void stopStream(Link& link, bool talkToDevice)
    {
        if (!link.stream) return;
        if (talkToDevice && link.camera) {
            GError* error = nullptr;
            arv_camera_stop_acquisition(link.camera, &error);
            if (error) logger()->warn("camera {}: stop acquisition: {}", config_.id(), takeError(error));
        }
        link.dropStream();
    }

    /// Frames finished before this grab are stale (the part may have moved since).
    static void drainStaleFrames(Link& link)
    {
        while (ArvBuffer* stale = arv_stream_try_pop_buffer(link.stream)) arv_stream_push_buffer(link.stream, stale);
    }

    Frame toFrame(const Link& link, ArvBuffer* buffer)
    {
        const auto id = arv_buffer_get_frame_id(buffer);
        const auto status = arv_buffer_get_status(buffer);
        auto giveBack = [home = link.home, buffer] { home->give(buffer); };
        if (status != ARV_BUFFER_STATUS_SUCCESS) {
            giveBack();
            Frame f =
                Frame::failed(FrameStatus::Incomplete, "camera " + config_.id() + ": frame " + std::to_string(id) +
                                                           " " + describeBufferStatus(status));
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
            m << "camera " << config_.id() << ": frame " << id << " has pixel format 0x" << std::hex << pf << std::dec
              << ", " << size << " bytes for " << w << "x" << h << " (expected " << enumName(want) << ")";
            Frame f = Frame::failed(FrameStatus::Error, m.str());
            f.frameId = id;
            return f;
        }
        // The view aliases Aravis' buffer: no copy (the buffer is ours until given back).
        cv::Mat view(h, w, cvTypeOf(want), const_cast<void*>(data));
        logger()->trace("camera {}: frame {} {}x{}", config_.id(), id, w, h);
        const Roi region = regionOf(buffer);
        Frame f = Frame::over(view, id, std::chrono::nanoseconds(arv_buffer_get_timestamp(buffer)), FrameStatus::Ok,
                              std::move(giveBack));
        f.region = region;
        f.payloadBytes = size;
        return f;
    }

    // --- features ------------------------------------------------------------

    Status setFeatureOn(Link& link, const std::string& name, const std::string& value)
    {
        ArvGcFeatureNode* node = featureNode(link, name);
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

    static ArvGcFeatureNode* featureNode(Link& link, const std::string& name)
    {
        ArvGc* gc = arv_device_get_genicam(arv_camera_get_device(link.camera));
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
        case ARV_GC_ACCESS_MODE_RO:
            info.access = "RO";
            break;
        case ARV_GC_ACCESS_MODE_WO:
            info.access = "WO";
            break;
        case ARV_GC_ACCESS_MODE_RW:
            info.access = "RW";
            break;
        default:
            info.access = "?";
            break;
        }
        if (info.type != "Command" && info.access != "WO") {
            GError* error = nullptr;
            const char* v = arv_gc_feature_node_get_value_as_string(feature, &error);
            info.value = error ? "(" + takeError(error) + ")" : safe(v);
        }
        out.push_back(std::move(info));
    }

    AravisConfig config_;
    std::mutex mutex_; // guards everything below except controlLost_
    std::condition_variable wakeup_;
    std::shared_ptr<Link> link_;
    Health health_ = Health::Streaming;
    std::string reason_;   ///< why the link is suspect or lost
    bool closing_ = false; ///< the worker is closing the connection that stopped answering
    bool triggerPending_ = false;
    std::uint64_t triggersRequested_ = 0;
    std::uint64_t triggerFailed_ = 0; ///< the last trigger the device did not acknowledge
    std::string triggerError_;
    std::atomic<bool> controlLost_{false};
    int consecutiveTimeouts_ = 0;
    milliseconds backoff_{0};
    Clock::time_point nextAttempt_{};

    // Regions: set at configure (and by setSettings while inactive), fixed while active.
    RegionRules rules_;
    Roi configured_;                 ///< the configured ROI on the sensor (the whole sensor unless roi is set)
    std::string regionsUnsupported_; ///< why this device cannot set a region; empty when it can
    // Guarded by mutex_:
    Roi wantedRegion_;            ///< the region setRegion() asked for
    Roi deviceRegion_;            ///< the region the device holds: frames of another one are stale
    double regionChangeMs_ = 0.0; ///< how long the last change took, for the next grab
    bool reportChange_ = false;

    Worker worker_; ///< linkWorker() while active; last, so it ends before what it uses
};

} // namespace

std::unique_ptr<Camera> makeAravisCamera(const ConfigNode& driver, Clock& clock)
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
    return std::make_unique<AravisCamera>(driver.path(), parseCameraSettings(driver), std::move(c), clock);
}

} // namespace hg::drivers
