// The simulated camera (`camera.driver.backend: sim`): the station's twin of a
// real camera, used by the simulated line and in tests. Each grab asks the pose
// source where the fixture is, poses the camera through the station
// calibration (camera_from_part = camera_from_fixture * fixture motion,
// docs/contracts.md §2) and renders the backlit silhouette of the part under test, as
// it is seated in the nest (setSeat, docs/daemon.md "Seating": camera_from_part
// · seat), with the hg::sim renderer, into a pool slot cropped to the ROI, or
// to the region setRegion() asked for (docs/camera.md "Regions per grab"; the
// fault switch refuse_region stands for a camera that cannot set one).
//
// Features (for `hullgauge camera`): ExposureTime (µs) and Gain (dB) are held
// and read back but do not change the image; Part switches the part under
// test and Fault the fault switch (simulation.h); PixelFormat, OffsetX/Y,
// Width/Height, SensorWidth/Height are read-only. Without parts (`hullgauge
// camera` on a station file alone) the twin shows the bare back light, or the
// `target`; without a pose source it renders at the zero pose.
//
// The twin's optics can be imperfect and age as a station does (docs/camera.md,
// "Optics of the simulated camera", "Aging"): a back light falling off towards
// the corners, dust specks on it, a halo eroding the silhouette, and, counted
// in cycles (countCycle, a new part in the nest), a panel that dims, gathers
// dust, a lens that defocuses and a halo that grows. The part `none` shows the
// empty fixture, what a flat-field reference is taken from.
//
// Two optional keys make the twin stand for a physical rig in calibration:
// `target` adds a backlit chessboard carried by the fixture as the part named
// "target", and `truth_station` names a station file whose camera and fixture
// geometry the twin renders with instead of the station's own (nominal) one,
// so `hullgauge calibrate run` has something true to recover.
#include "hullgauge/align/alignment.h"
#include "hullgauge/calib/target.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/file_kind.h"
#include "hullgauge/common/format.h"
#include "hullgauge/common/log.h"
#include "hullgauge/drivers/simulation.h"
#include "hullgauge/geometry/station.h"
#include "hullgauge/geometry/transform.h"
#include "hullgauge/model/primitives.h"
#include "hullgauge/sim/renderer.h"

#include "sim_camera.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <mutex>
#include <opencv2/core.hpp>
#include <random>
#include <sstream>
#include <tuple>

