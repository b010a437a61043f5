#include "hullgauge/station/plc_registers.h"

#include <algorithm>
#include <utility>

namespace hg::station {
namespace {

std::uint16_t u16(auto v)
{
    return static_cast<std::uint16_t>(v);
}

} // namespace

std::uint32_t readU32(std::span<const std::uint16_t> regs, std::uint16_t address)
{
    return (std::uint32_t{regs[address]} << 16) | regs[address + 1u];
}

PlcCounters readCounters(std::span<const std::uint16_t> regs)
{
    return {readU32(regs, reg::TriggerCount), readU32(regs, reg::PassCount), readU32(regs, reg::FailCount),
            readU32(regs, reg::FaultCount), readU32(regs, reg::MissedCount)};
}

std::optional<double> decodeTemperature(std::uint16_t word)
{
    if (word == kNoTemperature) return std::nullopt;
    return static_cast<std::int16_t>(word) / 100.0;
}

bool validSerialByte(unsigned byte)
{
    return byte == 0 || (byte >= 0x20 && byte <= 0x7E);
}

std::string decodeSerial(std::span<const std::uint16_t, reg::SerialWords> words)
{
    std::string s;
    for (auto w : words) {
        s.push_back(static_cast<char>(w >> 8));
        s.push_back(static_cast<char>(w & 0xFF));
    }
    while (!s.empty() && (s.back() == '\0' || s.back() == ' ')) s.pop_back();
    // A NUL inside the serial ends it (C-string convention of most PLC string types).
    if (auto nul = s.find('\0'); nul != std::string::npos) s.resize(nul);
    return s;
}

std::array<std::uint16_t, reg::SerialWords> encodeSerial(const std::string& serial)
{
    std::array<std::uint16_t, reg::SerialWords> words{};
    for (std::size_t i = 0; i < std::min<std::size_t>(serial.size(), 2 * reg::SerialWords); ++i) {
        auto byte = static_cast<std::uint16_t>(static_cast<unsigned char>(serial[i]));
        words[i / 2] = u16(words[i / 2] | (i % 2 == 0 ? byte << 8 : byte));
    }
    return words;
}

RegisterMap::RegisterMap()
{
    regs_[reg::Status] = u16(PlcStatus::Starting);
    // No temperature until the PLC writes one: 0 would read as a part at 0 °C.
    regs_[reg::PartTemperature] = kNoTemperature;
}

bool RegisterMap::writable(std::uint16_t address)
{
    return address == reg::TriggerSeq || address == reg::PartProgram ||
           (address >= reg::Serial && address < reg::Serial + reg::SerialWords) || address == reg::Command ||
           address == reg::CyclePurpose || address == reg::PartTemperature;
}

ModbusException RegisterMap::read(std::uint16_t address, std::uint16_t count, std::vector<std::uint16_t>& out) const
{
    if (count == 0 || static_cast<unsigned>(address) + count > reg::Count) return ModbusException::IllegalDataAddress;
    out.assign(regs_.begin() + address, regs_.begin() + address + count);
    return ModbusException::None;
}

ModbusException RegisterMap::write(std::uint16_t address, std::span<const std::uint16_t> values)
{
    if (values.empty()) return ModbusException::IllegalDataValue;
    // Check every address and value before changing anything: a block write is all or nothing.
    for (std::size_t i = 0; i < values.size(); ++i) {
        auto a = static_cast<unsigned>(address) + i;
        if (a >= reg::Count || !writable(static_cast<std::uint16_t>(a))) return ModbusException::IllegalDataAddress;
    }
    for (std::size_t i = 0; i < values.size(); ++i) {
        auto a = static_cast<std::uint16_t>(address + i);
        auto v = values[i];
        if (a >= reg::Serial && a < reg::Serial + reg::SerialWords) {
            if (!validSerialByte(v >> 8) || !validSerialByte(v & 0xFF)) return ModbusException::IllegalDataValue;
        } else if (a == reg::Command) {
            if (v > u16(PlcCommand::ResetCounters)) return ModbusException::IllegalDataValue;
        } else if (a == reg::CyclePurpose) {
            if (v > u16(CyclePurpose::Study)) return ModbusException::IllegalDataValue;
        }
    }

    std::optional<std::uint16_t> newTrigger;
    bool programWritten = false;
    for (std::size_t i = 0; i < values.size(); ++i) {
        auto a = static_cast<std::uint16_t>(address + i);
        if (a == reg::TriggerSeq) {
            if (values[i] != regs_[a]) newTrigger = values[i];
        } else if (a == reg::Command) {
            // The command acts on the write; the register itself reads 0.
            auto command = static_cast<PlcCommand>(values[i]);
            if (command == PlcCommand::Abort) commands_.abort = true;
            if (command == PlcCommand::ResetFault) commands_.resetFault = true;
            if (command == PlcCommand::ResetCounters) resetCounters();
            continue;
        }
        if (a == reg::PartProgram) programWritten = true;
        regs_[a] = values[i];
    }
    // The changeover first: a trigger in the same block runs the program it selects.
    if (programWritten) selectProgram(regs_[reg::PartProgram], false);
    if (newTrigger) {
        // Program and serial written in the same block are already in place.
        TriggerRequest request{*newTrigger, regs_[reg::PartProgram],
                               decodeSerial(std::span<const std::uint16_t, reg::SerialWords>(regs_.data() + reg::Serial,
                                                                                             reg::SerialWords)),
                               false, purpose()};
        request.partTemperatureC = decodeTemperature(regs_[reg::PartTemperature]);
        accept(std::move(request));
    }
    return ModbusException::None;
}

RejectReason RegisterMap::accept(TriggerRequest request)
{
    auto status = static_cast<PlcStatus>(regs_[reg::Status]);
    RejectReason reason = RejectReason::None;
    if (status == PlcStatus::Busy)
        reason = RejectReason::Busy;
    else if (status == PlcStatus::Fault || status == PlcStatus::Starting || status == PlcStatus::Maintenance)
        reason = RejectReason::NotReady;
    else if (!knownPrograms_.contains(request.program))
        reason = RejectReason::UnknownProgram;
    // Master and study cycles run on, so the master can be measured (docs/mastering.md).
    else if (request.purpose == CyclePurpose::Production &&
             masterDueOf(request.program).due == MasterDue::ProductionRefused)
        reason = RejectReason::MasteringDue;

    if (!request.manual) regs_[reg::TriggerSeq] = request.seq;
    if (reason != RejectReason::None) {
        regs_[reg::RejectedTriggers] = u16(regs_[reg::RejectedTriggers] + 1);
        regs_[reg::LastRejectReason] = u16(reason);
        if (!request.manual) ++counters_.missed;
        writeCounters();
        return reason;
    }
    if (!request.manual) {
        regs_[reg::AckSeq] = request.seq;
        ++counters_.triggers;
        plcCycleOpen_ = true;
        writeCounters();
    }
    regs_[reg::Status] = u16(PlcStatus::Busy);
    pending_.push_back(std::move(request));
    return RejectReason::None;
}

RejectReason RegisterMap::triggerManually(std::uint16_t program, const std::string& serial)
{
    return accept(TriggerRequest{0, program, serial, true, purpose(), decodeTemperature(regs_[reg::PartTemperature])});
}

void RegisterMap::setKnownPrograms(std::set<std::uint16_t> programs)
{
    knownPrograms_ = std::move(programs);
    // A reload may drop the active program, add it, or point it at another file: check it again.
    selectProgram(regs_[reg::ActiveProgram], true);
}

// The recipe changeover (docs/plc.md): PROGRAM_STATE changes in the write that
// selects the program when the answer is known at once (none, unknown program);
// otherwise it reads "preparing" until the cycle runner has loaded the program
// between cycles. Writing the active program again changes nothing, unless its
// load failed (a retry).
void RegisterMap::selectProgram(std::uint16_t program, bool recheck)
{
    const auto state = static_cast<ProgramState>(regs_[reg::ProgramState]);
    if (!recheck && program == regs_[reg::ActiveProgram] && state != ProgramState::LoadFailed) return;
    regs_[reg::ActiveProgram] = program;
    changeover_.reset();
    writeMasterDue();
    if (program == 0) {
        regs_[reg::ProgramState] = u16(ProgramState::None);
    } else if (!knownPrograms_.contains(program)) {
        regs_[reg::ProgramState] = u16(ProgramState::UnknownProgram);
    } else {
        regs_[reg::ProgramState] = u16(ProgramState::Preparing);
        changeover_ = program;
    }
}

std::optional<std::uint16_t> RegisterMap::takeChangeover()
{
    return std::exchange(changeover_, std::nullopt);
}

void RegisterMap::programPrepared(std::uint16_t program, ProgramState state)
{
    // A newer changeover (another program, or the same after a reload) reports on its own.
    if (program != regs_[reg::ActiveProgram] || changeover_) return;
    const auto now = static_cast<ProgramState>(regs_[reg::ProgramState]);
    if (now == ProgramState::None || now == ProgramState::UnknownProgram) return;
    regs_[reg::ProgramState] = u16(state);
}

void RegisterMap::setMasterDue(std::map<std::uint16_t, MasterDueState> due)
{
    masterDue_ = std::move(due);
    writeMasterDue();
}

MasterDueState RegisterMap::masterDueOf(std::uint16_t program) const
{
    const auto it = masterDue_.find(program);
    return it == masterDue_.end() ? MasterDueState{} : it->second;
}

void RegisterMap::writeMasterDue()
{
    const auto state = masterDueOf(regs_[reg::ActiveProgram]);
    regs_[reg::MasterDue] = u16(state.due);
    regs_[reg::MasterGraceLeft] = u16(std::min<std::uint64_t>(state.graceLeft, 0xFFFF));
}

void RegisterMap::setU32(std::uint16_t address, std::uint32_t value)
{
    regs_[address] = u16(value >> 16);
    regs_[address + 1u] = u16(value & 0xFFFF);
}

void RegisterMap::writeCounters()
{
    setU32(reg::TriggerCount, counters_.triggers);
    setU32(reg::PassCount, counters_.passes);
    setU32(reg::FailCount, counters_.fails);
    setU32(reg::FaultCount, counters_.faults);
    setU32(reg::MissedCount, counters_.missed);
}

// COMMAND = 3. A trigger accepted before the reset whose result is still to come
// stays counted, so TRIGGERS = PASSES + FAILS + FAULTS holds again with that result.
void RegisterMap::resetCounters()
{
    counters_ = PlcCounters{};
    counters_.triggers = plcCycleOpen_ ? 1 : 0;
    writeCounters();
}

void RegisterMap::writeRingEntry(const PublishedResult& r, std::uint16_t resultSeq)
{
    const auto base = u16(reg::ResultRing + (resultSeq % reg::RingEntries) * reg::RingEntryWords);
    regs_[base + ring::ResultSeq] = resultSeq;
    regs_[base + ring::TriggerSeq] = r.seq;
    regs_[base + ring::Result] = u16(r.result);
    regs_[base + ring::FaultCode] = r.faultCode;
    regs_[base + ring::LandmarksFailed] = r.landmarksFailed;
    regs_[base + ring::LandmarksTotal] = r.landmarksTotal;
    setU32(u16(base + ring::CycleMs), r.cycleMs);
}

void RegisterMap::setStatus(PlcStatus status)
{
    regs_[reg::Status] = u16(status);
}

bool RegisterMap::enterMaintenance()
{
    const auto status = static_cast<PlcStatus>(regs_[reg::Status]);
    if ((status != PlcStatus::Ready && status != PlcStatus::Done) || !pending_.empty()) return false;
    regs_[reg::Status] = u16(PlcStatus::Maintenance);
    return true;
}

PlcStatus RegisterMap::status() const
{
    return static_cast<PlcStatus>(regs_[reg::Status]);
}

void RegisterMap::publishResult(const PublishedResult& r)
{
    regs_[reg::Status] = u16(r.statusAfter);
    if (r.healthWarnings) regs_[reg::HealthWarnings] = *r.healthWarnings;
    if (r.manual) return;
    regs_[reg::Result] = u16(r.result);
    regs_[reg::FaultCode] = r.faultCode;
    regs_[reg::LandmarksFailed] = r.landmarksFailed;
    regs_[reg::LandmarksTotal] = r.landmarksTotal;
    regs_[reg::CycleMs] = u16(r.cycleMs >> 16);
    regs_[reg::CycleMs + 1] = u16(r.cycleMs & 0xFFFF);
    regs_[reg::SeatShiftUm] = r.seatShiftUm;
    regs_[reg::SeatRotationMdeg] = r.seatRotationMdeg;
    for (std::uint16_t k = 0; k < reg::LandmarkOkWords; ++k) {
        std::uint16_t word = 0;
        for (unsigned bit = 0; bit < 16; ++bit) {
            std::size_t i = std::size_t{k} * 16 + bit;
            if (i < r.landmarkOk.size() && r.landmarkOk[i]) word = u16(word | (1u << bit));
        }
        regs_[reg::LandmarkOkBits + k] = word;
    }
    // The handshake extensions of the same result (docs/plc.md): a cycle that ended
    // before its last grab frees the part now; the counters include this result.
    regs_[reg::AcqDoneSeq] = r.seq;
    const auto resultSeq = u16(regs_[reg::ResultSeq] + 1);
    regs_[reg::ResultSeq] = resultSeq;
    if (r.result == PlcResult::Pass)
        ++counters_.passes;
    else if (r.result == PlcResult::Fail)
        ++counters_.fails;
    else
        ++counters_.faults;
    plcCycleOpen_ = false;
    writeCounters();
    writeRingEntry(r, resultSeq);
    regs_[reg::DoneSeq] = r.seq;
}

void RegisterMap::acquisitionDone(std::uint16_t seq)
{
    regs_[reg::AcqDoneSeq] = seq;
}

void RegisterMap::setPurpose(CyclePurpose purpose)
{
    regs_[reg::CyclePurpose] = u16(purpose);
}

CyclePurpose RegisterMap::purpose() const
{
    return static_cast<CyclePurpose>(regs_[reg::CyclePurpose]);
}

void RegisterMap::beat()
{
    regs_[reg::Heartbeat] = u16(regs_[reg::Heartbeat] + 1);
}

std::optional<TriggerRequest> RegisterMap::takeTrigger()
{
    if (pending_.empty()) return std::nullopt;
    auto request = std::move(pending_.front());
    pending_.pop_front();
    return request;
}

PlcCommands RegisterMap::takeCommands()
{
    return std::exchange(commands_, PlcCommands{});
}

std::uint16_t RegisterMap::rejectedTriggers() const
{
    return regs_[reg::RejectedTriggers];
}

std::array<std::uint16_t, reg::Count> RegisterMap::snapshot() const
{
    return regs_;
}

} // namespace hg::station
