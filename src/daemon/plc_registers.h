// The register map (hullgauge/station/plc_registers.h, CONTRACTS §6) shared by
// the PLC server's thread, the cycle runner and the main loop: every access
// takes one lock, so a read of any block sees one consistent state (a result
// is published whole), and the runner can wait for a trigger or a command.
#pragma once

#include "hullgauge/station/plc_registers.h"

#include <chrono>
#include <condition_variable>
#include <mutex>

namespace hg::daemon {

class PlcRegisters {
  public:
    using Map = station::RegisterMap;

    /// Runs `f(map)` under the lock and returns what it returns; wakes a
    /// waiting runner when the call left a trigger or a command behind.
    template <class F> auto locked(F&& f)
    {
        std::lock_guard lock(mutex_);
        struct Notify {
            PlcRegisters& self;
            ~Notify()
            {
                if (self.map_.hasWork()) self.work_.notify_all();
            }
        } notify{*this};
        return f(map_);
    }
    template <class F> auto locked(F&& f) const
    {
        std::lock_guard lock(mutex_);
        return f(static_cast<const Map&>(map_));
    }

    station::ModbusException read(std::uint16_t address, std::uint16_t count, std::vector<std::uint16_t>& out) const
    {
        return locked([&](const Map& m) { return m.read(address, count, out); });
    }
    station::ModbusException write(std::uint16_t address, std::span<const std::uint16_t> values)
    {
        return locked([&](Map& m) { return m.write(address, values); });
    }
    station::RejectReason triggerManually(std::uint16_t program, const std::string& serial)
    {
        return locked([&](Map& m) { return m.triggerManually(program, serial); });
    }
    void setKnownPrograms(std::set<std::uint16_t> programs)
    {
        locked([&](Map& m) { m.setKnownPrograms(std::move(programs)); });
    }
    void setStatus(station::PlcStatus status)
    {
        locked([&](Map& m) { m.setStatus(status); });
    }
    bool enterMaintenance()
    {
        return locked([](Map& m) { return m.enterMaintenance(); });
    }
    void publishResult(const station::PublishedResult& r)
    {
        locked([&](Map& m) { m.publishResult(r); });
    }
    void beat()
    {
        locked([](Map& m) { m.beat(); });
    }
    station::PlcCommands takeCommands()
    {
        return locked([](Map& m) { return m.takeCommands(); });
    }
    std::array<std::uint16_t, station::reg::Count> snapshot() const
    {
        return locked([](const Map& m) { return m.snapshot(); });
    }

    /// Waits up to `timeout` for an accepted trigger and takes it; returns
    /// early without one when a command is written meanwhile.
    std::optional<station::TriggerRequest> waitTrigger(std::chrono::milliseconds timeout)
    {
        std::unique_lock lock(mutex_);
        work_.wait_for(lock, timeout, [&] { return map_.hasWork(); });
        return map_.takeTrigger();
    }

  private:
    mutable std::mutex mutex_;
    std::condition_variable work_;
    Map map_;
};

} // namespace hg::daemon