namespace hg::drivers {
namespace {

using std::chrono::milliseconds;

/// Name of the part the `target` key adds.
constexpr const char* kTargetPart = "target";
/// Thickness of a dark square (mm). Seen obliquely a square's side faces
/// widen its outline by thickness x tan(angle): 0.01 mm keeps that far below
/// a corner detector's precision, while the box stays a closed solid the
/// renderer takes as it is.
constexpr double kSquareThicknessMm = 0.01;

/// A backlit chessboard: a clear plate carrying opaque squares, as a
/// calibration target for back light is made. COLS x ROWS inner corners give
/// (COLS+1) x (ROWS+1) squares; the square at a board corner, on the side of
/// inner corner 0, is dark, and dark squares touch only at their corners, as
/// on a printed board. Target frame as calib::TargetSpec: origin on the first
/// inner corner, x along the columns, y along the rows, the squares' face
/// towards +z at z = 0 (the corners lie on it). Around the squares the plate is
/// clear: the back light is the board's white margin.
model::TriangleMesh backlitChessboard(const calib::TargetSpec& spec)
{
    model::TriangleMesh board;
    const double s = spec.squareMm;
    for (int j = 0; j <= spec.rows; ++j)
        for (int i = 0; i <= spec.cols; ++i) {
            if ((i + j) % 2 != 0) continue;
            board.append(model::makeBox({(i - 1) * s, (j - 1) * s, -kSquareThicknessMm}, {i * s, j * s, 0.0}));
        }
    return board;
}

/// `camera.driver.target`: the chessboard and where it sits on the turntable.
model::TriangleMesh parseTarget(const ConfigNode& node)
{
    require(node.isMap(), node, "expected {pattern: chessboard:COLSxROWS:SQUARE_MM, part_from_target: {R, t}}");
    node.allowOnlyKeys({"pattern", "part_from_target"});
    auto patternNode = node["pattern"];
    calib::TargetSpec spec;
    try {
        spec = calib::TargetSpec::parse(patternNode.asString(), patternNode.path());
    } catch (const InputError& e) {
        patternNode.fail(e.problem());
    }
    if (spec.kind != calib::TargetKind::Chessboard)
        patternNode.fail("the simulated camera renders chessboard targets only (chessboard:COLSxROWS:SQUARE_MM)");
    auto pose = node["part_from_target"];
    pose.allowOnlyKeys({"R", "t"});
    auto rNode = pose["R"];
    const geometry::Mat3 R = rNode.asMatrix3();
    if (!geometry::isRotation(R, 1e-4)) rNode.fail("not a rotation matrix (must be orthonormal with determinant +1)");
    model::TriangleMesh board = backlitChessboard(spec);
    board.transform(geometry::nearestRotation(R), pose["t"].asVector3());
    return board;
}

/// `camera.driver.truth_station`: the rig as it really is, relative to the station file.
geometry::Station loadTruthStation(const ConfigNode& node, const geometry::Station& nominal)
{
    std::filesystem::path file = node.asString();
    if (file.is_relative()) file = std::filesystem::path(node.file()).parent_path() / file;
    if (auto problem = notARegularFile(file); !problem.empty()) node.fail(problem + ": " + file.string());
    geometry::Station truth = geometry::loadStation(file);
    if (truth.camera.imageSize != nominal.camera.imageSize)
        node.fail("the camera of " + file.string() + " has another image size than camera.image_size");
    return truth;
}

/// `camera.driver.aging` (docs/camera.md, "Aging"): every `perCycles` cycles
/// the optics age by one step.
struct AgingConfig {
    std::uint64_t perCycles = 0; ///< 0: the optics never age
    double dim = 0.0;            ///< fraction the back light loses per step (multiplicative)
    int dustSpecks = 0;          ///< new specks per step
    double defocusPx = 0.0;      ///< blur σ added per step
    double haloPx = 0.0;         ///< halo added per step
    std::uint64_t seed = 1;      ///< the specks' draws
    double speckRadiusMin = 1.5, speckRadiusMax = 4.0;
    double speckDepthMin = 0.2, speckDepthMax = 0.5;
};

/// The most dust specks the back light gathers by aging: beyond them the panel is
/// long past cleaning, and every grab's shading stays cheap.
constexpr std::size_t kMaxAgedSpecks = 4096;
/// Aging stops growing the blur and the halo at the keys' upper bounds.
constexpr double kMaxBlurSigmaPx = 50.0;
constexpr double kMaxHaloPx = 10.0;

struct SimConfig {
    sim::RenderOptions render;
    AgingConfig aging;
    int bufferCount = 4;
    std::string initialPart;
    SimulatedCameraFault fault = SimulatedCameraFault::None;
};

/// `camera.driver.dust`: specks on the back light, centred on the sensor.
std::vector<sim::DustSpeck> parseDust(const ConfigNode& node, cv::Size sensor)
{
    std::vector<sim::DustSpeck> out;
    for (const auto& item : node.items()) {
        require(item.isMap(), item, "expected a speck {x, y, radius_px, depth}");
        item.allowOnlyKeys({"x", "y", "radius_px", "depth"});
        sim::DustSpeck d;
        d.x = item["x"].asDoubleIn(-0.5, sensor.width - 0.5);
        d.y = item["y"].asDoubleIn(-0.5, sensor.height - 0.5);
        d.radiusPx = item["radius_px"].asDoubleIn(0.5, 500.0);
        d.depth = item["depth"].asDoubleIn(0.0, 1.0);
        out.push_back(d);
    }
    return out;
}

/// A `[min, max]` within [lo, hi].
std::pair<double, double> parseRange(const ConfigNode& node, double lo, double hi)
{
    const auto v = node.asDoubles(2);
    if (!(v[0] >= lo && v[0] <= v[1] && v[1] <= hi))
        node.fail("expected [min, max] with " + formatNumber(lo) + " <= min <= max <= " + formatNumber(hi) +
                  ", found [" + formatNumber(v[0]) + ", " + formatNumber(v[1]) + "]");
    return {v[0], v[1]};
}

/// `camera.driver.aging` (docs/camera.md, "Aging").
AgingConfig parseAging(const ConfigNode& node)
{
    require(node.isMap(), node, "expected {per_cycles, dim, dust_specks, defocus_px, halo_px}");
    node.allowOnlyKeys(
        {"per_cycles", "dim", "dust_specks", "defocus_px", "halo_px", "seed", "speck_radius_px", "speck_depth"});
    AgingConfig a;
    a.perCycles = static_cast<std::uint64_t>(node["per_cycles"].asIntIn(1, 1000000000));
    if (auto n = node.optional("dim")) a.dim = n->asDoubleIn(0.0, 0.5);
    if (auto n = node.optional("dust_specks")) a.dustSpecks = static_cast<int>(n->asIntIn(0, 100));
    if (auto n = node.optional("defocus_px")) a.defocusPx = n->asDoubleIn(0.0, 5.0);
    if (auto n = node.optional("halo_px")) a.haloPx = n->asDoubleIn(0.0, 2.0);
    if (auto n = node.optional("seed")) a.seed = static_cast<std::uint64_t>(n->asIntIn(0, 1LL << 62));
    if (auto n = node.optional("speck_radius_px"))
        std::tie(a.speckRadiusMin, a.speckRadiusMax) = parseRange(*n, 0.5, 500.0);
    if (auto n = node.optional("speck_depth")) std::tie(a.speckDepthMin, a.speckDepthMax) = parseRange(*n, 0.0, 1.0);
    return a;
}

/// A uniform draw in [lo, hi] from the generator's raw output: the same on every standard library.
double uniform(std::mt19937_64& rng, double lo, double hi)
{
    const double u = static_cast<double>(rng() >> 11) * 0x1.0p-53;
    return lo + (hi - lo) * u;
}

/// The configured optics aged by `steps` (docs/camera.md, "Aging"); `drawn` holds the
/// specks aging added so far, extended from `rng` to the specks `steps` call for.
sim::RenderOptions agedOptics(const sim::RenderOptions& base, const AgingConfig& aging, std::uint64_t steps,
                              cv::Size sensor, std::mt19937_64& rng, std::vector<sim::DustSpeck>& drawn)
{
    sim::RenderOptions o = base;
    o.backgroundLevel = base.backgroundLevel * std::pow(1.0 - aging.dim, static_cast<double>(steps));
    o.blurSigmaPx = std::min(kMaxBlurSigmaPx, base.blurSigmaPx + static_cast<double>(steps) * aging.defocusPx);
    o.haloPx = std::min(kMaxHaloPx, base.haloPx + static_cast<double>(steps) * aging.haloPx);
    const auto wanted = std::min<std::uint64_t>(kMaxAgedSpecks, steps * static_cast<std::uint64_t>(aging.dustSpecks));
    while (drawn.size() < wanted) {
        sim::DustSpeck speck;
        speck.x = uniform(rng, 0.0, sensor.width - 1.0);
        speck.y = uniform(rng, 0.0, sensor.height - 1.0);
        speck.radiusPx = uniform(rng, aging.speckRadiusMin, aging.speckRadiusMax);
        speck.depth = uniform(rng, aging.speckDepthMin, aging.speckDepthMax);
        drawn.push_back(speck);
    }
    o.dust.insert(o.dust.end(), drawn.begin(), drawn.end());
    return o;
}

/// Rows a frame with missing packets lacks: every fourth band of 8 rows reads 0.
void dropPackets(cv::Mat& image)
{
    for (int y = 0; y < image.rows; y += 32) image.rowRange(y, std::min(y + 8, image.rows)).setTo(0);
}

/// Preallocated frame slots; a slot is busy while a Frame views it.
struct SlotPool {
    std::mutex mutex;
    std::vector<cv::Mat> slots;
    std::vector<bool> busy;

