#include "cycle/driver_devices.h"

#include "cycle/frame_pool.h"

#include "hullgauge/commission/twin.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/log.h"
#include "hullgauge/drivers/simulation.h"
#include "hullgauge/model/mesh_io.h"
#include "hullgauge/model/part_program.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <mutex>
#include <random>

namespace hg::daemon {
namespace {

using drivers::LifecycleState;

/// A seat drawn uniformly within the play (docs/daemon.md, "Seating"), as
/// commissioning draws the twin's seats (commission/twin.h).
SimulatedSeat drawSeat(std::mt19937_64& rng, const station::DaemonConfig::Seating& play, const geometry::Vec3& c)
{
    return {commission::drawSeat(rng, play.shiftMm, play.rotationDeg, c), c};
}

class DriverDevices : public StationDevices, public SimulationControl {
  public:
    DriverDevices(const station::DaemonConfig& config, Clock& clock)
    {
        const auto& doc = *config.station.document;
        fixture_ = drivers::makeFixture(doc["fixture"]["driver"], config.station.fixture, &sim_, clock);
        lamps_ = drivers::makeLamps(doc[config.lampsSection], &sim_, clock);
        // The simulated line: the camera renders the selected part at the fixture's actual pose.
        drivers::CameraEnvironment environment;
        for (const auto& [name, file] : config.simulatedParts) {
            environment.parts.emplace_back(name, model::loadMesh(file));
            if (name == "nominal") nominalCentre_ = seatCentre_ = environment.parts.back().second.bounds().center();
        }
        if (config.simulatedSeating) {
            seating_ = *config.simulatedSeating;
            seatRng_.seed(seating_->seed);
        }
        environment.poseSource = [this] { return heldPose(); };
        environment.simulation = &sim_;
        camera_ = drivers::makeCamera(doc, std::move(environment), clock);
        if (sim_.camera) selected_ = sim_.camera->part();
        if (!sim_.camera && seating_) {
            // Only the simulated camera renders a seat; a real camera sees the part as it lies.
            hg::log::category("daemon")->warn("simulation.seating ignored: the camera is not the simulated one");
            seating_.reset();
        }
        for (const auto& [number, program] : config.programs) maxViews_ = std::max(maxViews_, program.views.size());
        if (sim_.camera && config.simulatedParts.empty())
            throw InputError(config.file.string(), "simulation.parts",
                             "the simulated camera needs the parts it can render (nominal and variants)");
    }

    /// The part switch of the simulated camera, or null on real hardware.
    SimulationControl* simulation() { return sim_.camera ? this : nullptr; }

    Status start() override
    {
        if (auto r = bringUp(*lamps_); !r.ok()) return r;
        if (auto r = bringUp(*fixture_); !r.ok()) return r;
        if (auto r = homeIfNeeded(); !r.ok()) return r.prefixed("fixture: ");
        if (auto r = bringUp(*camera_); !r.ok()) return r;
        reserveFrames();
        hg::log::category("daemon")->info("fixture ({}) and camera active", fixture_->backend());
        return Status::success();
    }

    void shutdown() override
    {
        stopMotion();
        (void)camera_->deactivate();
        (void)camera_->cleanup();
        (void)fixture_->deactivate();
        (void)fixture_->cleanup();
        (void)lamps_->deactivate();
        (void)lamps_->cleanup();
    }

    Status moveTo(const geometry::FixturePose& pose, std::chrono::milliseconds timeout, bool retry) override
    {
        if (retry) {
            // Second attempt: clear a latched drive fault and home again if the drive lost it.
            (void)fixture_->resetFault();
            if (auto r = homeIfNeeded(); !r.ok()) return r;
        }
        if (auto r = fixture_->moveTo(pose); !r.ok()) return r;
        const Status arrived = fixture_->waitInPosition(timeout);
        std::lock_guard lock(heldPoseMutex_);
        heldPose_ = arrived.ok() ? std::optional(pose) : std::nullopt;
        return arrived;
    }

    void stopMotion() override
    {
        if (fixture_->state() == LifecycleState::Active) (void)fixture_->stop();
    }

