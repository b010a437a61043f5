#include "hullgauge/calib/fixture_sequence.h"

#include "hullgauge/common/error.h"

#include <cstdio>

namespace hg::calib {

FixtureSequenceResult runFixtureSequence(const std::vector<geometry::FixturePose>& poses, const TargetSpec& target,
                                         const geometry::Intrinsics& camera, geometry::FixtureType type,
                                         const FixtureSequenceIo& io, const std::string& source)
{
    auto check = [](const Status& s, const std::string& step) {
        if (!s.ok()) throw FaultError("calibrate run: " + step + ": " + s.message());
    };
    FixtureSequenceResult out;
    for (std::size_t i = 0; i < poses.size(); ++i) {
        if (io.cancelled && io.cancelled()) throw FaultError("calibrate run: cancelled");
        const auto& pose = poses[i];
        const std::string where = fmt::format("{}", geometry::PoseOn{pose, type});
        check(io.moveTo(pose), "move to " + where);
        cv::Mat frame;
        check(io.grab(frame), "grab at " + where);
        char name[96];
        std::snprintf(name, sizeof name, "pose%02zu_r%g_d%g.png", i, pose.rotationDeg, pose.declinationDeg);
        if (io.keep) io.keep(name, frame);
        auto v = detectTarget(frame, target, name);
        if (io.progress)
            io.progress(i, poses.size(),
                        "[" + std::to_string(i + 1) + "/" + std::to_string(poses.size()) + "] " + where + ": " +
                            (v ? std::to_string(v->imagePoints.size()) + " corners" : std::string("target not found")));
        if (v) out.views.push_back({pose, std::move(*v)});
    }
    out.axes = calibrateFixtureAxes(out.views, camera, source);
    return out;
}

} // namespace hg::calib