    std::optional<std::size_t> take()
    {
        std::lock_guard lock(mutex);
        for (std::size_t i = 0; i < busy.size(); ++i)
            if (!busy[i]) {
                busy[i] = true;
                return i;
            }
        return std::nullopt;
    }
    void give(std::size_t i)
    {
        std::lock_guard lock(mutex);
        busy[i] = false;
    }
};

class SimCameraImpl final : public Camera, public SimCameraControl {
  public:
    SimCameraImpl(std::string configPath, CameraSettings settings, SimConfig config, geometry::Station station,
                  CameraEnvironment& environment, Clock& clock)
        : Camera(std::move(configPath), std::move(settings), clock), config_(std::move(config)),
          station_(std::move(station)), poseSource_(std::move(environment.poseSource)), fault_(config_.fault),
          optics_(config_.render), agingRng_(config_.aging.seed)
    {
        for (auto& [name, mesh] : environment.parts)
            renderers_.emplace_back(name, std::make_shared<const sim::SilhouetteRenderer>(
                                              std::vector<model::TriangleMesh>{std::move(mesh)}));
        current_ = find(config_.initialPart);
        partName_ = config_.initialPart;
    }

    Status setPart(const std::string& name) override
    {
        auto r = find(name);
        if (!r && name != kEmptyFixture) {
            std::string known;
            for (const auto& n : partNames()) known += (known.empty() ? "" : ", ") + n;
            return Status::failure("sim camera: no part named '" + name + "' (known: " + known + ")");
        }
        std::lock_guard lock(mutex_);
        current_ = std::move(r);
        partName_ = name;
        log::category("camera")->info("sim camera: part under test is now '{}'", name);
        return Status::success();
    }