    // docs/camera.md, "Regions per grab": the camera rounds the region outward
    // to its increments, or delivers whole frames from then on.
    Status setRegion(const cv::Rect& region) override
    {
        const drivers::Roi roi =
            region.empty() ? drivers::Roi{} : drivers::Roi{region.x, region.y, region.width, region.height};
        auto delivered = camera_->setRegion(roi);
        if (!delivered.ok()) return delivered.status();
        hg::log::category("camera")->trace("region {} asked, {} delivered", roi, delivered.value());
        return Status::success();
    }

    Status grab(std::chrono::milliseconds timeout, GrabbedFrame& out) override
    {
        auto frame = camera_->grab(timeout);
        out.regionChangeMs = frame.regionChangeMs;
        switch (frame.status) {
        case drivers::FrameStatus::Ok:
            // The pipeline keeps the image after the buffer returns to the pool:
            // one copy, of the region the camera sent.
            out.image = frames_.copy(frame.image);
            out.origin = cv::Point(frame.region.x, frame.region.y);
            out.payloadBytes = frame.payloadBytes;
            return Status::success();
        case drivers::FrameStatus::Timeout:
            return Status::failure(StatusCode::Timeout, frame.message);
        case drivers::FrameStatus::Incomplete:
            return Status::failure(StatusCode::BadFrame, frame.message);
        case drivers::FrameStatus::Error:
            return Status::failure(StatusCode::Error, frame.message);
        }
        return Status::failure(StatusCode::Error, frame.message);
    }

    Status recover() override
    {
        (void)fixture_->resetFault();
        if (fixture_->state() == LifecycleState::Failed) (void)fixture_->cleanup();
        if (camera_->state() == LifecycleState::Failed) (void)camera_->cleanup();
        return start();
    }

    std::vector<std::string> parts() const override { return sim_.camera->partNames(); }
    std::string part() const override { return sim_.camera->part(); }
    bool selectPart(const std::string& name) override
    {
        if (!sim_.camera->setPart(name).ok()) return false;
        selected_ = name;
        return true;
    }

    void useProgram(const std::filesystem::path& simulatedNominal) override
    {
        if (!simulatedNominal.empty() && selected_ == "nominal") {
            if (shownFile_ != simulatedNominal) {
                // A STEP model as the program loader tessellates it; the default octree only sizes the cube.
                const auto cad = model::loadCadModel(simulatedNominal, 8, 4);
                shownMesh_ = std::make_shared<const model::TriangleMesh>(cad.solid->mesh());
                shownFile_ = simulatedNominal;
            }
            sim_.camera->showMesh(simulatedNominal.parent_path().filename().string(), shownMesh_);
            seatCentre_ = shownMesh_->bounds().center();
        } else if (!shownFile_.empty()) {
            (void)sim_.camera->setPart(selected_);
            seatCentre_ = nominalCentre_;
            shownFile_.clear();
        }
    }
    drivers::SimFixtureControl* fixtureFaults() override { return sim_.fixture; }

    nlohmann::json optics() const override
    {
        const drivers::SimulatedOptics o = sim_.camera->optics();
        return {
            {"cycles", o.cycles},          {"aging_steps", o.agingSteps},    {"background_level", o.backgroundLevel},
            {"vignetting", o.vignetting},  {"blur_sigma_px", o.blurSigmaPx}, {"halo_px", o.haloPx},
            {"dust_specks", o.dust.size()}};
    }
    void resetAging() override { sim_.camera->resetAging(); }

    void newPart() override
    {
        // One more cycle of the camera's aging (docs/camera.md, "Aging"), seated or not.
        sim_.camera->countCycle();
        if (!seating_) return;
        seat_ = drawSeat(seatRng_, *seating_, seatCentre_);
        sim_.camera->setSeat(seat_.seat);
    }

    std::optional<SimulatedSeat> trueSeat() const override
    {
        if (!seating_) return std::nullopt;
        return seat_;
    }

    void showLamps(LampPattern pattern) override
    {
        if (auto r = lamps_->show(pattern); !r.ok()) hg::log::category("daemon")->warn("{}", r.message());
    }

