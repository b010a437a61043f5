// The PLC register map of docs/contracts.md §6: access rules, exception codes, the
// trigger handshake and the publication of a result (the lock around it is the
// daemon's, tests/daemon/test_plc_registers.cpp).
#include "hullgauge/station/plc_registers.h"
#include "hullgauge/station/result_record.h"

#include <gtest/gtest.h>

namespace hg::station {
namespace {

std::uint16_t readOne(const RegisterMap& r, std::uint16_t address)
{
    std::vector<std::uint16_t> v;
    EXPECT_EQ(r.read(address, 1, v), ModbusException::None);
    return v.empty() ? 0xFFFF : v[0];
}

ModbusException writeOne(RegisterMap& r, std::uint16_t address, std::uint16_t value)
{
    std::array<std::uint16_t, 1> v{value};
    return r.write(address, v);
}

// Programs 1 and 7 configured, STATUS ready.
void makeReady(RegisterMap& r)
{
    r.setKnownPrograms({1, 7});
    r.setStatus(PlcStatus::Ready);
}

TEST(PlcRegisterMap, StartsInStartingWithNoTemperatureAndEverythingElseZero)
{
    RegisterMap r;
    auto s = r.snapshot();
    EXPECT_EQ(s[102], 4);     // STATUS starting (docs/contracts.md §6)
    EXPECT_EQ(s[12], 0x8000); // PART_TEMPERATURE: no reading until the PLC writes one (docs/plc.md)
    for (std::size_t a = 0; a < s.size(); ++a) {
        if (a != 102 && a != 12) {
            EXPECT_EQ(s[a], 0) << "address " << a;
        }
    }
}

TEST(PlcRegisterMap, ReadOnlyAndUnmappedWritesAnswerIllegalDataAddress)
{
    RegisterMap r;
    makeReady(r);
    for (std::uint16_t a :
         {100, 101, 102, 103, 104, 105, 106, 107, 108, 109, 110, 114, 115, 116, 117, 120, 135, 136, 145, 160, 223})
        EXPECT_EQ(writeOne(r, a, 1), ModbusException::IllegalDataAddress) << "read-only " << a;
    for (std::uint16_t a : {13, 50, 99, 112, 118, 119, 146, 159, 224, 1000, 65535})
        EXPECT_EQ(writeOne(r, a, 1), ModbusException::IllegalDataAddress) << "unmapped " << a;
    // A block that starts writable and runs into an unmapped register changes nothing.
    std::array<std::uint16_t, 14> block{};
    block.fill(0x4141);
    EXPECT_EQ(r.write(0, block), ModbusException::IllegalDataAddress);
    EXPECT_EQ(readOne(r, 0), 0);
    EXPECT_EQ(readOne(r, 2), 0);
}

TEST(PlcRegisterMap, BadValuesAnswerIllegalDataValueAndChangeNothing)
{
    RegisterMap r;
    makeReady(r);
    EXPECT_EQ(writeOne(r, 2, 0x4101), ModbusException::IllegalDataValue);  // control character in SERIAL
    EXPECT_EQ(writeOne(r, 9, 0x80'41), ModbusException::IllegalDataValue); // non-ASCII byte
    EXPECT_EQ(writeOne(r, 10, 4), ModbusException::IllegalDataValue);      // unknown command
    // All-or-nothing: program 7 in the same block as a bad serial word is not applied.
    std::array<std::uint16_t, 3> block{7, 0x4142, 0x1F00};
    EXPECT_EQ(r.write(1, block), ModbusException::IllegalDataValue);
    EXPECT_EQ(readOne(r, 1), 0);
    EXPECT_EQ(readOne(r, 2), 0);
}

TEST(PlcRegisterMap, ReadsInsideTheMapSucceedAndPastItFail)
{
    RegisterMap r;
    makeReady(r);
    std::vector<std::uint16_t> v;
    EXPECT_EQ(r.read(0, 125, v), ModbusException::None);
    EXPECT_EQ(v.size(), 125u);
    // Every read-only register, 100..223, in one read of 124.
    EXPECT_EQ(r.read(100, 124, v), ModbusException::None);
    EXPECT_EQ(v.size(), 124u);
    EXPECT_EQ(r.read(220, 5, v), ModbusException::IllegalDataAddress);
    EXPECT_EQ(r.read(224, 1, v), ModbusException::IllegalDataAddress);
    EXPECT_EQ(r.read(0, 0, v), ModbusException::IllegalDataAddress);
}

TEST(PlcRegisterMap, SerialIsTwoCharactersPerRegisterHighByteFirst)
{
    auto words = encodeSerial("AB12");
    EXPECT_EQ(words[0], 0x4142); // 'A' = 0x41 high, 'B' = 0x42 low
    EXPECT_EQ(words[1], 0x3132);
    EXPECT_EQ(words[2], 0);
    EXPECT_EQ(decodeSerial(words), "AB12");
    EXPECT_EQ(decodeSerial(encodeSerial("SN-0123456789ABCDEF")), "SN-0123456789ABC"); // cut at 16
    std::array<std::uint16_t, 8> padded{0x5820, 0x2020, 0, 0, 0, 0, 0, 0};            // "X" + spaces
    EXPECT_EQ(decodeSerial(padded), "X");
}

TEST(PlcRegisterMap, ChangedTriggerIsAcceptedAndLatchedWithProgramAndSerial)
{
    RegisterMap r;
    makeReady(r);
    auto serial = encodeSerial("PART-0001");
    std::array<std::uint16_t, 10> block{};
    block[0] = 5; // TRIGGER_SEQ
    block[1] = 7; // PART_PROGRAM
    std::copy(serial.begin(), serial.end(), block.begin() + 2);
    ASSERT_EQ(r.write(0, block), ModbusException::None);
    EXPECT_EQ(readOne(r, 100), 5); // ACK_SEQ
    EXPECT_EQ(readOne(r, 102), 1); // STATUS busy at once
    auto t = r.takeTrigger();
    ASSERT_TRUE(t);
    EXPECT_EQ(t->seq, 5);
    EXPECT_EQ(t->program, 7);
    EXPECT_EQ(t->serial, "PART-0001");
    EXPECT_FALSE(t->manual);
    // The PLC changes program and serial for the next part: the latched request is unaffected.
    ASSERT_EQ(writeOne(r, 1, 1), ModbusException::None);
    EXPECT_EQ(t->program, 7);
}

TEST(PlcRegisterMap, SameTriggerValueDoesNothing)
{
    RegisterMap r;
    makeReady(r);
    ASSERT_EQ(writeOne(r, 1, 1), ModbusException::None);
    ASSERT_EQ(writeOne(r, 0, 3), ModbusException::None);
    ASSERT_TRUE(r.takeTrigger());
    r.setStatus(PlcStatus::Ready);
    ASSERT_EQ(writeOne(r, 0, 3), ModbusException::None);
    EXPECT_FALSE(r.takeTrigger());
    EXPECT_EQ(r.rejectedTriggers(), 0);
}

TEST(PlcRegisterMap, RefusedTriggersAreCountedWithTheirReason)
{
    RegisterMap r;
    makeReady(r);
    ASSERT_EQ(writeOne(r, 1, 9), ModbusException::None); // program 9 is not configured
    ASSERT_EQ(writeOne(r, 0, 1), ModbusException::None);
    EXPECT_EQ(readOne(r, 110), 1);
    EXPECT_EQ(readOne(r, 111), static_cast<std::uint16_t>(RejectReason::UnknownProgram));
    EXPECT_EQ(readOne(r, 100), 0); // ACK_SEQ unchanged
    EXPECT_EQ(readOne(r, 102), 0); // still ready

    ASSERT_EQ(writeOne(r, 1, 1), ModbusException::None);
    ASSERT_EQ(writeOne(r, 0, 2), ModbusException::None); // accepted
    ASSERT_EQ(writeOne(r, 0, 3), ModbusException::None); // busy: refused
    EXPECT_EQ(readOne(r, 100), 2);
    EXPECT_EQ(readOne(r, 110), 2);
    EXPECT_EQ(readOne(r, 111), static_cast<std::uint16_t>(RejectReason::Busy));
    ASSERT_TRUE(r.takeTrigger());
    EXPECT_FALSE(r.takeTrigger()); // the refused one was never queued

    r.setStatus(PlcStatus::Fault);
    ASSERT_EQ(writeOne(r, 0, 4), ModbusException::None);
    EXPECT_EQ(readOne(r, 110), 3);
    EXPECT_EQ(readOne(r, 111), static_cast<std::uint16_t>(RejectReason::NotReady));
}

TEST(PlcRegisterMap, PublishedResultAppearsWithDoneSeqAndBits)
{
    RegisterMap r;
    makeReady(r);
    PublishedResult p;
    p.seq = 42;
    p.result = PlcResult::Fail;
    p.faultCode = 0;
    p.landmarksFailed = 2;
    p.landmarksTotal = 20;
    p.cycleMs = 0x0001'2345; // 74565 ms
    p.landmarkOk.assign(20, true);
    p.landmarkOk[3] = false;
    p.landmarkOk[17] = false;
    r.publishResult(p);
    std::vector<std::uint16_t> v;
    ASSERT_EQ(r.read(100, 36, v), ModbusException::None);
    EXPECT_EQ(v[1], 42);     // DONE_SEQ
    EXPECT_EQ(v[2], 2);      // STATUS done
    EXPECT_EQ(v[3], 2);      // RESULT fail
    EXPECT_EQ(v[5], 2);      // LANDMARKS_FAILED
    EXPECT_EQ(v[6], 20);     // LANDMARKS_TOTAL
    EXPECT_EQ(v[7], 0x0001); // CYCLE_MS high word first
    EXPECT_EQ(v[8], 0x2345);
    EXPECT_EQ(v[20], 0xFFF7); // word 0: landmarks 0..15, bit 3 clear
    EXPECT_EQ(v[21], 0x000D); // word 1: landmarks 16..19 = bits 0,2,3 set, bit 1 (landmark 17) clear
    EXPECT_EQ(v[22], 0);
}

TEST(PlcRegisterMap, TheSeatIsPublishedWithTheResultInTheFreeRegistersOfItsBlock)
{
    RegisterMap r;
    makeReady(r);
    PublishedResult p;
    p.seq = 7;
    p.result = PlcResult::Aborted;
    p.faultCode = 32;
    p.seatShiftUm = 2003;
    p.seatRotationMdeg = 65535;
    r.publishResult(p);
    std::vector<std::uint16_t> v;
    ASSERT_EQ(r.read(100, 36, v), ModbusException::None);
    EXPECT_EQ(v[1], 7);      // DONE_SEQ in the same block
    EXPECT_EQ(v[4], 32);     // FAULT_CODE part-not-seated
    EXPECT_EQ(v[12], 2003);  // SEAT_SHIFT_UM (112)
    EXPECT_EQ(v[13], 65535); // SEAT_ROTATION_MDEG (113)
    EXPECT_EQ(v[11], 0);     // LAST_REJECT_REASON untouched
    EXPECT_EQ(v[14], 7);     // ACQ_DONE_SEQ: a cycle that ended before its last grab frees the part with DONE_SEQ
    EXPECT_EQ(v[15], 1);     // RESULT_SEQ: the first result
    EXPECT_EQ(v[18], 0);     // 118..119 stay free
    EXPECT_EQ(v[19], 0);
    // The PLC cannot write them.
    EXPECT_EQ(writeOne(r, 112, 1), ModbusException::IllegalDataAddress);
    EXPECT_EQ(writeOne(r, 113, 1), ModbusException::IllegalDataAddress);
}

TEST(InspectionRecordToPublished, TheSeatInMicrometresAndMillidegreesSaturating)
{
    InspectionRecord record;
    EXPECT_EQ(record.toPublished(PlcStatus::Done).seatShiftUm, 0); // no alignment: 0
    record.alignment = {{"method", "silhouette"}, {"shift_mm", 0.3124}, {"rotation_deg", 0.2506}};
    auto p = record.toPublished(PlcStatus::Done);
    EXPECT_EQ(p.seatShiftUm, 312);      // 312.4 µm rounded
    EXPECT_EQ(p.seatRotationMdeg, 251); // 250.6 mdeg rounded
    record.alignment = {{"shift_mm", 70.0}, {"rotation_deg", 66.0}};
    p = record.toPublished(PlcStatus::Done);
    EXPECT_EQ(p.seatShiftUm, 65535); // 70 000 µm saturates
    EXPECT_EQ(p.seatRotationMdeg, 65535);
    record.alignment = {{"shift_mm", nullptr}};
    EXPECT_EQ(record.toPublished(PlcStatus::Done).seatShiftUm, 0);
}

// HEALTH_WARNINGS (146, docs/plc.md): bit k for the k-th figure of
// vision::HealthFigure beyond its limit — backlight 0, uniformity 1, dust 2,
// focus 3, contrast 4, noise 5 — written with the result, a manual cycle's too
// (the station's health is not the PLC's handshake); a cycle that examined
// nothing leaves it as it was.
TEST(PlcRegisterMap, HealthWarningsAreABitPerFigureWrittenWithTheResult)
{
    RegisterMap r;
    makeReady(r);
    InspectionRecord record;
    record.triggerSeq = 4;
    record.verdict = Verdict::Pass;
    record.health = HealthRecord{};
    record.health->warnings = {vision::HealthFigure::Dust, vision::HealthFigure::Focus};
    r.publishResult(record.toPublished(PlcStatus::Done));
    std::vector<std::uint16_t> v;
    ASSERT_EQ(r.read(100, 124, v), ModbusException::None);
    EXPECT_EQ(v[46], 0b001100); // 146: dust (bit 2) and focus (bit 3)
    EXPECT_EQ(v[1], 4);         // in the block of DONE_SEQ
    EXPECT_EQ(v[45], 0);        // 145, the missed triggers' low word, untouched
    EXPECT_EQ(v[47], 0);        // 147 stays free

    // A manual cycle: the station's health changes, the PLC's result registers do not.
    record.manual = true;
    record.triggerSeq = 9;
    record.health->warnings = {vision::HealthFigure::Backlight, vision::HealthFigure::Noise};
    r.publishResult(record.toPublished(PlcStatus::Done));
    EXPECT_EQ(readOne(r, 146), 0b100001); // backlight (bit 0) and noise (bit 5)
    EXPECT_EQ(readOne(r, 101), 4);

    // No view examined (an abort before the first grab): the warnings stand.
    InspectionRecord aborted;
    aborted.triggerSeq = 10;
    aborted.verdict = Verdict::Aborted;
    r.publishResult(aborted.toPublished(PlcStatus::Done));
    EXPECT_EQ(readOne(r, 101), 10);
    EXPECT_EQ(readOne(r, 146), 0b100001);
    // Every figure back within: 0.
    record.health->warnings.clear();
    r.publishResult(record.toPublished(PlcStatus::Done));
    EXPECT_EQ(readOne(r, 146), 0);
    // The PLC cannot write it.
    EXPECT_EQ(writeOne(r, 146, 1), ModbusException::IllegalDataAddress);
}

TEST(PlcRegisterMap, ManualTriggerLeavesThePlcHandshakeAlone)
{
    RegisterMap r;
    makeReady(r);
    EXPECT_EQ(r.triggerManually(1, "BENCH"), RejectReason::None);
    auto t = r.takeTrigger();
    ASSERT_TRUE(t);
    EXPECT_TRUE(t->manual);
    EXPECT_EQ(readOne(r, 100), 0);
    PublishedResult p;
    p.manual = true;
    p.result = PlcResult::Pass;
    p.seq = 99;
    r.publishResult(p);
    EXPECT_EQ(readOne(r, 101), 0); // DONE_SEQ untouched
    EXPECT_EQ(readOne(r, 103), 0); // RESULT untouched
    EXPECT_EQ(readOne(r, 102), 2); // STATUS done
    EXPECT_EQ(r.triggerManually(3, "X"), RejectReason::UnknownProgram);
}

TEST(PlcRegisterMap, CommandRegisterQueuesAbortAndReadsZero)
{
    RegisterMap r;
    makeReady(r);
    ASSERT_EQ(writeOne(r, 10, 1), ModbusException::None);
    EXPECT_EQ(readOne(r, 10), 0);
    EXPECT_TRUE(r.hasWork());
    auto c = r.takeCommands();
    EXPECT_TRUE(c.abort);
    EXPECT_FALSE(c.resetFault);
    EXPECT_FALSE(r.takeCommands().any());
    EXPECT_FALSE(r.hasWork());
    // An abort and a fault reset written before either is taken: both are kept.
    ASSERT_EQ(writeOne(r, 10, 1), ModbusException::None);
    ASSERT_EQ(writeOne(r, 10, 2), ModbusException::None);
    c = r.takeCommands();
    EXPECT_TRUE(c.abort);
    EXPECT_TRUE(c.resetFault);
}

} // namespace
} // namespace hg::station

namespace hg::station {
namespace {

// STATUS 5 (maintenance, an extension): entered only from an idle map with no
// trigger pending, atomically with trigger acceptance; triggers meanwhile are
// refused as not ready (LAST_REJECT_REASON 3) and counted.
TEST(PlcRegisterMap, MaintenanceRefusesTriggersAndIsEnteredOnlyWhenIdle)
{
    RegisterMap r;
    EXPECT_FALSE(r.enterMaintenance()); // still starting
    makeReady(r);
    ASSERT_TRUE(r.enterMaintenance());
    EXPECT_EQ(readOne(r, reg::Status), 5);
    EXPECT_EQ(r.triggerManually(1, "S1"), RejectReason::NotReady);
    EXPECT_EQ(readOne(r, reg::RejectedTriggers), 1);
    EXPECT_EQ(readOne(r, reg::LastRejectReason), 3);
    r.setStatus(PlcStatus::Ready);
    EXPECT_EQ(r.triggerManually(1, "S2"), RejectReason::None); // accepted: STATUS busy, one pending
    EXPECT_FALSE(r.enterMaintenance());
    EXPECT_EQ(readOne(r, reg::Status), 1);
}

TEST(PlcRegisterMap, CyclePurposeTakesProductionMasterStudyAndRefusesAnythingElse)
{
    RegisterMap r;
    makeReady(r);
    for (std::uint16_t v : {1, 2, 0}) {
        EXPECT_EQ(writeOne(r, 11, v), ModbusException::None) << v;
        EXPECT_EQ(readOne(r, 11), v); // CYCLE_PURPOSE reads back what applies
    }
    ASSERT_EQ(writeOne(r, 11, 2), ModbusException::None);
    for (std::uint16_t v : {3, 4, 255, 65535}) {
        EXPECT_EQ(writeOne(r, 11, v), ModbusException::IllegalDataValue) << v;
        EXPECT_EQ(readOne(r, 11), 2) << "changed by the refused value " << v;
        EXPECT_EQ(r.purpose(), CyclePurpose::Study);
    }
    // All or nothing: a trigger in the same block as a bad purpose is not taken.
    std::array<std::uint16_t, 12> block{};
    block[0] = 9;  // TRIGGER_SEQ
    block[1] = 1;  // PART_PROGRAM
    block[11] = 7; // CYCLE_PURPOSE: no such purpose
    EXPECT_EQ(r.write(0, block), ModbusException::IllegalDataValue);
    EXPECT_FALSE(r.takeTrigger());
    EXPECT_EQ(readOne(r, 0), 0);
    EXPECT_EQ(hg::enumName(CyclePurpose::Master), "master");
    EXPECT_EQ(hg::parseEnum<CyclePurpose>("study"), CyclePurpose::Study);
    EXPECT_FALSE(hg::parseEnum<CyclePurpose>("golden"));
}

TEST(PlcRegisterMap, ThePurposeIsLatchedWithTheTriggerAndTheLastWriterWins)
{
    RegisterMap r;
    makeReady(r);
    // One FC16 block: program, purpose master and the trigger together.
    std::array<std::uint16_t, 12> block{};
    block[0] = 1;
    block[1] = 1;
    block[11] = 1;
    ASSERT_EQ(r.write(0, block), ModbusException::None);
    auto first = r.takeTrigger();
    ASSERT_TRUE(first);
    EXPECT_EQ(first->purpose, CyclePurpose::Master);
    // The maintenance socket writes the same register: it wins over the PLC's earlier write ...
    r.setPurpose(CyclePurpose::Study);
    EXPECT_EQ(readOne(r, 11), 2);
    EXPECT_EQ(first->purpose, CyclePurpose::Master); // the latched request keeps its purpose
    r.setStatus(PlcStatus::Ready);
    EXPECT_EQ(r.triggerManually(1, "M"), RejectReason::None);
    EXPECT_EQ(r.takeTrigger()->purpose, CyclePurpose::Study);
    // ... and a later PLC write wins over it.
    r.setStatus(PlcStatus::Ready);
    ASSERT_EQ(writeOne(r, 11, 0), ModbusException::None);
    ASSERT_EQ(writeOne(r, 0, 2), ModbusException::None);
    EXPECT_EQ(r.takeTrigger()->purpose, CyclePurpose::Production);
}

// PART_TEMPERATURE (12, docs/plc.md): a signed 16-bit word in 0.01 °C, 0x8000
// no reading; every value is taken and reads back, and the value in the
// register when a trigger is accepted goes with it, as CYCLE_PURPOSE does.
TEST(PlcRegisterMap, ThePartTemperatureIsSignedHundredthsOfADegreeLatchedWithTheTrigger)
{
    EXPECT_EQ(decodeTemperature(2150), 21.50);
    EXPECT_EQ(decodeTemperature(0), 0.0);
    EXPECT_EQ(decodeTemperature(65036), -5.00); // -500 as a 16-bit word: 65536 - 500
    EXPECT_EQ(decodeTemperature(0x7FFF), 327.67);
    EXPECT_EQ(decodeTemperature(0x8001), -327.67);
    EXPECT_FALSE(decodeTemperature(0x8000)); // no reading

    RegisterMap r;
    makeReady(r);
    for (std::uint16_t v : {2150, 65036, 0, 0x7FFF, 0x8001, 0x8000}) {
        EXPECT_EQ(writeOne(r, 12, v), ModbusException::None) << v;
        EXPECT_EQ(readOne(r, 12), v);
    }
    // One FC16 block from 0: program, serial, purpose and a part at 21.50 °C with the trigger.
    std::array<std::uint16_t, 13> block{};
    block[0] = 1;     // TRIGGER_SEQ
    block[1] = 1;     // PART_PROGRAM
    block[12] = 2150; // PART_TEMPERATURE
    ASSERT_EQ(r.write(0, block), ModbusException::None);
    auto first = r.takeTrigger();
    ASSERT_TRUE(first);
    ASSERT_TRUE(first->partTemperatureC);
    EXPECT_EQ(*first->partTemperatureC, 21.50);
    // Written before the next trigger: -5.00 °C goes with it; the first keeps its own.
    r.setStatus(PlcStatus::Ready);
    ASSERT_EQ(writeOne(r, 12, 65036), ModbusException::None);
    ASSERT_EQ(writeOne(r, 0, 2), ModbusException::None);
    auto second = r.takeTrigger();
    ASSERT_TRUE(second && second->partTemperatureC);
    EXPECT_EQ(*second->partTemperatureC, -5.00);
    EXPECT_EQ(*first->partTemperatureC, 21.50);
    // 0x8000: the trigger carries no reading; a manual trigger takes the register's too.
    r.setStatus(PlcStatus::Ready);
    ASSERT_EQ(writeOne(r, 12, 0x8000), ModbusException::None);
    ASSERT_EQ(writeOne(r, 0, 3), ModbusException::None);
    auto third = r.takeTrigger();
    ASSERT_TRUE(third);
    EXPECT_FALSE(third->partTemperatureC);
    r.setStatus(PlcStatus::Ready);
    ASSERT_EQ(writeOne(r, 12, 2150), ModbusException::None);
    EXPECT_EQ(r.triggerManually(1, "M"), RejectReason::None);
    EXPECT_EQ(r.takeTrigger()->partTemperatureC, std::optional<double>(21.50));
}

} // namespace
} // namespace hg::station

namespace hg::station {
namespace {

// The production-line handshake (docs/plc.md): ACQ_DONE_SEQ, RESULT_SEQ, the
// counters, the ring of the last results and the recipe changeover, with
// register values worked out by hand.

PublishedResult result(std::uint16_t seq, PlcResult verdict, std::uint32_t cycleMs = 0)
{
    PublishedResult p;
    p.seq = seq;
    p.result = verdict;
    p.cycleMs = cycleMs;
    return p;
}

std::vector<std::uint16_t> readBlock(const RegisterMap& r, std::uint16_t address, std::uint16_t count)
{
    std::vector<std::uint16_t> v;
    EXPECT_EQ(r.read(address, count, v), ModbusException::None);
    return v;
}

void triggerProgram1(RegisterMap& r, std::uint16_t seq)
{
    std::array<std::uint16_t, 2> block{seq, 1};
    ASSERT_EQ(r.write(0, block), ModbusException::None);
}

TEST(PlcHandshake, AcquisitionDoneComesFirstAndDoneSeqBringsItAlongWhenTheCycleEndedEarlier)
{
    RegisterMap r;
    makeReady(r);
    triggerProgram1(r, 5);
    ASSERT_TRUE(r.takeTrigger());
    r.acquisitionDone(5);
    EXPECT_EQ(readOne(r, 114), 5); // ACQ_DONE_SEQ
    EXPECT_EQ(readOne(r, 101), 0); // DONE_SEQ not yet
    r.publishResult(result(5, PlcResult::Pass));
    EXPECT_EQ(readOne(r, 114), 5);
    EXPECT_EQ(readOne(r, 101), 5);
    // Trigger 6 faults before its last grab: ACQ_DONE_SEQ moves in the same write as DONE_SEQ.
    triggerProgram1(r, 6);
    ASSERT_TRUE(r.takeTrigger());
    EXPECT_EQ(readOne(r, 114), 5);
    auto faulted = result(6, PlcResult::Aborted);
    faulted.faultCode = 10;
    r.publishResult(faulted);
    EXPECT_EQ(readOne(r, 114), 6);
    EXPECT_EQ(readOne(r, 101), 6);
    // A manual cycle's result leaves it alone, like DONE_SEQ.
    auto manual = result(0, PlcResult::Pass);
    manual.manual = true;
    r.publishResult(manual);
    EXPECT_EQ(readOne(r, 114), 6);
    EXPECT_EQ(readOne(r, 115), 2); // RESULT_SEQ counts the PLC's results only
}

TEST(PlcHandshake, CountersAreU32HighWordFirstAndCountThePlcsTriggersAndResults)
{
    RegisterMap r;
    makeReady(r);
    // 65 537 passes = 0x0001'0001; RESULT_SEQ wraps at 65 536 to 1.
    for (std::uint32_t i = 1; i <= 65'537; ++i) {
        const auto seq = static_cast<std::uint16_t>(i % 60'000 + 1);
        triggerProgram1(r, seq);
        ASSERT_TRUE(r.takeTrigger());
        r.publishResult(result(seq, PlcResult::Pass));
    }
    auto v = readBlock(r, 136, 10);
    EXPECT_EQ(v, (std::vector<std::uint16_t>{0x0001, 0x0001, 0x0001, 0x0001, 0, 0, 0, 0, 0, 0}));
    EXPECT_EQ(readOne(r, 115), 1); // RESULT_SEQ 65 537 mod 65 536
    // A fail, an error, a refused trigger (busy) and a refused manual trigger (not counted).
    triggerProgram1(r, 7);
    triggerProgram1(r, 8); // busy: missed
    EXPECT_EQ(r.triggerManually(1, "X"), RejectReason::Busy);
    ASSERT_TRUE(r.takeTrigger());
    r.publishResult(result(7, PlcResult::Fail));
    triggerProgram1(r, 9);
    ASSERT_TRUE(r.takeTrigger());
    r.publishResult(result(9, PlcResult::Aborted));
    v = readBlock(r, 136, 10);
    // triggers 65 539 = 0x0001'0003, passes 0x0001'0001, fails 1, faults 1, missed 1.
    EXPECT_EQ(v, (std::vector<std::uint16_t>{0x0001, 0x0003, 0x0001, 0x0001, 0, 1, 0, 1, 0, 1}));
    EXPECT_EQ(readOne(r, 110), 2); // REJECTED_TRIGGERS counts the manual refusal too
    const auto snapshot = r.snapshot();
    EXPECT_EQ(readCounters(snapshot), (PlcCounters{65'539, 65'537, 1, 1, 1}));
    EXPECT_EQ(r.counters(), readCounters(snapshot));
    EXPECT_EQ(readU32(snapshot, reg::TriggerCount), 0x0001'0003u);
}

TEST(PlcHandshake, ResultSeqWrapsFrom65535To0AndTheRingKeepsItsPlace)
{
    RegisterMap r;
    makeReady(r);
    for (std::uint32_t i = 1; i <= 65'535; ++i) {
        triggerProgram1(r, static_cast<std::uint16_t>(i % 2 + 1));
        ASSERT_TRUE(r.takeTrigger());
        r.publishResult(result(static_cast<std::uint16_t>(i % 2 + 1), PlcResult::Pass));
    }
    EXPECT_EQ(readOne(r, 115), 65'535);
    EXPECT_EQ(readOne(r, 160 + 7 * 8), 65'535); // 65 535 mod 8 = 7
    triggerProgram1(r, 500);
    ASSERT_TRUE(r.takeTrigger());
    r.publishResult(result(500, PlcResult::Fail, 1234));
    EXPECT_EQ(readOne(r, 115), 0);
    // 65 536 results: entry 0 holds result sequence number 0, trigger 500.
    EXPECT_EQ(readBlock(r, 160, 8), (std::vector<std::uint16_t>{0, 500, 2, 0, 0, 0, 0, 1234}));
    EXPECT_EQ(readOne(r, 160 + 7 * 8), 65'535); // the one before it stays
}

TEST(PlcHandshake, TheRingHoldsTheLastEightResultsAtResultSeqModEight)
{
    RegisterMap r;
    makeReady(r);
    // Ten results: trigger 100 + n, alternating pass and fail, cycle time 70 000 + n ms.
    for (std::uint16_t n = 1; n <= 10; ++n) {
        triggerProgram1(r, static_cast<std::uint16_t>(100 + n));
        ASSERT_TRUE(r.takeTrigger());
        auto p = result(static_cast<std::uint16_t>(100 + n), n % 2 ? PlcResult::Pass : PlcResult::Fail, 70'000u + n);
        p.landmarksFailed = static_cast<std::uint16_t>(n % 2 ? 0 : n);
        p.landmarksTotal = 12;
        r.publishResult(p);
    }
    const auto ring = readBlock(r, 160, 64);
    // Entries 0..2 hold results 8, 9, 10 (9 and 10 overwrote 1 and 2), entries 3..7 results 3..7.
    const std::vector<std::uint16_t> expected{
        8,  108, 2, 0, 8,  12, 1, 70008 - 65536, // entry 0: result 8, a fail with 8 failed, 70 008 ms
        9,  109, 1, 0, 0,  12, 1, 70009 - 65536, // entry 1: result 9 overwrote result 1
        10, 110, 2, 0, 10, 12, 1, 70010 - 65536, // entry 2: result 10, the newest
        3,  103, 1, 0, 0,  12, 1, 70003 - 65536, // entry 3: result 3, the oldest kept
        4,  104, 2, 0, 4,  12, 1, 70004 - 65536, //
        5,  105, 1, 0, 0,  12, 1, 70005 - 65536, //
        6,  106, 2, 0, 6,  12, 1, 70006 - 65536, //
        7,  107, 1, 0, 0,  12, 1, 70007 - 65536, //
    };
    EXPECT_EQ(ring, expected);
    EXPECT_EQ(readOne(r, 115), 10); // RESULT_SEQ: newest entry 10 mod 8 = 2
}

TEST(PlcHandshake, ResetCountersIsCommandThreeAndKeepsATriggerWhoseResultIsToCome)
{
    RegisterMap r;
    makeReady(r);
    triggerProgram1(r, 1);
    ASSERT_TRUE(r.takeTrigger());
    r.publishResult(result(1, PlcResult::Pass));
    triggerProgram1(r, 2);
    triggerProgram1(r, 3); // busy: missed
    EXPECT_EQ(r.counters(), (PlcCounters{2, 1, 0, 0, 1}));
    // Reset while trigger 2 runs: it stays counted, so its result keeps TRIGGERS = PASSES + FAILS + FAULTS.
    ASSERT_EQ(writeOne(r, 10, 3), ModbusException::None);
    EXPECT_EQ(readOne(r, 10), 0); // COMMAND reads 0
    EXPECT_EQ(readBlock(r, 136, 10), (std::vector<std::uint16_t>{0, 1, 0, 0, 0, 0, 0, 0, 0, 0}));
    EXPECT_FALSE(r.takeCommands().any()); // nothing for the runner: the write did it
    ASSERT_TRUE(r.takeTrigger());
    r.publishResult(result(2, PlcResult::Fail));
    EXPECT_EQ(r.counters(), (PlcCounters{1, 0, 1, 0, 0}));
    // Between cycles a reset gives all zeros; RESULT_SEQ and the ring are not counters.
    ASSERT_EQ(writeOne(r, 10, 3), ModbusException::None);
    EXPECT_EQ(readBlock(r, 136, 10), std::vector<std::uint16_t>(10, 0));
    EXPECT_EQ(readOne(r, 115), 2);
    for (std::uint16_t bad : {4, 5, 255, 65535}) EXPECT_EQ(writeOne(r, 10, bad), ModbusException::IllegalDataValue);
}

TEST(PlcHandshake, ChangeoverShowsPreparingUntilTheDaemonPreparedTheProgram)
{
    RegisterMap r;
    makeReady(r);
    EXPECT_EQ(readBlock(r, 116, 2), (std::vector<std::uint16_t>{0, 0})); // ACTIVE_PROGRAM 0, PROGRAM_STATE none
    ASSERT_EQ(writeOne(r, 1, 7), ModbusException::None);
    EXPECT_EQ(readBlock(r, 116, 2), (std::vector<std::uint16_t>{7, 2})); // preparing
    EXPECT_TRUE(r.hasWork());
    EXPECT_EQ(r.takeChangeover(), std::optional<std::uint16_t>(7));
    EXPECT_FALSE(r.takeChangeover());
    r.programPrepared(7, ProgramState::Ready);
    EXPECT_EQ(readBlock(r, 116, 2), (std::vector<std::uint16_t>{7, 1})); // ready
    // Writing the active program again (every trigger block does) changes nothing.
    ASSERT_EQ(writeOne(r, 1, 7), ModbusException::None);
    EXPECT_FALSE(r.takeChangeover());
    EXPECT_EQ(readOne(r, 117), 1);
    // Program 1 selected, then 7 again before 1 was prepared: the report on 1 is stale.
    ASSERT_EQ(writeOne(r, 1, 1), ModbusException::None);
    ASSERT_EQ(writeOne(r, 1, 7), ModbusException::None);
    r.programPrepared(1, ProgramState::Ready);
    EXPECT_EQ(readBlock(r, 116, 2), (std::vector<std::uint16_t>{7, 2}));
    EXPECT_EQ(r.takeChangeover(), std::optional<std::uint16_t>(7));
    r.programPrepared(7, ProgramState::LoadFailed);
    EXPECT_EQ(readOne(r, 117), 4); // load failed
    // The same program written again retries the load.
    ASSERT_EQ(writeOne(r, 1, 7), ModbusException::None);
    EXPECT_EQ(readOne(r, 117), 2);
    EXPECT_EQ(r.takeChangeover(), std::optional<std::uint16_t>(7));
    r.programPrepared(7, ProgramState::Ready);
    // PART_PROGRAM 0: no program.
    ASSERT_EQ(writeOne(r, 1, 0), ModbusException::None);
    EXPECT_EQ(readBlock(r, 116, 2), (std::vector<std::uint16_t>{0, 0}));
    EXPECT_FALSE(r.takeChangeover());
}

TEST(PlcHandshake, AnUnknownProgramIsNotReadyAtOnceAndItsTriggerIsRefused)
{
    RegisterMap r;
    makeReady(r);
    std::array<std::uint16_t, 2> block{3, 9}; // TRIGGER_SEQ 3 with program 9, not configured
    ASSERT_EQ(r.write(0, block), ModbusException::None);
    EXPECT_EQ(readBlock(r, 116, 2), (std::vector<std::uint16_t>{9, 3})); // unknown program, in the same write
    EXPECT_FALSE(r.takeChangeover());
    EXPECT_FALSE(r.takeTrigger());
    EXPECT_EQ(readOne(r, 100), 0);
    EXPECT_EQ(readOne(r, 111), 2); // LAST_REJECT_REASON unknown program
    EXPECT_EQ(r.counters().missed, 1u);
    // A reload that configures it: the daemon prepares it; one that drops the active program: unknown.
    r.setKnownPrograms({1, 7, 9});
    EXPECT_EQ(readOne(r, 117), 2);
    EXPECT_EQ(r.takeChangeover(), std::optional<std::uint16_t>(9));
    r.programPrepared(9, ProgramState::Ready);
    r.setKnownPrograms({1, 7, 9}); // the same list: prepared again (the file may have changed)
    EXPECT_EQ(r.takeChangeover(), std::optional<std::uint16_t>(9));
    r.setKnownPrograms({1});
    EXPECT_EQ(readOne(r, 117), 3);
    EXPECT_FALSE(r.takeChangeover());
    r.programPrepared(9, ProgramState::Ready); // a late report cannot make an unknown program ready
    EXPECT_EQ(readOne(r, 117), 3);
    EXPECT_EQ(hg::enumName(ProgramState::LoadFailed), "load failed");
}

} // namespace
} // namespace hg::station
