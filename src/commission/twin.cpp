#include "hullgauge/commission/twin.h"

#include "hullgauge/align/pose_correction.h"
#include "hullgauge/plan/program_plan.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>

namespace hg::commission {
namespace {

/// A unit vector of uniformly random direction (a normal sample, normalised).
geometry::Vec3 randomDirection(std::mt19937_64& rng)
{
    std::normal_distribution<double> normal;
    geometry::Vec3 v;
    do v = geometry::Vec3(normal(rng), normal(rng), normal(rng));
    while (v.norm() < 1e-9);
    return v.normalized();
}

/// The captured view of frame `index` at `pose`: the frame seen by the seated
/// camera, inspected through the nominal camera at that pose (the inspector
/// measures the seat itself, docs/alignment.md).
inspect::CapturedView capture(const geometry::Station& station, const geometry::FixturePose& pose,
                              const geometry::RigidTransform& seat, const FrameSource& frames, std::size_t index,
                              std::size_t frame)
{
    const geometry::CameraModel nominal = station.cameraAt(pose);
    inspect::CapturedView view;
    view.id = "v" + std::to_string(index);
    view.camera = nominal;
    view.frame = frames(align::seatedCamera(nominal, seat), frame);
    return view;
}

} // namespace

geometry::RigidTransform drawSeat(std::mt19937_64& rng, double shiftMm, double rotationDeg,
                                  const geometry::Vec3& centre)
{
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    // The cube root of a uniform variable: uniform in the volume of the ball.
    const geometry::Vec3 d = randomDirection(rng) * (shiftMm * std::cbrt(unit(rng)));
    const geometry::Vec3 axis = randomDirection(rng);
    const double angle = geometry::degToRad(rotationDeg * std::cbrt(unit(rng)));
    const geometry::Mat3 R = Eigen::AngleAxisd(angle, axis).toRotationMatrix();
    return {R, centre + d - R * centre};
}

sim::RenderOptions twinRenderOptions(const geometry::ImageQuality& quality, std::uint64_t seed)
{
    constexpr double kFullScale = 255.0;
    constexpr double kBackground = 0.92;
    sim::RenderOptions o;
    o.bitDepth = 8;
    const double contrast = std::min(quality.contrastGrey / kFullScale, kBackground);
    o.backgroundLevel = kBackground;
    o.objectLevel = kBackground - contrast;
    o.noiseSigma = quality.noiseGrey;
    o.blurSigmaPx = quality.blurSigmaPx;
    o.seed = seed;
    return o;
}

FrameSource renderedFrames(const model::TriangleMesh& mesh, const sim::RenderOptions& options)
{
    auto renderer = std::make_shared<const sim::SilhouetteRenderer>(std::vector<model::TriangleMesh>{mesh});
    return [renderer, options](const geometry::CameraModel& camera, std::size_t frame) {
        sim::RenderOptions o = options;
        o.seed = options.seed + frame;
        return renderer->render(camera, o);
    };
}

TwinCycle runCycle(const inspect::Inspector& inspector, const geometry::Station& station,
                   const std::vector<geometry::FixturePose>& planned, std::size_t seatViews,
                   const vision::SegmentationSettings& segmentation, const geometry::RigidTransform& seat,
                   const model::TriangleMesh& asMade, const FrameSource& frames, std::size_t firstFrame)
{
    TwinCycle cycle;
    cycle.seat = seat;
    cycle.commanded = planned;
    std::vector<inspect::SilhouetteView> prepared;
    std::vector<std::string> ids;
    for (std::size_t k = 0; k < planned.size(); ++k) {
        // As the daemon's cycle runner: after the seat views, the rest are
        // taken where they see the seated part as planned (docs/alignment.md,
        // "Poses corrected for the seat").
        if (seatViews > 0 && k == seatViews) {
            cycle.provisionalSeat = inspector.measureSeat(prepared);
            const auto& s = cycle.provisionalSeat;
            if (s && s->measured && s->withinLimits)
                for (std::size_t j = k; j < planned.size(); ++j)
                    cycle.commanded[j] =
                        align::correctPose(station.fixture, planned[j], s->seat, s->referencePoint).pose;
        }
        inspect::CapturedView view = capture(station, cycle.commanded[k], seat, frames, k, firstFrame + k);
        cycle.frameMarginPx.push_back(plan::frameMarginPx(asMade, align::seatedCamera(view.camera, seat)));
        ids.push_back(view.id);
        prepared.push_back(inspector.prepareView(view, segmentation));
    }
    cycle.result = inspector.inspect(std::move(prepared), ids);
    return cycle;
}

} // namespace hg::commission
