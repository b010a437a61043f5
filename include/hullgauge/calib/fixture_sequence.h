// The live fixture-axis calibration sequence (docs/calibration.md, dissertation 4.3):
// for every pose move, wait in position, grab, detect the target; then solve
// the axes. The station's hardware is reached through callbacks, so the same
// sequence runs from `hullgauge calibrate run` (its own drivers) and from the
// daemon's maintenance socket (the daemon's devices, production paused) —
// and this module stays free of I/O.
#pragma once

#include "hullgauge/calib/fixture_axes.h"
#include "hullgauge/calib/target.h"
#include "hullgauge/common/status.h"
#include "hullgauge/geometry/fixture.h"

#include <cstddef>
#include <functional>
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

namespace hg::calib {

/// The station's hardware as the sequence reaches it; each step answers an hg::Status.
struct FixtureSequenceIo {
    /// Move to the pose and wait until in position.
    std::function<Status(const geometry::FixturePose&)> moveTo;
    /// Grab one frame.
    std::function<Status(cv::Mat&)> grab;
    /// Each pose's line: "[i/n] rotation … deg: 54 corners" (optional).
    std::function<void(std::size_t index, std::size_t count, const std::string& line)> progress;
    /// Each grabbed frame with its file-safe name (optional: keep the images).
    std::function<void(const std::string& name, const cv::Mat& image)> keep;
    /// Asked before each pose: true stops the sequence (optional).
    std::function<bool()> cancelled;
};

struct FixtureSequenceResult {
    std::vector<FixtureView> views; ///< the poses where the target was found
    FixtureAxesResult axes;
};

/// Runs the sequence over `poses` and solves the axes (calibrateFixtureAxes,
/// `source` names the poses in its errors). A failed step throws
/// hg::FaultError "calibrate run: <step>: <message>" naming the pose; a
/// cancelled sequence throws hg::FaultError "calibrate run: cancelled".
FixtureSequenceResult runFixtureSequence(const std::vector<geometry::FixturePose>& poses, const TargetSpec& target,
                                         const geometry::Intrinsics& camera, geometry::FixtureType type,
                                         const FixtureSequenceIo& io, const std::string& source);

} // namespace hg::calib
