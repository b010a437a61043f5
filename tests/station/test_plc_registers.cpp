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

TEST(PlcRegisterMap, StartsInStartingWithEverythingElseZero)
{
    RegisterMap r;
    auto s = r.snapshot();
    EXPECT_EQ(s[102], 4); // STATUS starting (docs/contracts.md §6)
    for (std::size_t a = 0; a < s.size(); ++a) {
        if (a != 102) {
            EXPECT_EQ(s[a], 0) << "address " << a;
        }
    }
}

TEST(PlcRegisterMap, ReadOnlyAndUnmappedWritesAnswerIllegalDataAddress)
{
    RegisterMap r;
    makeReady(r);
    for (std::uint16_t a : {100, 101, 102, 103, 104, 105, 106, 107, 108, 109, 110, 120, 135})
        EXPECT_EQ(writeOne(r, a, 1), ModbusException::IllegalDataAddress) << "read-only " << a;
    for (std::uint16_t a : {12, 50, 99, 112, 119, 136, 1000, 65535})
        EXPECT_EQ(writeOne(r, a, 1), ModbusException::IllegalDataAddress) << "unmapped " << a;
    // A block that starts writable and runs into a read-only register changes nothing.
    std::array<std::uint16_t, 13> block{};
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
    EXPECT_EQ(writeOne(r, 10, 3), ModbusException::IllegalDataValue);      // unknown command
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
    EXPECT_EQ(r.read(0, 136, v), ModbusException::None);
    EXPECT_EQ(v.size(), 136u);
    EXPECT_EQ(r.read(130, 7, v), ModbusException::IllegalDataAddress);
    EXPECT_EQ(r.read(136, 1, v), ModbusException::IllegalDataAddress);
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
    EXPECT_EQ(v[14], 0);     // 114..119 stay free
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
    EXPECT_EQ(toString(CyclePurpose::Master), "master");
    EXPECT_EQ(parsePurpose("study"), CyclePurpose::Study);
    EXPECT_FALSE(parsePurpose("golden"));
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

} // namespace
} // namespace hg::station
