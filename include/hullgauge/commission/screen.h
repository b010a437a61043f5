// Suggested landmarks proven on the station's digital twin before they are
// proposed (docs/commissioning.md, "Suggestions proven on the twin"): the
// landmarks the suggestion chose (plan/landmark_suggest.h), planned and
// capable over the nest's play, are put in the program they are suggested
// for as its `landmarks:` list writes them, planned as commissioning plans
// that program (plan::planProgram) and taken through seats of the nominal
// part on the twin (verification.h, without seeded defects). A landmark that is not observed
// at a seat, that rejects the good part, or whose measured U exceeds 1.25 ×
// its prediction is refused under the rule "twin_<test>" with the twin's
// numbers, and the suggestion spreads again without it.
//
// Pure computation on values, as the verification it runs.
#pragma once

#include "hullgauge/commission/verification.h"
#include "hullgauge/plan/landmark_suggest.h"
#include "hullgauge/plan/planner.h"

#include <cstdint>
#include <string>

namespace hg::commission {

/// The program suggested landmarks go into, before it has any: the CAD model
/// (its solid, B-rep and octree), `part` as its name, `alignment` as its
/// alignment settings, the part program's default inspection settings.
model::PartProgram draftProgram(const model::CadModel& cad, const std::string& part,
                                const model::AlignmentSettings& alignment);

/// What the twin verifies for a program at its planned views: the poses in
/// travel order, the landmarks each view observes, the predicted U per
/// landmark, the station's segmentation (its `segmentation:` section, else
/// the defaults).
VerificationProblem verificationProblem(const model::PartProgram& program, const geometry::Station& station,
                                        const plan::ViewPlan& plan,
                                        const std::vector<inspect::LandmarkCapability>& capability);

struct ScreenOptions {
    std::size_t seats = 8; ///< nominal seats on the twin, drawn within the play
    /// U measured may be at most this times the predicted U: a guard band
    /// under the release's 1.25 ×, as U measured varies with the seat and the
    /// noise and a suggestion has no verification after it.
    double uncertaintyRatio = 1.15;
    double toleranceMm = 0.5; ///< the suggested landmarks' tolerance
    std::uint64_t seed = 1;   ///< of the seats and the twin's noise
};

/// The screen of the header for `base`'s part at `station` (`base` is
/// copied, `station` must outlive the screen); `frames` defaults to the
/// twin's own (twinFrames of the station, seeded from options.seed).
plan::SuggestScreen twinScreen(const model::PartProgram& base, const geometry::Station& station,
                               const ScreenOptions& options, FrameSourceFactory frames = {});

} // namespace hg::commission