    std::string part() const override
    {
        std::lock_guard lock(mutex_);
        return partName_;
    }

    std::vector<std::string> partNames() const override
    {
        std::vector<std::string> out;
        for (const auto& [n, _] : renderers_) out.push_back(n);
        out.emplace_back(kEmptyFixture);
        return out;
    }

    void showMesh(const std::string& name, std::shared_ptr<const model::TriangleMesh> mesh) override
    {
        std::lock_guard lock(mutex_);
        if (shownMesh_ != mesh) {
            shownRenderer_ = std::make_shared<const sim::SilhouetteRenderer>(std::vector<model::TriangleMesh>{*mesh});
            shownMesh_ = std::move(mesh);
        }
        if (partName_ != name) log::category("camera")->info("sim camera: part under test is now '{}'", name);
        current_ = shownRenderer_;
        partName_ = name;
    }

    void setSeat(const geometry::RigidTransform& seat) override
    {
        std::lock_guard lock(mutex_);
        seat_ = seat;
    }

    void injectFault(SimulatedCameraFault fault) override
    {
        std::lock_guard lock(mutex_);
        fault_ = fault;
        log::category("camera")->info("sim camera: fault switch {}", enumName(fault));
    }

    void countCycle() override
    {
        std::lock_guard lock(mutex_);
        ++cycles_;
        const AgingConfig& aging = config_.aging;
        if (aging.perCycles == 0 || cycles_ / aging.perCycles == agingSteps_) return;
        agingSteps_ = cycles_ / aging.perCycles;
        optics_ = agedOptics(config_.render, aging, agingSteps_, station_.camera.imageSize, agingRng_, agedDust_);
        log::category("camera")->info("sim camera: aged {} steps in {} cycles: back light {:.4f}, blur {:.3f} px, "
                                      "halo {:.3f} px, {} dust specks",
                                      agingSteps_, cycles_, optics_.backgroundLevel, optics_.blurSigmaPx,
                                      optics_.haloPx, optics_.dust.size());
    }

