// The register map under the daemon's lock: a PLC reading while results are
// published never sees half of one, and the runner's wait ends on a trigger
// or a command.
#include "plant/plc_registers.h"

#include <atomic>
#include <future>
#include <gtest/gtest.h>
#include <thread>

namespace hg::daemon {
namespace {

using namespace std::chrono_literals;
using station::ModbusException;
using station::PlcResult;
using station::PlcStatus;
using station::PublishedResult;

void makeReady(PlcRegisters& r)
{
    r.setKnownPrograms({1});
    r.setStatus(PlcStatus::Ready);
}

// A reader never sees DONE_SEQ of one cycle with RESULT of another.
TEST(PlcRegisters, ConcurrentReadersSeeConsistentResults)
{
    PlcRegisters r;
    makeReady(r);
    std::atomic<bool> stop{false};
    std::atomic<int> inconsistent{0};
    std::atomic<int> reads{0};
    std::thread reader([&] {
        std::vector<std::uint16_t> v;
        while (!stop) {
            if (r.read(101, 6, v) != ModbusException::None) continue;
            ++reads;
            // Odd sequences pass with 0 failed, even ones fail with seq % 7 + 1 failed.
            auto seq = v[0];
            if (seq == 0) continue;
            bool pass = seq % 2 == 1;
            if (v[2] != (pass ? 1 : 2) || v[4] != (pass ? 0 : seq % 7 + 1)) ++inconsistent;
        }
    });
    for (std::uint16_t seq = 1; seq < 20000; ++seq) {
        PublishedResult p;
        p.seq = seq;
        bool pass = seq % 2 == 1;
        p.result = pass ? PlcResult::Pass : PlcResult::Fail;
        p.landmarksFailed = pass ? 0 : static_cast<std::uint16_t>(seq % 7 + 1);
        p.landmarksTotal = 10;
        r.publishResult(p);
    }
    stop = true;
    reader.join();
    EXPECT_EQ(inconsistent.load(), 0);
}

TEST(PlcRegisters, WaitEndsWithTheTriggerWrittenMeanwhile)
{
    PlcRegisters r;
    makeReady(r);
    // The wait's timeout is far beyond the test's: only the write can end it.
    auto waiter = std::async(std::launch::async, [&] { return r.waitTrigger(std::chrono::hours(1)); });
    std::array<std::uint16_t, 2> block{7, 1}; // TRIGGER_SEQ 7, program 1
    ASSERT_EQ(r.write(0, block), ModbusException::None);
    auto t = waiter.get();
    ASSERT_TRUE(t);
    EXPECT_EQ(t->seq, 7);
    EXPECT_EQ(t->program, 1);
}

TEST(PlcRegisters, WaitEndsWithoutATriggerWhenACommandIsWritten)
{
    PlcRegisters r;
    makeReady(r);
    auto waiter = std::async(std::launch::async, [&] { return r.waitTrigger(std::chrono::hours(1)); });
    std::array<std::uint16_t, 1> reset{2}; // COMMAND = reset fault
    ASSERT_EQ(r.write(station::reg::Command, reset), ModbusException::None);
    EXPECT_FALSE(waiter.get());
    EXPECT_TRUE(r.takeCommands().resetFault);
}

// The recipe changeover wakes the runner between cycles (docs/plc.md).
TEST(PlcRegisters, WaitEndsWithoutATriggerWhenAProgramIsSelected)
{
    PlcRegisters r;
    makeReady(r);
    auto waiter = std::async(std::launch::async, [&] { return r.waitTrigger(std::chrono::hours(1)); });
    std::array<std::uint16_t, 1> program{1};
    ASSERT_EQ(r.write(station::reg::PartProgram, program), ModbusException::None);
    EXPECT_FALSE(waiter.get());
    EXPECT_EQ(r.takeChangeover(), std::optional<std::uint16_t>(1));
}

// A reader never sees DONE_SEQ of one result with the counters or the ring of another.
TEST(PlcRegisters, CountersAndRingChangeWithDoneSeq)
{
    PlcRegisters r;
    makeReady(r);
    std::atomic<bool> stop{false};
    std::atomic<int> inconsistent{0};
    std::thread reader([&] {
        std::vector<std::uint16_t> v;
        while (!stop) {
            if (r.read(100, 124, v) != ModbusException::None) continue;
            const auto doneSeq = v[1];
            const auto resultSeq = v[15];
            const auto passes = (std::uint32_t{v[38]} << 16) | v[39];
            const std::size_t entry = 60 + (resultSeq % 8) * 8;
            // Trigger n is result n: DONE_SEQ, RESULT_SEQ, PASSES, ACQ_DONE_SEQ and the newest entry agree.
            if (doneSeq != resultSeq || passes != resultSeq || v[14] != doneSeq ||
                (resultSeq != 0 && (v[entry] != resultSeq || v[entry + 1] != doneSeq)))
                ++inconsistent;
        }
    });
    for (std::uint16_t seq = 1; seq < 5000; ++seq) {
        std::array<std::uint16_t, 2> block{seq, 1};
        EXPECT_EQ(r.write(0, block), ModbusException::None);
        EXPECT_TRUE(r.waitTrigger(0ms));
        PublishedResult p;
        p.seq = seq;
        p.result = PlcResult::Pass;
        r.publishResult(p);
    }
    stop = true;
    reader.join();
    EXPECT_EQ(inconsistent.load(), 0);
    EXPECT_EQ(r.counters().passes, 4999u);
}

} // namespace
} // namespace hg::daemon
