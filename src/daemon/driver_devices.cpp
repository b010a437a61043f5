#include "driver_devices.h"

#include "hullgauge/common/error.h"
#include "hullgauge/common/log.h"
#include "hullgauge/drivers/camera.h"
#include "hullgauge/drivers/fixture.h"
#include "hullgauge/drivers/lamps.h"
#include "hullgauge/model/mesh_io.h"

namespace hg::daemon {
namespace {

using drivers::FixtureStatusCode;
using drivers::LifecycleState;

Status fromFixture(const drivers::FixtureResult& r)
{
    switch (r.code) {
    case FixtureStatusCode::Ok:
        return Status::success();
    case FixtureStatusCode::Timeout:
        return Status::failure(StatusCode::Timeout, r.message);
    case FixtureStatusCode::Fault:
        return Status::failure(StatusCode::Fault, r.message);
    case FixtureStatusCode::CommunicationError:
        return Status::failure(StatusCode::CommunicationError, r.message);
    case FixtureStatusCode::NotAllowed:
        return Status::failure(StatusCode::NotAllowed, r.message);
    }
    return Status::failure(StatusCode::Error, r.message);
}

drivers::StationIndication indication(LampPattern p)
{
    switch (p) {
    case LampPattern::Off:
        return drivers::StationIndication::Dark;
    case LampPattern::Busy:
        return drivers::StationIndication::Busy;
    case LampPattern::Pass:
        return drivers::StationIndication::Pass;
    case LampPattern::Fail:
        return drivers::StationIndication::Fail;
    case LampPattern::Fault:
        return drivers::StationIndication::Fault;
    }
    return drivers::StationIndication::Dark;
}

class DriverDevices : public StationDevices {
  public:
    explicit DriverDevices(const station::DaemonConfig& config)
    {
        const auto& doc = *config.station.document;
        fixture_ = drivers::makeFixture(doc["fixture"]["driver"], config.station.fixture);
        lamps_ = drivers::makeLamps(doc[config.lampsSection]);
        auto cameraDriver = doc["camera"]["driver"];
        if (cameraDriver.has("backend") && cameraDriver["backend"].asString() == "sim") {
            // The simulated line: the camera renders the selected part at the fixture's actual pose.
            drivers::SimCameraInputs inputs;
            inputs.station = config.station;
            for (const auto& [name, file] : config.simulatedParts)
                inputs.parts.emplace_back(name, model::loadMesh(file));
            if (inputs.parts.empty())
                throw InputError(config.file.string(), "simulation.parts",
                                 "the simulated camera needs the parts it can render (nominal and variants)");
            inputs.poseSource = [this]() -> std::optional<geometry::FixturePose> {
                drivers::FixtureStatus status;
                if (!fixture_->status(status).ok() || status.busy || status.fault) return std::nullopt;
                return status.position;
            };
            auto sim = drivers::makeSimCamera(cameraDriver, std::move(inputs));
            simCamera_ = sim.get();
            camera_ = std::move(sim);
        } else {
            camera_ = drivers::makeCamera(doc);
        }
    }

    Status start() override
    {
        auto log = hg::log::category("daemon");
        if (lamps_->state() == LifecycleState::Unconfigured) {
            if (auto r = lamps_->configure(); !r.ok()) return Status::failure(StatusCode::Error, "lamps: " + r.message);
        }
        if (lamps_->state() == LifecycleState::Inactive) {
            if (auto r = lamps_->activate(); !r.ok()) return Status::failure(StatusCode::Error, "lamps: " + r.message);
        }
        if (fixture_->state() == LifecycleState::Unconfigured) {
            if (auto r = fixture_->configure(); !r.ok()) return fromFixture(r).prefixed("fixture: ");
        }
        if (fixture_->state() == LifecycleState::Inactive) {
            if (auto r = fixture_->activate(); !r.ok()) return fromFixture(r).prefixed("fixture: ");
        }
        if (auto r = homeIfNeeded(); !r.ok()) return r;
        if (camera_->state() == LifecycleState::Unconfigured) {
            if (auto r = camera_->configure(); !r.ok())
                return Status::failure(StatusCode::Error, "camera: " + r.message());
        }
        if (camera_->state() == LifecycleState::Inactive) {
            if (auto r = camera_->activate(); !r.ok())
                return Status::failure(StatusCode::Error, "camera: " + r.message());
        }
        log->info("fixture ({}) and camera active", fixture_->backend());
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
        if (auto r = fixture_->moveTo(pose); !r.ok()) return fromFixture(r);
        return fromFixture(fixture_->waitInPosition(timeout));
    }

    void stopMotion() override
    {
        if (fixture_->state() == LifecycleState::Active) (void)fixture_->stop();
    }

    Status grab(std::chrono::milliseconds timeout, cv::Mat& image) override
    {
        auto frame = camera_->grab(timeout);
        switch (frame.status) {
        case drivers::FrameStatus::Ok:
            // The pipeline keeps the image after the buffer returns to the pool.
            image = frame.image.clone();
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

    std::vector<std::string> simulatedParts() const override
    {
        return simCamera_ ? simCamera_->partNames() : std::vector<std::string>{};
    }
    std::string simulatedPart() const override { return simCamera_ ? simCamera_->part() : std::string(); }
    bool selectSimulatedPart(const std::string& name) override { return simCamera_ && simCamera_->setPart(name).ok(); }

    void showLamps(LampPattern pattern) override
    {
        if (auto r = lamps_->show(indication(pattern)); !r.ok())
            hg::log::category("daemon")->warn("lamps: {}", r.message);
    }

    nlohmann::json lampStatus() const override
    {
        nlohmann::json j{{"backend", std::string(lamps_->backend())}};
        const auto* sim = dynamic_cast<const drivers::SimulatedLamps*>(lamps_.get());
        for (auto lamp : drivers::kAllLamps) {
            auto name = std::string(drivers::toString(lamp));
            j[name] = std::string(drivers::toString(lamps_->commanded(lamp)));
            // The simulated lines' levels: what an operator would see now (blink phase included).
            if (sim) j["lit"][name] = sim->lit(lamp);
        }
        return j;
    }

  private:
    Status homeIfNeeded()
    {
        drivers::FixtureStatus status;
        if (auto r = fixture_->status(status); !r.ok()) return fromFixture(r);
        if (status.homed) return Status::success();
        if (auto r = fixture_->home(); !r.ok()) return fromFixture(r);
        return fromFixture(fixture_->waitInPosition(fixture_->homeTimeout()));
    }

    std::unique_ptr<drivers::Fixture> fixture_;
    std::unique_ptr<drivers::Camera> camera_;
    drivers::SimCamera* simCamera_ = nullptr; ///< camera_ when it is the simulated one
    std::unique_ptr<drivers::Lamps> lamps_;
};

} // namespace

std::unique_ptr<StationDevices> makeDriverDevices(const station::DaemonConfig& config)
{
    if (!config.station.document) throw InputError(config.stationFile.string(), "", "station document missing");
    return std::make_unique<DriverDevices>(config);
}

} // namespace hg::daemon
