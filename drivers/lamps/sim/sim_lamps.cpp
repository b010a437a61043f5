// The simulated lamps: three recorded line levels instead of GPIO lines, so
// tests read exactly what an operator would see (blink phase included).
#include <array>
#include <atomic>
#include <mutex>

#include "../backends.h"

namespace hg::drivers {
namespace {

class SimLamps final : public Lamps, public SimLampsControl {
  public:
    SimLamps(LampsConfig config, Clock& clock) : Lamps(std::move(config), clock) {}
    ~SimLamps() override { shutdown(); }

    std::string_view backend() const override { return "sim"; }

    bool lit(Lamp lamp) const override
    {
        std::lock_guard lock(levelsMutex_);
        return requested_ && lit_[static_cast<std::size_t>(lamp)];
    }

    bool lineLevel(Lamp lamp) const override
    {
        std::lock_guard lock(levelsMutex_);
        auto i = static_cast<std::size_t>(lamp);
        return requested_ && (lit_[i] != config().lines[i].activeLow);
    }

    bool linesRequested() const override
    {
        std::lock_guard lock(levelsMutex_);
        return requested_;
    }

    std::uint64_t transitions() const override { return transitions_.load(); }

    void injectWriteFailure(bool fail) override { failWrites_.store(fail); }

  protected:
    Status openLines() override
    {
        if (failWrites_.load())
            return Status::failure(StatusCode::IoError, config().key + ": simulated GPIO chip does not answer");
        std::lock_guard lock(levelsMutex_);
        requested_ = true;
        lit_.fill(false);
        return Status::success();
    }

    void closeLines() override
    {
        std::lock_guard lock(levelsMutex_);
        requested_ = false;
        lit_.fill(false);
    }

    Status writeOutputs(const std::array<bool, 3>& lit) override
    {
        if (failWrites_.load())
            return Status::failure(StatusCode::IoError, config().key + ": simulated write to the lamp lines failed");
        std::lock_guard lock(levelsMutex_);
        if (lit != lit_) ++transitions_;
        lit_ = lit;
        return Status::success();
    }

  private:
    mutable std::mutex levelsMutex_;
    bool requested_ = false;
    std::array<bool, 3> lit_{};
    std::atomic<std::uint64_t> transitions_{0};
    std::atomic<bool> failWrites_{false};
};

} // namespace

std::unique_ptr<Lamps> makeSimulatedLamps(LampsConfig config, SimulationControls* simulation, Clock& clock)
{
    auto lamps = std::make_unique<SimLamps>(std::move(config), clock);
    if (simulation) simulation->lamps = lamps.get();
    return lamps;
}

} // namespace hg::drivers
