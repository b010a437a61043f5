// Work run in a process of its own (include/hullgauge/common/child_process.h).
#include "hullgauge/common/child_process.h"

#include <gtest/gtest.h>

#include <csignal>
#include <cstdlib>
#include <stdexcept>
#include <unistd.h>

namespace {

using hg::ChildOutcome;
using namespace std::chrono_literals;

// More than a pipe holds (64 KiB): the parent reads while the child writes.
TEST(ChildProcess, WhatTheWorkReturnsComesBackWhole)
{
    std::string expected;
    for (int i = 0; expected.size() < 5'000'000; ++i) expected += std::to_string(i) + ',';
    const ChildOutcome outcome = hg::runInChild(
        [] {
            std::string text;
            for (int i = 0; text.size() < 5'000'000; ++i) text += std::to_string(i) + ',';
            return text;
        },
        60s);
    ASSERT_EQ(outcome.kind, ChildOutcome::Kind::finished) << outcome.detail;
    EXPECT_EQ(outcome.output.size(), expected.size());
    EXPECT_TRUE(outcome.output == expected);
}

TEST(ChildProcess, AFaultInTheWorkIsTheSignalThatEndedIt)
{
    const ChildOutcome outcome = hg::runInChild([]() -> std::string { std::abort(); }, 60s);
    ASSERT_EQ(outcome.kind, ChildOutcome::Kind::signalled);
    EXPECT_EQ(outcome.signal, SIGABRT);
    EXPECT_EQ(hg::describeSignal(SIGABRT).rfind("signal 6 (", 0), 0u) << hg::describeSignal(SIGABRT);
    EXPECT_TRUE(outcome.output.empty());
}

// The work never ends, so the outcome cannot depend on how fast the machine is.
TEST(ChildProcess, WorkStillRunningAtTheDeadlineIsKilled)
{
    const ChildOutcome outcome = hg::runInChild(
        []() -> std::string {
            for (;;) ::pause();
        },
        200ms);
    EXPECT_EQ(outcome.kind, ChildOutcome::Kind::timedOut);
}

TEST(ChildProcess, WorkThatThrowsHasFailedAndSaysSo)
{
    const ChildOutcome outcome = hg::runInChild([]() -> std::string { throw std::runtime_error("no"); }, 60s);
    EXPECT_EQ(outcome.kind, ChildOutcome::Kind::failed);
    EXPECT_EQ(outcome.detail, "the work threw");
}

// The child's exit runs none of the parent's exit handlers or buffers: a
// line left in this process's stdout buffer is written once, by this process.
TEST(ChildProcess, TheChildFlushesNothingOfTheParents)
{
    testing::internal::CaptureStdout();
    std::printf("once");
    const ChildOutcome outcome = hg::runInChild([] { return std::string("done"); }, 60s);
    std::fflush(stdout);
    EXPECT_EQ(testing::internal::GetCapturedStdout(), "once");
    EXPECT_EQ(outcome.output, "done");
}

} // namespace