    SimulatedOptics optics() const override
    {
        std::lock_guard lock(mutex_);
        SimulatedOptics out;
        out.cycles = cycles_;
        out.agingSteps = agingSteps_;
        out.backgroundLevel = optics_.backgroundLevel;
        out.vignetting = optics_.vignetting;
        out.blurSigmaPx = optics_.blurSigmaPx;
        out.haloPx = optics_.haloPx;
        for (const auto& d : optics_.dust) out.dust.emplace_back(d.x, d.y, d.radiusPx, d.depth);
        return out;
    }

    void resetAging() override
    {
        std::lock_guard lock(mutex_);
        cycles_ = 0;
        agingSteps_ = 0;
        optics_ = config_.render;
        agingRng_.seed(config_.aging.seed);
        agedDust_.clear();
        log::category("camera")->info("sim camera: aging reset, the optics as configured");
    }

  protected:
    HookResult onConfigure() override
    {
        allowRegions();
        return doApplySettings(settings());
    }

    Status doApplySettings(const CameraSettings& s) override
    {
        const cv::Size sensor = station_.camera.imageSize;
        const cv::Rect roi =
            s.roi.isFullSensor() ? cv::Rect({0, 0}, sensor) : cv::Rect(s.roi.x, s.roi.y, s.roi.width, s.roi.height);
        if ((roi & cv::Rect({0, 0}, sensor)) != roi) {
            std::ostringstream m;
            m << "sim camera: ROI [" << roi.x << ", " << roi.y << ", " << roi.width << ", " << roi.height
              << "] exceeds the " << sensor.width << "x" << sensor.height << " image of the station";
            return Status::failure(m.str());
        }
        roi_ = roi;
        if (s.exposureUs) exposureUs_ = *s.exposureUs;
        if (s.gainDb) gainDb_ = *s.gainDb;
        return Status::success();
    }

    HookResult onActivate() override
    {
        {
            std::lock_guard lock(mutex_);
            region_ = roi_;
        }
        // Sized once for the configured ROI: every region lies within it (alignRegion).
        pool_ = std::make_shared<SlotPool>();
        for (int i = 0; i < config_.bufferCount; ++i)
            pool_->slots.emplace_back(roi_.size(), cvTypeOf(settings().pixelFormat));
        pool_->busy.assign(pool_->slots.size(), false);
        return Status::success();
    }

    HookResult onDeactivate() override
    {
        pool_.reset(); // slots still viewed by frames stay alive with them
        return Status::success();
    }

    void onCleanup() override { pool_.reset(); }

    Frame doGrab(milliseconds timeout) override
    {
        std::shared_ptr<const sim::SilhouetteRenderer> renderer;
        PoseSource source;
        SimulatedCameraFault fault;
        geometry::RigidTransform seat;
        cv::Rect region;
        sim::RenderOptions optics;
        {
            std::lock_guard lock(mutex_);
            optics = optics_;
            region = region_;
            renderer = current_;
            seat = seat_;
            source = poseSource_;
            fault = fault_;
            if (fault_ == SimulatedCameraFault::Dropped) fault_ = SimulatedCameraFault::None;
        }
        if (fault == SimulatedCameraFault::Timeout || fault == SimulatedCameraFault::Dropped) {
            // A silent camera costs the caller its whole timeout, as a real one does (on the driver's clock).
            clock().sleepUntil(clock().now() + timeout, [] { return false; });
            if (fault == SimulatedCameraFault::Dropped) ++frameCount_;
            return Frame::failed(FrameStatus::Timeout, "sim camera: no frame within " +
                                                           std::to_string(timeout.count()) + " ms (fault switch " +
                                                           std::string(enumName(fault)) + ")");
        }
        const auto pose = source ? source() : std::optional<geometry::FixturePose>(geometry::FixturePose{});
        if (!pose)
            return Frame::failed(FrameStatus::Timeout, "sim camera: the fixture pose is unknown (moving or faulted)");
        auto slot = pool_->take();
        if (!slot)
            return Frame::failed(FrameStatus::Timeout, "sim camera: all " + std::to_string(config_.bufferCount) +
                                                           " buffers are held by the caller");
        // The region's image, continuous, in the front of the slot (which holds the configured ROI).
        cv::Mat out(region.size(), pool_->slots[*slot].type(), pool_->slots[*slot].data);
        render(renderer.get(), optics, *pose, seat, region, out);
        const auto id = ++frameCount_;
        const bool incomplete = fault == SimulatedCameraFault::Incomplete;
        if (incomplete) dropPackets(out);
        auto pool = pool_;
        const std::size_t index = *slot;
        Frame frame = Frame::over(
            out, id, clock().now().time_since_epoch(), incomplete ? FrameStatus::Incomplete : FrameStatus::Ok,
            [pool, index] { pool->give(index); },
            incomplete ? "sim camera: packets missing (fault switch incomplete)" : "");
        frame.region = Roi{region.x, region.y, region.width, region.height};
        frame.payloadBytes = out.total() * out.elemSize();
        return frame;
    }