    nlohmann::json lampStatus() const override
    {
        nlohmann::json j{{"backend", std::string(lamps_->backend())}};
        for (auto lamp : drivers::kAllLamps) {
            auto name = std::string(enumName(lamp));
            j[name] = enumName(lamps_->commanded(lamp));
            // The simulated lines' levels: what an operator would see now (blink phase included).
            if (sim_.lamps) j["lit"][name] = sim_.lamps->lit(lamp);
        }
        return j;
    }

  private:
    /// Configures and activates a driver from wherever it is (start and recovery).
    static Status bringUp(drivers::Device& device)
    {
        Status r;
        if (device.state() == LifecycleState::Unconfigured) r = device.configure();
        if (r.ok() && device.state() == LifecycleState::Inactive) r = device.activate();
        return r.prefixed(device.kind() + ": ");
    }

    /// Two cycles' frames of the configured region (docs/daemon.md, "Memory"):
    /// the cycle's, and the last one's while its job and archive finish.
    void reserveFrames()
    {
        const drivers::Roi roi = camera_->wholeRegion();
        const std::size_t slots = 2 * std::max<std::size_t>(maxViews_, 1);
        frames_.reserve(slots, static_cast<std::size_t>(roi.width) * static_cast<std::size_t>(roi.height));
        hg::log::category("daemon")->debug("frame pool: {} slots of {}x{}", slots, roi.width, roi.height);
    }

    /// Where the fixture holds the part, for the simulated camera. A drive that
    /// stops answering or latches a fault does not move the part: the frame
    /// shows it where the drive last reported it or arrived, and the fault is
    /// the next move's (FAULT 21/22, docs/plc.md), as on a real line, where the
    /// camera knows nothing of the drive; once the simulated grab failed first
    /// and reported FAULT 10.
    std::optional<geometry::FixturePose> heldPose()
    {
        drivers::FixtureStatus status;
        const bool answered = fixture_->status(status).ok();
        std::lock_guard lock(heldPoseMutex_);
        if (answered) {
            if (status.busy && !status.fault) return std::nullopt; // moving: no sharp frame of it
            heldPose_ = status.position;
        }
        return heldPose_;
    }

    Status homeIfNeeded()
    {
        drivers::FixtureStatus status;
        if (auto r = fixture_->status(status); !r.ok()) return r;
        if (status.homed) return Status::success();
        if (auto r = fixture_->home(); !r.ok()) return r;
        return fixture_->waitInPosition(fixture_->homeTimeout());
    }

    drivers::SimulationControls sim_; ///< the twins' controls, where a driver is simulated
    std::mutex heldPoseMutex_;        ///< the camera's grab asks from the runner or its own thread
    std::optional<geometry::FixturePose> heldPose_;
    // The simulated nest (runner thread only): its play, the draws, the part in it.
    std::optional<station::DaemonConfig::Seating> seating_;
    std::mt19937_64 seatRng_;
    geometry::Vec3 seatCentre_ = geometry::Vec3::Zero();
    geometry::Vec3 nominalCentre_ = geometry::Vec3::Zero();
    std::string selected_ = "nominal"; ///< the operator's choice (sim-part)
    std::filesystem::path shownFile_;  ///< a workbench part's CAD model the camera shows, if any
    std::shared_ptr<const model::TriangleMesh> shownMesh_;
    SimulatedSeat seat_;
    std::unique_ptr<drivers::Fixture> fixture_;
    std::unique_ptr<drivers::Camera> camera_;
    std::unique_ptr<drivers::Lamps> lamps_;
    std::size_t maxViews_ = 0; ///< the most views of a part program
    FramePool frames_;         ///< the grabbed frames the cycle keeps (runner thread only)
};

} // namespace

StationHardware makeDriverDevices(const station::DaemonConfig& config, Clock& clock)
{
    if (!config.station.document) throw InputError(config.stationFile.string(), "", "station document missing");
    auto devices = std::make_unique<DriverDevices>(config, clock);
    SimulationControl* simulation = devices->simulation();
    return {std::move(devices), simulation};
}

} // namespace hg::daemon
