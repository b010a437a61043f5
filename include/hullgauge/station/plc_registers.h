// The PLC's view of the station: the holding-register map of docs/contracts.md §6 and
// its rules, independent of the Modbus transport and of threads. A pure value:
// the daemon's PlcRegisters (src/daemon/plant/plc_registers.h) holds one under a
// lock, so a read of any block of registers sees one consistent state: RESULT,
// FAULT_CODE, the landmark counts, CYCLE_MS, LANDMARK_OK_BITS and DONE_SEQ of a
// cycle are written together by publishResult(), and a PLC that reads
// DONE_SEQ == its TRIGGER_SEQ in the same block reads that cycle's result.
//
// Trigger rule (docs/contracts.md §6): a write that changes TRIGGER_SEQ asks for an
// inspection with the PART_PROGRAM and SERIAL in the registers after that write
// (an FC16 block writing program, serial and trigger together is applied as one).
// It is accepted when STATUS is ready or done and the program is known: ACK_SEQ
// latches the value, STATUS becomes busy at once (so a second trigger is
// refused even before the sequencer picks the first one up), and the request
// is queued for the sequencer. Otherwise REJECTED_TRIGGERS counts it and
// LAST_REJECT_REASON says why; nothing else changes.
//
// The production-line handshake (extensions, docs/plc.md "The production-line
// handshake"): ACQ_DONE_SEQ (the part may leave the nest once its last frame is
// in), the recipe changeover (ACTIVE_PROGRAM, PROGRAM_STATE), RESULT_SEQ, the
// 32-bit counters and the ring of the last 8 results. Everything a result
// changes is written by publishResult() with DONE_SEQ.
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <set>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "hullgauge/common/enum_names.h"

