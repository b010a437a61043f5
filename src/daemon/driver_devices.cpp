#include "driver_devices.h"

#include "hullgauge/common/error.h"
#include "hullgauge/common/log.h"
#include "hullgauge/drivers/simulation.h"
#include "hullgauge/model/mesh_io.h"

#include <array>

namespace hg::daemon {
namespace {

using drivers::LifecycleState;

drivers::StationIndication indication(LampPattern p)
{
    using I = drivers::StationIndication;
    constexpr std::array<I, 5> byPattern{I::Dark, I::Busy, I::Pass, I::Fail, I::Fault}; // LampPattern order
    return byPattern[static_cast<std::size_t>(p)];
}

class DriverDevices : public StationDevices, public SimulationControl {
  public:
    explicit DriverDevices(const station::DaemonConfig& config)
    {
        const auto& doc = *config.station.document;
        fixture_ = drivers::makeFixture(doc["fixture"]["driver"], config.station.fixture, &sim_);
        lamps_ = drivers::makeLamps(doc[config.lampsSection], &sim_);
        // The simulated line: the camera renders the selected part at the fixture's actual pose.
        drivers::CameraEnvironment environment;
        for (const auto& [name, file] : config.simulatedParts)
            environment.parts.emplace_back(name, model::loadMesh(file));
        environment.poseSource = [this]() -> std::optional<geometry::FixturePose> {
            drivers::FixtureStatus status;
            if (!fixture_->status(status).ok() || status.busy || status.fault) return std::nullopt;
            return status.position;
        };
        environment.simulation = &sim_;
        camera_ = drivers::makeCamera(doc, std::move(environment));
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
        return fixture_->waitInPosition(timeout);
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

    std::vector<std::string> parts() const override { return sim_.camera->partNames(); }
    std::string part() const override { return sim_.camera->part(); }
    bool selectPart(const std::string& name) override { return sim_.camera->setPart(name).ok(); }

    void showLamps(LampPattern pattern) override
    {
        if (auto r = lamps_->show(indication(pattern)); !r.ok()) hg::log::category("daemon")->warn("{}", r.message());
    }

    nlohmann::json lampStatus() const override
    {
        nlohmann::json j{{"backend", std::string(lamps_->backend())}};
        for (auto lamp : drivers::kAllLamps) {
            auto name = std::string(drivers::toString(lamp));
            j[name] = std::string(drivers::toString(lamps_->commanded(lamp)));
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

    Status homeIfNeeded()
    {
        drivers::FixtureStatus status;
        if (auto r = fixture_->status(status); !r.ok()) return r;
        if (status.homed) return Status::success();
        if (auto r = fixture_->home(); !r.ok()) return r;
        return fixture_->waitInPosition(fixture_->homeTimeout());
    }

    drivers::SimulationControls sim_; ///< the twins' controls, where a driver is simulated
    std::unique_ptr<drivers::Fixture> fixture_;
    std::unique_ptr<drivers::Camera> camera_;
    std::unique_ptr<drivers::Lamps> lamps_;
};

} // namespace

StationHardware makeDriverDevices(const station::DaemonConfig& config)
{
    if (!config.station.document) throw InputError(config.stationFile.string(), "", "station document missing");
    auto devices = std::make_unique<DriverDevices>(config);
    SimulationControl* simulation = devices->simulation();
    return {std::move(devices), simulation};
}

} // namespace hg::daemon
