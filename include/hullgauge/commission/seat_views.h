// Views for the seat chosen on the twin (docs/commissioning.md, "--fix";
// docs/alignment.md, "Views for the seat"). The seat is measured on a
// program's first views; where the twin's seat test finds them wanting,
// each candidate pose the fixture reaches is tried as the first view, the
// first planned view second, at nominal seats on the twin, and the one
// whose measured seats move the landmarks least is chosen.
//
// Pure computation on values, as the verification it runs.
#pragma once

#include "hullgauge/commission/verification.h"

#include <vector>

namespace hg::commission {

/// The poses tried: a turntable's rotation every 45° at declinations of 30°
/// and 60° (each clamped into the ranges, none twice); a rail's travel at
/// five evenly spaced places.
std::vector<geometry::FixturePose> seatViewCandidates(const geometry::FixtureKinematics& fixture);

/// One candidate's figures on the twin.
struct SeatViewTrial {
    geometry::FixturePose pose;
    std::size_t beyondU = 0;         ///< landmark-seats whose seat error exceeded U (the seat test)
    double landmarkErrorMaxMm = 0.0; ///< the largest seat error at a landmark
    double shiftMm = 0.0;            ///< the largest seat error at the reference point
    double rotationDeg = 0.0;
};

struct SeatViewChoice {
    /// The views for the seat: the chosen candidate, then the first planned
    /// view; empty when no candidate was tried.
    std::vector<geometry::FixturePose> seatViews;
    std::vector<SeatViewTrial> trials; ///< in the order tried; the chosen one is seatViews[0]'s
};

/// Tries every candidate of seatViewCandidates (other than the first planned
/// view) first in `problem`'s poses, at `seats` nominal seats of `options`'
/// play (no seeded defects), and chooses the one with the fewest landmark
/// errors beyond U, then the smallest largest error.
SeatViewChoice chooseSeatViews(const VerificationProblem& problem, const VerificationOptions& options,
                               const FrameSourceFactory& frames, std::size_t seats);

} // namespace hg::commission