namespace hg::station {

/// Holding-register addresses (0-based), docs/contracts.md §6. Extensions beyond the
/// contract are marked and documented in docs/plc.md.
namespace reg {
inline constexpr std::uint16_t TriggerSeq = 0;
inline constexpr std::uint16_t PartProgram = 1;
inline constexpr std::uint16_t Serial = 2; ///< 2..9, 16 ASCII characters, high byte first
inline constexpr std::uint16_t SerialWords = 8;
inline constexpr std::uint16_t Command = 10; ///< extension: PlcCommand (1 abort, 2 reset fault, 3 reset counters)
/// Extension: the purpose of the next cycles (CyclePurpose), latched with each trigger (docs/plc.md).
inline constexpr std::uint16_t CyclePurpose = 11;
/// Extension: the part's temperature, signed 0.01 °C (kNoTemperature: none), latched with each trigger (docs/plc.md).
inline constexpr std::uint16_t PartTemperature = 12;
inline constexpr std::uint16_t AckSeq = 100;
inline constexpr std::uint16_t DoneSeq = 101;
inline constexpr std::uint16_t Status = 102;
inline constexpr std::uint16_t Result = 103;
inline constexpr std::uint16_t FaultCode = 104;
inline constexpr std::uint16_t LandmarksFailed = 105;
inline constexpr std::uint16_t LandmarksTotal = 106;
inline constexpr std::uint16_t CycleMs = 107; ///< 107..108, u32 high word first
inline constexpr std::uint16_t Heartbeat = 109;
inline constexpr std::uint16_t RejectedTriggers = 110;
inline constexpr std::uint16_t LastRejectReason = 111; ///< extension, RejectReason
/// Extension: the measured seat of the part (docs/alignment.md), with the result.
inline constexpr std::uint16_t SeatShiftUm = 112;      ///< shift of the reference point, µm, saturating at 65535
inline constexpr std::uint16_t SeatRotationMdeg = 113; ///< rotation angle, millidegrees, saturating at 65535
/// Extension: TRIGGER_SEQ whose last frame is grabbed; with DONE_SEQ when a cycle ends before it.
inline constexpr std::uint16_t AcqDoneSeq = 114;
/// Extension: +1 with every result published to the PLC (wraps at 65536), written with DONE_SEQ.
inline constexpr std::uint16_t ResultSeq = 115;
/// Extension: the recipe changeover, the PART_PROGRAM value PROGRAM_STATE speaks of.
inline constexpr std::uint16_t ActiveProgram = 116;
inline constexpr std::uint16_t ProgramState = 117; ///< extension, station::ProgramState
/// Extension: re-mastering due of ACTIVE_PROGRAM (MasterDue, docs/plc.md, docs/mastering.md).
inline constexpr std::uint16_t MasterDue = 118;
inline constexpr std::uint16_t MasterGraceLeft = 119; ///< production cycles still judged, saturating at 65535
inline constexpr std::uint16_t LandmarkOkBits = 120;  ///< 120..135
inline constexpr std::uint16_t LandmarkOkWords = 16;
/// Extension: the counters, u32 each, high word first (PlcCounters).
inline constexpr std::uint16_t TriggerCount = 136; ///< 136..137, triggers accepted
inline constexpr std::uint16_t PassCount = 138;    ///< 138..139, results RESULT 1
inline constexpr std::uint16_t FailCount = 140;    ///< 140..141, results RESULT 2
inline constexpr std::uint16_t FaultCount = 142;   ///< 142..143, results RESULT 3
inline constexpr std::uint16_t MissedCount = 144;  ///< 144..145, triggers refused
/// Extension: the station's health (docs/health.md, "In the daemon"): bit k set while the
/// k-th vision::HealthFigure is beyond its limit, written with the result of every cycle that examined it.
inline constexpr std::uint16_t HealthWarnings = 146;
/// Extension: the last RingEntries results, entry k = RESULT_SEQ mod RingEntries at
/// ResultRing + k · RingEntryWords; the words of an entry are in namespace ring.
inline constexpr std::uint16_t ResultRing = 160; ///< 160..223
inline constexpr std::uint16_t RingEntries = 8;
inline constexpr std::uint16_t RingEntryWords = 8;
/// One past the last mapped address; reads of [0, Count) are allowed (gaps read 0).
/// 100..Count-1 is 124 registers: one FC03 (at most 125) reads every read-only register.
inline constexpr std::uint16_t Count = ResultRing + RingEntries * RingEntryWords;
static_assert(Count - AckSeq <= 125, "the read-only block must fit one FC03 read");
} // namespace reg

/// The words of a ring entry (offsets from its first register); 2..7 are in
/// the order of RESULT..CYCLE_MS (103..108).
namespace ring {
inline constexpr std::uint16_t ResultSeq = 0;
inline constexpr std::uint16_t TriggerSeq = 1;
inline constexpr std::uint16_t Result = 2;
inline constexpr std::uint16_t FaultCode = 3;
inline constexpr std::uint16_t LandmarksFailed = 4;
inline constexpr std::uint16_t LandmarksTotal = 5;
inline constexpr std::uint16_t CycleMs = 6; ///< 6..7, u32 high word first
} // namespace ring

/// PART_TEMPERATURE's "no reading" (0x8000, the int16 −32768 no temperature is); the register holds it
/// until the PLC writes a temperature.
inline constexpr std::uint16_t kNoTemperature = 0x8000;
/// A PART_TEMPERATURE word as °C (two's complement int16 in 0.01 °C: 2150 is 21.50 °C, 0xFE0C −5.00 °C);
/// none for kNoTemperature.
std::optional<double> decodeTemperature(std::uint16_t word);

/// Largest number of landmarks LANDMARK_OK_BITS can report.
inline constexpr std::size_t kMaxReportedLandmarks = reg::LandmarkOkWords * 16;

/// STATUS register values (docs/contracts.md §6).
/// Maintenance (5) is an extension: a calibration runs from the maintenance
/// socket; triggers are refused as not ready.
enum class PlcStatus : std::uint16_t { Ready = 0, Busy = 1, Done = 2, Fault = 3, Starting = 4, Maintenance = 5 };
/// The names docs/plc.md gives the STATUS values (the line view shows them, docs/hmi.md).
constexpr auto nameTable(PlcStatus)
{
    using enum PlcStatus;
    return std::to_array<EnumName<PlcStatus>>({{Ready, "ready"},
                                               {Busy, "busy"},
                                               {Done, "done"},
                                               {Fault, "fault"},
                                               {Starting, "starting"},
                                               {Maintenance, "maintenance"}});
}
/// RESULT register values (docs/contracts.md §6).
enum class PlcResult : std::uint16_t { None = 0, Pass = 1, Fail = 2, Aborted = 3 };
/// COMMAND register values (extension). ResetCounters acts in the write itself.
enum class PlcCommand : std::uint16_t { None = 0, Abort = 1, ResetFault = 2, ResetCounters = 3 };
/// PROGRAM_STATE register values (extension, docs/plc.md "Recipe changeover"):
/// what the daemon made of ACTIVE_PROGRAM. Only Ready lets a PLC trigger at once.
enum class ProgramState : std::uint16_t { None = 0, Ready = 1, Preparing = 2, UnknownProgram = 3, LoadFailed = 4 };
constexpr auto nameTable(ProgramState)
{
    using enum ProgramState;
    return std::to_array<EnumName<ProgramState>>({{None, "none"},
                                                  {Ready, "ready"},
                                                  {Preparing, "preparing"},
                                                  {UnknownProgram, "unknown program"},
                                                  {LoadFailed, "load failed"}});
}
/// The counters registers (extension), u32 each, wrapping at 2^32. Only the
/// PLC's triggers count (the maintenance socket's manual cycles never do), and
/// between results TRIGGERS = PASSES + FAILS + FAULTS (+ 1 while a PLC trigger
/// is accepted and its result not yet published).
struct PlcCounters {
    std::uint32_t triggers = 0; ///< triggers accepted (ACK_SEQ latched)
    std::uint32_t passes = 0;   ///< results with RESULT 1
    std::uint32_t fails = 0;    ///< results with RESULT 2
    std::uint32_t faults = 0;   ///< results with RESULT 3: any FAULT_CODE (station fault, program, abort, seat)
    std::uint32_t missed = 0;   ///< triggers refused (REJECTED_TRIGGERS without the manual ones)
    bool operator==(const PlcCounters&) const = default;
};
/// The u32 at `address`, `address + 1` (high word first).
std::uint32_t readU32(std::span<const std::uint16_t> regs, std::uint16_t address);
/// The counters in a register snapshot.
PlcCounters readCounters(std::span<const std::uint16_t> regs);
/// CYCLE_PURPOSE register values (extension, docs/study.md): what the cycles
/// are for. Master and study cycles stay out of production statistics.
enum class CyclePurpose : std::uint16_t { Production = 0, Master = 1, Study = 2 };
constexpr auto nameTable(CyclePurpose)
{
    using enum CyclePurpose;
    return std::to_array<EnumName<CyclePurpose>>({{Production, "production"}, {Master, "master"}, {Study, "study"}});
}
/// The commands written to COMMAND and not taken yet: each is latched until
/// taken, so an abort and a fault reset written back to back are both seen.
struct PlcCommands {
    bool abort = false;
    bool resetFault = false;
    bool any() const { return abort || resetFault; }
};
/// LAST_REJECT_REASON register values (extension).
/// MasteringDue (4): a production trigger of a program whose re-mastering is
/// due and its grace used up (docs/mastering.md, "Re-mastering due").
enum class RejectReason : std::uint16_t { None = 0, Busy = 1, UnknownProgram = 2, NotReady = 3, MasteringDue = 4 };
/// MASTER_DUE register values (extension, docs/plc.md): of ACTIVE_PROGRAM.
enum class MasterDue : std::uint16_t { No = 0, Due = 1, ProductionRefused = 2 };
/// A program's re-mastering due as the register map shows and applies it.
struct MasterDueState {
    MasterDue due = MasterDue::No;
    std::uint64_t graceLeft = 0; ///< production cycles still judged (MASTER_GRACE_LEFT)
    bool operator==(const MasterDueState&) const = default;
};

/// Modbus exception codes the map answers with (Modbus application protocol §7).
enum class ModbusException : std::uint8_t {
    None = 0,
    IllegalFunction = 1,
    IllegalDataAddress = 2, ///< read-only or unmapped address, or a block past the map
    IllegalDataValue = 3,   ///< a value the register does not take
};

/// An accepted trigger, latched with the program and serial at acceptance.
struct TriggerRequest {
    std::uint16_t seq = 0;
    std::uint16_t program = 0;
    std::string serial; ///< trailing NULs and spaces removed
    /// From the maintenance socket, not the PLC: its result never touches
    /// ACK_SEQ, DONE_SEQ or the result registers the PLC owns a handshake on.
    bool manual = false;
    /// CYCLE_PURPOSE at acceptance.
    CyclePurpose purpose = CyclePurpose::Production;
    /// PART_TEMPERATURE at acceptance (°C); none: the PLC gives no reading (docs/mastering.md, "Temperature").
    std::optional<double> partTemperatureC{};
};

/// What the PLC sees of a finished (or aborted) cycle.
struct PublishedResult {
    std::uint16_t seq = 0;
    PlcResult result = PlcResult::None;
    std::uint16_t faultCode = 0;
    std::uint16_t landmarksFailed = 0;
    std::uint16_t landmarksTotal = 0;
    std::uint32_t cycleMs = 0;
    /// ok[i]: landmark i passed; entries beyond kMaxReportedLandmarks are not reported.
    std::vector<bool> landmarkOk;
    /// The measured seat (extension, SEAT_SHIFT_UM, SEAT_ROTATION_MDEG); 0 when
    /// the cycle measured none (alignment off, aborted or faulted before).
    std::uint16_t seatShiftUm = 0;
    std::uint16_t seatRotationMdeg = 0;
    /// STATUS after publishing: Done normally, Fault when the station needs recovery.
    PlcStatus statusAfter = PlcStatus::Done;
    /// A manual cycle's result only changes STATUS (see TriggerRequest::manual)
    /// and the station's health: HEALTH_WARNINGS is the station's, not the
    /// PLC's handshake, so every cycle that examined it writes it.
    bool manual = false;
    /// HEALTH_WARNINGS (extension); absent: the cycle examined no view, the register keeps its value.
    std::optional<std::uint16_t> healthWarnings;
};

class RegisterMap {
  public:
    RegisterMap();

