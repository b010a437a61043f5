// Views for the seat chosen on the twin (docs/commissioning.md, "--fix").
#include "hullgauge/commission/seat_views.h"

#include <algorithm>
#include <cmath>
#include <tuple>

namespace hg::commission {

std::vector<geometry::FixturePose> seatViewCandidates(const geometry::FixtureKinematics& fixture)
{
    std::vector<geometry::FixturePose> out;
    const auto add = [&](const geometry::FixturePose& p) {
        if (fixture.reachable(p) && std::find(out.begin(), out.end(), p) == out.end()) out.push_back(p);
    };
    if (fixture.type == geometry::FixtureType::Rail) {
        const geometry::Range r = fixture.railRangeMm;
        for (int k = 0; k < 5; ++k) add({0.0, 0.0, r.min + (r.max - r.min) * k / 4.0});
        return out;
    }
    const geometry::Range rot = fixture.rotationRangeDeg, dec = fixture.declinationRangeDeg;
    for (double declination : {30.0, 60.0})
        for (int k = 0; k < 8; ++k) {
            // Turns from −135° to 180°, within the range; a turntable limited to
            // less than a turn gets the ones it reaches.
            const double rotation = -135.0 + 45.0 * k;
            add({std::clamp(rotation, rot.min, rot.max), std::clamp(declination, dec.min, dec.max)});
        }
    return out;
}

namespace {

SeatViewTrial trial(const VerificationProblem& problem, const VerificationOptions& options,
                    const FrameSourceFactory& frames, const geometry::FixturePose& first)
{
    VerificationProblem p = problem;
    p.poses = {first};
    p.viewLandmarks = {{}};
    for (std::size_t k = 0; k < problem.poses.size(); ++k) {
        if (problem.poses[k] == first) continue;
        p.poses.push_back(problem.poses[k]);
        p.viewLandmarks.push_back(k < problem.viewLandmarks.size() ? problem.viewLandmarks[k]
                                                                   : std::vector<std::string>{});
    }
    const VerificationReport r = verifyProgram(p, options, frames);
    SeatViewTrial t;
    t.pose = first;
    t.shiftMm = r.seatErrorMaxShiftMm;
    t.rotationDeg = r.seatErrorMaxRotationDeg;
    for (const LandmarkVerification& v : r.landmarks) {
        t.beyondU += v.seatErrorBeyondU;
        t.landmarkErrorMaxMm = std::max(t.landmarkErrorMaxMm, v.seatErrorMaxMm.value_or(0.0));
    }
    return t;
}

} // namespace

SeatViewChoice chooseSeatViews(const VerificationProblem& problem, const VerificationOptions& options,
                               const FrameSourceFactory& frames, std::size_t seats)
{
    SeatViewChoice out;
    if (problem.poses.empty() || !problem.station) return out;
    VerificationOptions o = options;
    o.seats = seats;
    o.defectMultiples = {};
    for (const geometry::FixturePose& c : seatViewCandidates(problem.station->fixture))
        if (!(c == problem.poses.front())) out.trials.push_back(trial(problem, o, frames, c));
    if (out.trials.empty()) return out;
    const auto best = std::min_element(out.trials.begin(), out.trials.end(), [](const auto& a, const auto& b) {
        return std::tie(a.beyondU, a.landmarkErrorMaxMm) < std::tie(b.beyondU, b.landmarkErrorMaxMm);
    });
    out.seatViews = {best->pose, problem.poses.front()};
    return out;
}

} // namespace hg::commission
