// The register map (hullgauge/station/plc_registers.h, docs/contracts.md §6) shared by
// the PLC server's thread, the cycle runner and the main loop: every access
// takes one lock, so a read of any block sees one consistent state (a result
// is published whole), and the runner can wait for a trigger or a command.
#pragma once

#include "hullgauge/common/log.h"
#include "hullgauge/station/plc_registers.h"

#include <chrono>
#include <condition_variable>
#include <mutex>
#include <utility>

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
        const bool running = runningLocked();
        const auto purpose = map_.purpose();
        const auto before = map_.snapshot();
        auto written = map_.write(address, values);
        if (map_.purpose() != purpose)
            hg::log::category("plc")->info("cycle purpose {} (PLC)", enumName(map_.purpose()));
        if (written == station::ModbusException::None) logChanges(before, address, values);
        // An abort applies to the running cycle only (docs/plc.md): one written
        // while idle is dropped, so it cannot abort the next part.
        if (!running) dropAbort();
        return notifying(written);
    }
    /// True while a trigger is accepted or its cycle runs (STATUS busy) or a
    /// calibration runs (STATUS maintenance): the only times an abort applies.
    bool running() const
    {
        std::lock_guard lock(mutex_);
        return runningLocked();
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
        notifying(0);
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
    void setPurpose(station::CyclePurpose purpose)
    {
        std::lock_guard lock(mutex_);
        map_.setPurpose(purpose);
    }
    station::CyclePurpose purpose() const
    {
        std::lock_guard lock(mutex_);
        return map_.purpose();
    }
    void beat()
    {
        std::lock_guard lock(mutex_);
        map_.beat();
    }
    void acquisitionDone(std::uint16_t seq)
    {
        std::lock_guard lock(mutex_);
        map_.acquisitionDone(seq);
    }
    std::optional<std::uint16_t> takeChangeover()
    {
        std::lock_guard lock(mutex_);
        return map_.takeChangeover();
    }
    void programPrepared(std::uint16_t program, station::ProgramState state)
    {
        std::lock_guard lock(mutex_);
        map_.programPrepared(program, state);
    }
    void setMasterDue(std::map<std::uint16_t, station::MasterDueState> due)
    {
        std::lock_guard lock(mutex_);
        map_.setMasterDue(std::move(due));
    }
    station::PlcCounters counters() const
    {
        std::lock_guard lock(mutex_);
        return map_.counters();
    }
    station::PlcCommands takeCommands()
    {
        std::lock_guard lock(mutex_);
        auto commands = map_.takeCommands();
        commands.resetFault = commands.resetFault || std::exchange(resetKept_, false);
        return commands;
    }
    std::array<std::uint16_t, station::reg::Count> snapshot() const
    {
        std::lock_guard lock(mutex_);
        return map_.snapshot();
    }

    /// Waits up to `timeout` for an accepted trigger and takes it; returns
    /// early without one when a command or a program changeover is written meanwhile.
    std::optional<station::TriggerRequest> waitTrigger(std::chrono::milliseconds timeout)
    {
        std::unique_lock lock(mutex_);
        work_.wait_for(lock, timeout, [&] { return hasWorkLocked(); });
        return map_.takeTrigger();
    }

  private:
    template <class T> T notifying(T result)
    {
        if (hasWorkLocked()) work_.notify_all();
        return result;
    }
    bool hasWorkLocked() const { return map_.hasWork() || resetKept_; }
    bool runningLocked() const
    {
        const auto status = map_.status();
        return status == station::PlcStatus::Busy || status == station::PlcStatus::Maintenance;
    }
    /// Takes the latched commands and keeps only the fault reset.
    void dropAbort() { resetKept_ = map_.takeCommands().resetFault || resetKept_; }
    /// The PLC's changeover and counter reset, in the log (docs/plc.md).
    void logChanges(const std::array<std::uint16_t, station::reg::Count>& before, std::uint16_t address,
                    std::span<const std::uint16_t> values) const
    {
        namespace reg = station::reg;
        const auto after = map_.snapshot();
        auto log = hg::log::category("plc");
        if (after[reg::ActiveProgram] != before[reg::ActiveProgram] ||
            after[reg::ProgramState] != before[reg::ProgramState])
            log->info("part program {}: {}", after[reg::ActiveProgram],
                      enumName(static_cast<station::ProgramState>(after[reg::ProgramState])));
        const auto command = static_cast<std::size_t>(reg::Command - address);
        if (address <= reg::Command && command < values.size() &&
            values[command] == static_cast<std::uint16_t>(station::PlcCommand::ResetCounters))
            log->info("counters reset (PLC)");
    }

    mutable std::mutex mutex_;
    std::condition_variable work_;
    Map map_;
    bool resetKept_ = false; ///< a fault reset taken with a dropped abort
};

} // namespace hg::daemon