    /// FC03. Fills `out` with `count` registers from `address`; any block
    /// inside [0, reg::Count) may be read (unmapped gaps read 0).
    ModbusException read(std::uint16_t address, std::uint16_t count, std::vector<std::uint16_t>& out) const;
    /// FC06 / FC16. Applies the whole block or nothing: any address outside
    /// the PLC-writable registers answers IllegalDataAddress, any bad value
    /// IllegalDataValue (checked before anything changes).
    ModbusException write(std::uint16_t address, std::span<const std::uint16_t> values);

    /// The part-program numbers a trigger may name (set at start and on reload).
    void setKnownPrograms(std::set<std::uint16_t> programs);
    /// STATUS as the sequencer reports it (Starting, Ready, Busy, Fault).
    void setStatus(PlcStatus status);
    /// Ready or done with no trigger pending -> Maintenance, atomically with
    /// the trigger acceptance (a trigger accepted first wins); false otherwise.
    bool enterMaintenance();
    PlcStatus status() const;
    /// Writes RESULT, FAULT_CODE, counts, CYCLE_MS, the seat, LANDMARK_OK_BITS,
    /// HEALTH_WARNINGS, DONE_SEQ and STATUS together.
    void publishResult(const PublishedResult& r);
    /// HEARTBEAT += 1 (wraps at 65536).
    void beat();
    /// ACQ_DONE_SEQ = seq: the last frame of the PLC's trigger `seq` is in.
    void acquisitionDone(std::uint16_t seq);

