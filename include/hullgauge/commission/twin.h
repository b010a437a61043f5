// The station's digital twin (docs/commissioning.md, "The twin"): a part as
// made, seated at random within the nest's play, taken through a program's
// planned poses exactly as the daemon's cycle takes it — the first
// `correct_poses_after` views at the planned poses, the seat measured on them
// (docs/alignment.md), the remaining poses corrected for that seat, every
// frame segmented and the part inspected through the cameras the fixture
// actually reached. Where the frames come from is the caller's: the twin's
// own renderer (the simulated camera's, hg::sim) when commissioning, an
// independent renderer in the tests that judge the twin.
//
// Pure computation on values: no I/O, no threads of its own.
#pragma once

#include "hullgauge/align/alignment.h"
#include "hullgauge/geometry/station.h"
#include "hullgauge/inspect/inspector.h"
#include "hullgauge/model/mesh.h"
#include "hullgauge/sim/renderer.h"
#include "hullgauge/vision/segmentation.h"

#include <cstddef>
#include <functional>
#include <optional>
#include <random>
#include <vector>

namespace hg::commission {

/// A seat drawn uniformly within the nest's play (docs/daemon.md, "Seating"):
/// the shift and the rotation vector each uniform in the ball of its play, the
/// rotation about `centre` (the nominal mesh's bounding-box centre), then the
/// shift: X ↦ R (X − c) + c + d. The seat is nominal_from_part.
geometry::RigidTransform drawSeat(std::mt19937_64& rng, double shiftMm, double rotationDeg,
                                  const geometry::Vec3& centre);

/// The grey frame (CV_8UC1 or CV_16UC1, the whole sensor) of the part as made
/// seen through `seatedCamera` (camera_from_nominal · seat); `frame` counts the
/// frames of a commissioning run so that each gets fresh, reproducible noise.
using FrameSource = std::function<cv::Mat(const geometry::CameraModel& seatedCamera, std::size_t frame)>;

/// What the twin renders for a station's image quality (`camera.image_quality`,
/// docs/config-reference.md): the background and object levels that give its
/// contrast (the background at 92 % of full scale, as the simulated camera's
/// defaults), its noise, its blur, 8-bit frames, noise seeded from `seed`.
sim::RenderOptions twinRenderOptions(const geometry::ImageQuality& quality, std::uint64_t seed);

/// The twin's own frames: `mesh` (the part as made) rendered by the simulated
/// camera's renderer with `options`, the seed advanced per frame.
FrameSource renderedFrames(const model::TriangleMesh& mesh, const sim::RenderOptions& options);

/// One cycle on the twin.
struct TwinCycle {
    inspect::InspectionResult result;
    /// The part's true seat (nominal_from_part), as drawn: what the measured one is judged against.
    geometry::RigidTransform seat;
    /// The poses the fixture was sent to: planned, corrected after the seat views.
    std::vector<geometry::FixturePose> commanded;
    /// The seat measured on the first views (what corrected the rest).
    std::optional<align::AlignmentResult> provisionalSeat;
    /// Per view: plan::frameMarginPx of the seated part at the commanded pose.
    std::vector<double> frameMarginPx;
};

/// The part's cycle (the header's steps): `planned` poses in travel order,
/// `seatViews` of them before the correction (0: no alignment, nothing
/// corrected), `seat` the part's true seat, `asMade` the mesh whose frame
/// margins are measured. Throws ArgumentError when a frame does not
/// match its camera.
TwinCycle runCycle(const inspect::Inspector& inspector, const geometry::Station& station,
                   const std::vector<geometry::FixturePose>& planned, std::size_t seatViews,
                   const vision::SegmentationSettings& segmentation, const geometry::RigidTransform& seat,
                   const model::TriangleMesh& asMade, const FrameSource& frames, std::size_t firstFrame = 0);

} // namespace hg::commission