    RegionRules regionRules() const override { return {}; }
    Roi configuredRegion() const override { return Roi{roi_.x, roi_.y, roi_.width, roi_.height}; }

    /// The twin sets any region at once (increments of 1); the fault switch
    /// refuse_region stands for a camera whose offset and size features are not writable.
    Result<Roi> doSetRegion(const Roi& aligned) override
    {
        std::lock_guard lock(mutex_);
        if (fault_ == SimulatedCameraFault::RefuseRegion) {
            fallBackToWholeFrames(fmt::format("sim camera: region {} refused: OffsetX, OffsetY, Width and Height are "
                                              "not writable (fault switch refuse_region)",
                                              aligned));
            region_ = roi_;
            return configuredRegion();
        }
        region_ = cv::Rect(aligned.x, aligned.y, aligned.width, aligned.height);
        return aligned;
    }

    /// The part at `pose`, seated so (or the bare back light without a part) into `out`, cropped to `region`.
    void render(const sim::SilhouetteRenderer* renderer, sim::RenderOptions options, const geometry::FixturePose& pose,
                const geometry::RigidTransform& seat, const cv::Rect& region, cv::Mat& out) const
    {
        const PixelFormat format = settings().pixelFormat;
        options.bitDepth = format == PixelFormat::Mono8 ? 8 : 16;
        options.seed = config_.render.seed + frameCount_; // fresh, reproducible noise per frame
        const geometry::CameraModel camera = align::seatedCamera(station_.cameraAt(pose), seat);
        // Only the region is rendered: a whole sensor's float images per grab
        // would set the daemon's memory peak (docs/daemon.md "Memory").
        const cv::Mat image = (renderer ? *renderer : backlight_).render(camera, options, region);
        if (format == PixelFormat::Mono12)
            image.convertTo(out, CV_16U, 1.0 / 16.0); // 12 significant bits
        else
            image.copyTo(out);
    }

    Result<std::vector<FeatureInfo>> doListFeatures() override
    {
        std::vector<FeatureInfo> out;
        for (const char* name : {"Part", "Fault", "PixelFormat", "ExposureTime", "Gain", "OffsetX", "OffsetY", "Width",
                                 "Height", "SensorWidth", "SensorHeight"}) {
            FeatureInfo f;
            f.name = name;
            const bool writable = f.name == "Part" || f.name == "Fault" || f.name == "ExposureTime" || f.name == "Gain";
            f.type = f.name == "Part" || f.name == "Fault" || f.name == "PixelFormat" ? "Enumeration"
                     : f.name == "ExposureTime" || f.name == "Gain"                   ? "Float"
                                                                                      : "Integer";
            f.access = writable ? "RW" : "RO";
            f.value = doGetFeature(name).value();
            out.push_back(std::move(f));
        }
        return out;
    }