    /// The program whose changeover waits to be prepared (PART_PROGRAM written
    /// with a new value, or the configuration reloaded), if any; taken once.
    std::optional<std::uint16_t> takeChangeover();
    /// The daemon prepared `program` (Ready or LoadFailed): PROGRAM_STATE shows
    /// it while ACTIVE_PROGRAM is still `program` and no newer changeover waits.
    void programPrepared(std::uint16_t program, ProgramState state);
    /// Re-mastering due per program (a program not named: not due): MASTER_DUE
    /// and MASTER_GRACE_LEFT show ACTIVE_PROGRAM's, and a production trigger of
    /// a program whose production is refused is rejected (RejectReason::MasteringDue).
    void setMasterDue(std::map<std::uint16_t, MasterDueState> due);
    PlcCounters counters() const { return counters_; }
    /// CYCLE_PURPOSE as the maintenance socket sets it: the same register the
    /// PLC writes, so whichever was written last applies to the next trigger.
    void setPurpose(CyclePurpose purpose);
    CyclePurpose purpose() const;

    /// Takes the oldest accepted trigger, if any.
    std::optional<TriggerRequest> takeTrigger();
    /// Takes the commands written since the last call (abort, reset fault).
    PlcCommands takeCommands();
    /// True when a trigger or a command waits to be taken.
    bool hasWork() const { return !pending_.empty() || commands_.any() || changeover_.has_value(); }

