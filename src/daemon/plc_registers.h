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

    // The PLC server's requests; a write may leave a trigger or a command for the runner.
    station::ModbusException read(std::uint16_t address, std::uint16_t count, std::vector<std::uint16_t>& out) const
    {
        std::lock_guard lock(mutex_);
        return map_.read(address, count, out);
    }
    station::ModbusException write(std::uint16_t address, std::span<const std::uint16_t> values)
    {
        std::lock_guard lock(mutex_);
        return notifying(map_.write(address, values));
    }
    station::RejectReason triggerManually(std::uint16_t program, const std::string& serial)
    {
        std::lock_guard lock(mutex_);
        return notifying(map_.triggerManually(program, serial));
    }

    void setKnownPrograms(std::set<std::uint16_t> programs)
    {
        std::lock_guard lock(mutex_);
        map_.setKnownPrograms(std::move(programs));
    }
    void setStatus(station::PlcStatus status)
    {
        std::lock_guard lock(mutex_);
        map_.setStatus(status);
    }
    bool enterMaintenance()
    {
        std::lock_guard lock(mutex_);
        return map_.enterMaintenance();
    }
    void publishResult(const station::PublishedResult& r)
    {
        std::lock_guard lock(mutex_);
        map_.publishResult(r);
    }
    void beat()
    {
        std::lock_guard lock(mutex_);
        map_.beat();
    }
    station::PlcCommands takeCommands()
    {
        std::lock_guard lock(mutex_);
        return map_.takeCommands();
    }
    std::array<std::uint16_t, station::reg::Count> snapshot() const
    {
        std::lock_guard lock(mutex_);
        return map_.snapshot();
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
    template <class T> T notifying(T result)
    {
        if (map_.hasWork()) work_.notify_all();
        return result;
    }

    mutable std::mutex mutex_;
    std::condition_variable work_;
    Map map_;
};

} // namespace hg::daemon