    Result<std::string> doGetFeature(const std::string& name) override
    {
        auto num = [](double v) {
            std::ostringstream s;
            s << v;
            return s.str();
        };
        if (name == "Part") return part();
        if (name == "Fault") {
            std::lock_guard lock(mutex_);
            return std::string(enumName(fault_));
        }
        if (name == "PixelFormat") return std::string(enumName(settings().pixelFormat));
        if (name == "ExposureTime") return num(exposureUs_);
        if (name == "Gain") return num(gainDb_);
        const cv::Rect region = currentRegion();
        if (name == "OffsetX") return std::to_string(region.x);
        if (name == "OffsetY") return std::to_string(region.y);
        if (name == "Width") return std::to_string(region.width);
        if (name == "Height") return std::to_string(region.height);
        if (name == "SensorWidth") return std::to_string(station_.camera.imageSize.width);
        if (name == "SensorHeight") return std::to_string(station_.camera.imageSize.height);
        return Status::failure("sim camera: no feature named '" + name + "'");
    }

    Status doSetFeature(const std::string& name, const std::string& value) override
    {
        if (name == "Part") return setPart(value);
        if (name == "Fault") {
            auto fault = parseEnum<SimulatedCameraFault>(value);
            if (!fault)
                return Status::failure(StatusCode::NotAllowed, "sim camera: Fault is one of " +
                                                                   enumNameList<SimulatedCameraFault>() + "; got '" +
                                                                   value + "'");
            injectFault(*fault);
            return Status::success();
        }
        if (name == "ExposureTime" || name == "Gain") {
            char* end = nullptr;
            const double v = std::strtod(value.c_str(), &end);
            if (end == value.c_str() || *end != '\0' || v < 0)
                return Status::failure("sim camera: " + name + " needs a non-negative number, got '" + value + "'");
            (name == "Gain" ? gainDb_ : exposureUs_) = v;
            return Status::success();
        }
        if (doGetFeature(name).ok())
            return Status::failure("sim camera: " + name + " is read-only here; set it in camera.driver");
        return Status::failure("sim camera: no feature named '" + name + "'");
    }

    Result<CameraInfo> doInfo() override
    {
        CameraInfo info;
        info.backend = "sim";
        info.vendor = "hullgauge";
        info.model = "simulated backlit camera";
        info.serial = "SIM";
        info.address = "sim";
        info.sensorWidth = station_.camera.imageSize.width;
        info.sensorHeight = station_.camera.imageSize.height;
        return info;
    }

  private:
    /// The region grabs deliver: the configured ROI until setRegion() changes it while active.
    cv::Rect currentRegion() const
    {
        std::lock_guard lock(mutex_);
        return state() == LifecycleState::Active ? region_ : roi_;
    }

    std::shared_ptr<const sim::SilhouetteRenderer> find(const std::string& name) const
    {
        for (const auto& [n, r] : renderers_)
            if (n == name) return r;
        return nullptr;
    }