    /// Counters for the maintenance socket and logs.
    std::uint16_t rejectedTriggers() const;
    /// A copy of the whole map (for status displays and tests).
    std::array<std::uint16_t, reg::Count> snapshot() const;

    /// A trigger from the maintenance socket: the same acceptance rules as
    /// the PLC's, counted the same way, but the handshake registers stay the PLC's.
    RejectReason triggerManually(std::uint16_t program, const std::string& serial);

  private:
    RejectReason accept(TriggerRequest request);
    static bool writable(std::uint16_t address);
    /// PART_PROGRAM was written with `program`: ACTIVE_PROGRAM and PROGRAM_STATE follow.
    void selectProgram(std::uint16_t program, bool recheck);
    void setU32(std::uint16_t address, std::uint32_t value);
    void writeCounters();
    void resetCounters();
    void writeRingEntry(const PublishedResult& r, std::uint16_t resultSeq);
    MasterDueState masterDueOf(std::uint16_t program) const;
    void writeMasterDue();

    std::array<std::uint16_t, reg::Count> regs_{};
    std::set<std::uint16_t> knownPrograms_;
    std::map<std::uint16_t, MasterDueState> masterDue_;
    std::deque<TriggerRequest> pending_;
    PlcCommands commands_;
    std::optional<std::uint16_t> changeover_;
    PlcCounters counters_;
    bool plcCycleOpen_ = false; ///< a PLC trigger is accepted and its result not yet published
};

/// The serial number in SERIAL (2 ASCII characters per register, high byte
/// first), without trailing NULs and spaces.
std::string decodeSerial(std::span<const std::uint16_t, reg::SerialWords> words);
/// SERIAL carries printable ASCII; NUL pads a short serial (the rule of every
/// serial, the PLC's and the maintenance socket's manual trigger).
bool validSerialByte(unsigned byte);
/// A serial's most characters: the SERIAL registers' (a manual trigger's serial is held to it too).
inline constexpr std::size_t kSerialChars = 2 * reg::SerialWords;
/// The inverse of decodeSerial (pads with NULs; longer strings are cut at 16).
std::array<std::uint16_t, reg::SerialWords> encodeSerial(const std::string& serial);

} // namespace hg::station
