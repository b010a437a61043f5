#include "hullgauge/station/plc_registers.h"

#include <algorithm>
#include <utility>

namespace hg::station {
namespace {

std::uint16_t u16(auto v)
{
    return static_cast<std::uint16_t>(v);
}

// SERIAL carries printable ASCII; NUL pads a short serial.
bool validSerialByte(unsigned byte)
{
    return byte == 0 || (byte >= 0x20 && byte <= 0x7E);
}

} // namespace

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

PlcRegisters::PlcRegisters()
{
    regs_[reg::Status] = u16(PlcStatus::Starting);
}

bool PlcRegisters::writable(std::uint16_t address)
{
    return address == reg::TriggerSeq || address == reg::PartProgram ||
           (address >= reg::Serial && address < reg::Serial + reg::SerialWords) || address == reg::Command;
}

ModbusException PlcRegisters::read(std::uint16_t address, std::uint16_t count, std::vector<std::uint16_t>& out) const
{
    if (count == 0 || static_cast<unsigned>(address) + count > reg::Count) return ModbusException::IllegalDataAddress;
    std::lock_guard lock(mutex_);
    out.assign(regs_.begin() + address, regs_.begin() + address + count);
    return ModbusException::None;
}

ModbusException PlcRegisters::write(std::uint16_t address, std::span<const std::uint16_t> values)
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
            if (v > u16(PlcCommand::ResetFault)) return ModbusException::IllegalDataValue;
        }
    }

    std::lock_guard lock(mutex_);
    std::optional<std::uint16_t> newTrigger;
    for (std::size_t i = 0; i < values.size(); ++i) {
        auto a = static_cast<std::uint16_t>(address + i);
        if (a == reg::TriggerSeq) {
            if (values[i] != regs_[a]) newTrigger = values[i];
        } else if (a == reg::Command) {
            // The command acts on the write; the register itself reads 0.
            auto command = static_cast<PlcCommand>(values[i]);
            if (command != PlcCommand::None) {
                pendingCommand_ = command;
                triggerReady_.notify_all();
            }
            continue;
        }
        regs_[a] = values[i];
    }
    if (newTrigger) {
        // Program and serial written in the same block are already in place.
        TriggerRequest request{*newTrigger, regs_[reg::PartProgram],
                               decodeSerial(std::span<const std::uint16_t, reg::SerialWords>(regs_.data() + reg::Serial,
                                                                                             reg::SerialWords)),
                               false};
        acceptLocked(std::move(request));
    }
    return ModbusException::None;
}

RejectReason PlcRegisters::acceptLocked(TriggerRequest request)
{
    auto status = static_cast<PlcStatus>(regs_[reg::Status]);
    RejectReason reason = RejectReason::None;
    if (status == PlcStatus::Busy)
        reason = RejectReason::Busy;
    else if (status == PlcStatus::Fault || status == PlcStatus::Starting || status == PlcStatus::Maintenance)
        reason = RejectReason::NotReady;
    else if (!knownPrograms_.contains(request.program))
        reason = RejectReason::UnknownProgram;

    if (!request.manual) regs_[reg::TriggerSeq] = request.seq;
    if (reason != RejectReason::None) {
        regs_[reg::RejectedTriggers] = u16(regs_[reg::RejectedTriggers] + 1);
        regs_[reg::LastRejectReason] = u16(reason);
        return reason;
    }
    if (!request.manual) regs_[reg::AckSeq] = request.seq;
    regs_[reg::Status] = u16(PlcStatus::Busy);
    pending_.push_back(std::move(request));
    triggerReady_.notify_all();
    return RejectReason::None;
}

RejectReason PlcRegisters::triggerManually(std::uint16_t program, const std::string& serial)
{
    std::lock_guard lock(mutex_);
    return acceptLocked(TriggerRequest{0, program, serial, true});
}

void PlcRegisters::setKnownPrograms(std::set<std::uint16_t> programs)
{
    std::lock_guard lock(mutex_);
    knownPrograms_ = std::move(programs);
}

void PlcRegisters::setStatus(PlcStatus status)
{
    std::lock_guard lock(mutex_);
    regs_[reg::Status] = u16(status);
}

bool PlcRegisters::enterMaintenance()
{
    std::lock_guard lock(mutex_);
    const auto status = static_cast<PlcStatus>(regs_[reg::Status]);
    if ((status != PlcStatus::Ready && status != PlcStatus::Done) || !pending_.empty()) return false;
    regs_[reg::Status] = u16(PlcStatus::Maintenance);
    return true;
}

PlcStatus PlcRegisters::status() const
{
    std::lock_guard lock(mutex_);
    return static_cast<PlcStatus>(regs_[reg::Status]);
}

void PlcRegisters::publishResult(const PublishedResult& r)
{
    std::lock_guard lock(mutex_);
    regs_[reg::Status] = u16(r.statusAfter);
    if (r.manual) return;
    regs_[reg::Result] = u16(r.result);
    regs_[reg::FaultCode] = r.faultCode;
    regs_[reg::LandmarksFailed] = r.landmarksFailed;
    regs_[reg::LandmarksTotal] = r.landmarksTotal;
    regs_[reg::CycleMs] = u16(r.cycleMs >> 16);
    regs_[reg::CycleMs + 1] = u16(r.cycleMs & 0xFFFF);
    for (std::uint16_t k = 0; k < reg::LandmarkOkWords; ++k) {
        std::uint16_t word = 0;
        for (unsigned bit = 0; bit < 16; ++bit) {
            std::size_t i = std::size_t{k} * 16 + bit;
            if (i < r.landmarkOk.size() && r.landmarkOk[i]) word = u16(word | (1u << bit));
        }
        regs_[reg::LandmarkOkBits + k] = word;
    }
    regs_[reg::DoneSeq] = r.seq;
}

void PlcRegisters::beat()
{
    std::lock_guard lock(mutex_);
    regs_[reg::Heartbeat] = u16(regs_[reg::Heartbeat] + 1);
}

std::optional<TriggerRequest> PlcRegisters::waitTrigger(std::chrono::milliseconds timeout)
{
    std::unique_lock lock(mutex_);
    if (!triggerReady_.wait_for(lock, timeout, [&] { return !pending_.empty(); })) return std::nullopt;
    auto request = std::move(pending_.front());
    pending_.pop_front();
    return request;
}

PlcCommand PlcRegisters::takeCommand()
{
    std::lock_guard lock(mutex_);
    return std::exchange(pendingCommand_, PlcCommand::None);
}

std::uint16_t PlcRegisters::rejectedTriggers() const
{
    std::lock_guard lock(mutex_);
    return regs_[reg::RejectedTriggers];
}

std::array<std::uint16_t, reg::Count> PlcRegisters::snapshot() const
{
    std::lock_guard lock(mutex_);
    return regs_;
}

} // namespace hg::station