    SimConfig config_;
    geometry::Station station_;
    const sim::SilhouetteRenderer backlight_{}; ///< nothing in front of the back light
    std::vector<std::pair<std::string, std::shared_ptr<const sim::SilhouetteRenderer>>> renderers_;
    mutable std::mutex mutex_; // guards current_, partName_, poseSource_, fault_, seat_, region_, the aging
    std::shared_ptr<const sim::SilhouetteRenderer> current_;
    std::string partName_;
    std::shared_ptr<const model::TriangleMesh> shownMesh_; ///< showMesh's last mesh and its renderer
    std::shared_ptr<const sim::SilhouetteRenderer> shownRenderer_;
    PoseSource poseSource_;
    SimulatedCameraFault fault_;
    geometry::RigidTransform seat_; ///< nominal_from_part of the part in the nest
    cv::Rect roi_;                  ///< the configured ROI on the sensor (the whole sensor when unset)
    cv::Rect region_;               ///< the region grabs deliver while active (setRegion), within roi_
    double exposureUs_ = 10000.0;
    double gainDb_ = 0.0;
    std::shared_ptr<SlotPool> pool_;
    std::uint64_t frameCount_ = 0;
    // The aging (docs/camera.md, "Aging"): cycles counted, steps taken, the optics now.
    std::uint64_t cycles_ = 0;
    std::uint64_t agingSteps_ = 0;
    sim::RenderOptions optics_; ///< config_.render aged by agingSteps_
    std::mt19937_64 agingRng_;
    std::vector<sim::DustSpeck> agedDust_; ///< the specks aging added, in the order drawn
};

} // namespace

std::unique_ptr<Camera> makeSimCamera(const ConfigNode& root, CameraEnvironment& environment, Clock& clock)
{
    const ConfigNode driver = root["camera"]["driver"];
    driver.allowOnlyKeys({"backend",      "pixel_format",  "exposure_us", "gain_db", "roi",
                          "trigger",      "buffer_count",  "part",        "fault",   "background_level",
                          "object_level", "blur_sigma_px", "noise_sigma", "seed",    "sub_scanlines",
                          "vignetting",   "dust",          "halo_px",     "aging",   "target",
                          "truth_station"});
    // Initialised, never assigned: a Station's document shares its YAML nodes
    // with `root`, and assigning one over the other would overwrite `root`.
    const auto truthNode = driver.optional("truth_station");
    geometry::Station station =
        truthNode ? loadTruthStation(*truthNode, geometry::parseStation(root)) : geometry::parseStation(root);
    auto& parts = environment.parts;
    SimConfig c;
    if (auto n = driver.optional("buffer_count")) c.bufferCount = static_cast<int>(n->asIntIn(1, 64));
    if (auto n = driver.optional("background_level")) c.render.backgroundLevel = n->asDoubleIn(0.0, 1.0);
    if (auto n = driver.optional("object_level")) c.render.objectLevel = n->asDoubleIn(0.0, 1.0);
    if (auto n = driver.optional("blur_sigma_px")) c.render.blurSigmaPx = n->asDoubleIn(0.0, 50.0);
    if (auto n = driver.optional("noise_sigma")) c.render.noiseSigma = n->asDoubleIn(0.0, 65535.0);
    if (auto n = driver.optional("seed")) c.render.seed = static_cast<std::uint64_t>(n->asIntIn(0, 1LL << 62));
    if (auto n = driver.optional("sub_scanlines")) c.render.subScanlines = static_cast<int>(n->asIntIn(4, 256));
    if (auto n = driver.optional("vignetting")) c.render.vignetting = n->asDoubleIn(0.0, 0.95);
    if (auto n = driver.optional("dust")) c.render.dust = parseDust(*n, station.camera.imageSize);
    if (auto n = driver.optional("halo_px")) c.render.haloPx = n->asDoubleIn(0.0, kMaxHaloPx);
    if (auto n = driver.optional("aging")) c.aging = parseAging(*n);
    if (auto n = driver.optional("fault")) c.fault = n->asEnum<SimulatedCameraFault>("fault");
    if (auto n = driver.optional("target")) {
        const bool taken =
            std::any_of(parts.begin(), parts.end(), [](const auto& p) { return p.first == kTargetPart; });
        if (taken) n->fail("a part is already named 'target'");
        parts.emplace_back(kTargetPart, parseTarget(*n));
    }
    for (const auto& [name, mesh] : parts)
        if (name == kEmptyFixture)
            throw ArgumentError("sim camera: a part is named '" + name + "', the name of the empty fixture");
    auto partNode = driver.optional("part");
    if (partNode || !parts.empty()) {
        c.initialPart = partNode ? partNode->asString() : parts.front().first;
        const bool known =
            c.initialPart == kEmptyFixture ||
            std::any_of(parts.begin(), parts.end(), [&](const auto& p) { return p.first == c.initialPart; });
        if (!known) (partNode ? *partNode : driver).fail("no part named '" + c.initialPart + "' to render");
    }
    auto camera = std::make_unique<SimCameraImpl>(driver.path(), parseCameraSettings(driver), std::move(c),
                                                  std::move(station), environment, clock);
    if (environment.simulation) environment.simulation->camera = camera.get();
    return camera;
}

} // namespace hg::drivers
