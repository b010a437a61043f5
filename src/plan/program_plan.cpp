#include "hullgauge/plan/program_plan.h"

#include "hullgauge/align/alignment.h"
#include "hullgauge/align/pose_correction.h"
#include "hullgauge/common/format.h"
#include "hullgauge/inspect/part_map.h"
#include "hullgauge/plan/plan_report.h"
#include "hullgauge/plan/view_rules.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace hg::plan {
namespace {

/// The frame check of `camera` for the part seated anywhere within the
/// alignment limits (the nest's play, docs/alignment.md).
FrameCheck checkFrame(const std::string& id, const model::TriangleMesh& mesh, const geometry::CameraModel& camera,
                      const model::AlignmentSettings& play)
{
    FrameCheck c;
    c.view = id;
    c.nominalMarginPx = frameMarginPx(mesh, camera);
    const geometry::Vec3 centre = mesh.bounds().center();
    double radius = 0.0;
    double nearest = std::numeric_limits<double>::infinity();
    for (const geometry::Vec3& v : mesh.vertices) {
        radius = std::max(radius, (v - centre).norm());
        nearest = std::min(nearest, camera.depthOf(v));
    }
    const double motionMm = play.maxShiftMm + geometry::degToRad(play.maxRotationDeg) * radius;
    // The finest pixel at the nearest depth: at any depth for a telecentric camera.
    c.seatAllowancePx = camera.depthInFront(nearest) && (camera.isTelecentric() || nearest > 0.0)
                            ? motionMm / camera.millimetresPerPixelAt(nearest).minCoeff()
                            : std::numeric_limits<double>::infinity();
    return c;
}

std::string frameProblem(const FrameCheck& c, const model::AlignmentSettings& play)
{
    return "view " + c.view + " does not hold the whole part in its frame: the part as drawn lies " +
           formatNumber(c.nominalMarginPx, 3) + " px inside the frame's edge and a seat within the play (" +
           formatNumber(play.maxShiftMm) + " mm, " + formatNumber(play.maxRotationDeg) + "°) moves it up to " +
           formatNumber(c.seatAllowancePx, 3) +
           " px; a shorter lens or the camera farther from the part (or a smaller play: alignment limits)";
}

/// The cameras of a cycle of the part seated so, as the daemon takes it
/// (docs/alignment.md, "Poses corrected for the seat"): the first
/// `correct_poses_after` views at their planned poses, the rest at the poses
/// corrected for the seat; each sees the seated part.
std::vector<geometry::CameraModel> seatedCameras(const model::TriangleMesh& mesh,
                                                 const model::AlignmentSettings& alignment,
                                                 const geometry::Station& station,
                                                 const std::vector<geometry::FixturePose>& poses,
                                                 const geometry::RigidTransform& seat)
{
    const std::size_t seatViews = alignment.method == model::AlignmentMethod::None
                                      ? poses.size()
                                      : static_cast<std::size_t>(alignment.correctPosesAfter);
    const geometry::Vec3 reference = mesh.bounds().center();
    std::vector<geometry::CameraModel> cameras;
    for (std::size_t k = 0; k < poses.size(); ++k) {
        const geometry::FixturePose pose =
            k < seatViews ? poses[k] : align::correctPose(station.fixture, poses[k], seat, reference).pose;
        cameras.push_back(align::seatedCamera(station.cameraAt(pose), seat));
    }
    return cameras;
}

} // namespace

std::vector<geometry::RigidTransform> playSeats(const model::TriangleMesh& mesh,
                                                const model::AlignmentSettings& alignment)
{
    const geometry::Vec3 c = mesh.bounds().center();
    const double shift = kPlayOfLimits * alignment.maxShiftMm;
    const double angle = kPlayOfLimits * alignment.maxRotationDeg;
    std::vector<geometry::RigidTransform> shifts{geometry::RigidTransform::identity()}, turns{shifts};
    for (int axis = 0; axis < 3; ++axis)
        for (double sign : {-1.0, 1.0}) {
            const geometry::Vec3 e = sign * geometry::Vec3::Unit(axis);
            shifts.push_back(geometry::RigidTransform::translation(shift * e));
            const geometry::RigidTransform turn = geometry::RigidTransform::rotation(e, angle);
            turns.push_back({turn.R, c - turn.R * c});
        }
    // Every shift with every turn: a real seat is both at once.
    std::vector<geometry::RigidTransform> seats;
    for (const auto& s : shifts)
        for (const auto& t : turns)
            if (&s != &shifts.front() || &t != &turns.front()) seats.push_back(s * t);
    return seats;
}

std::vector<inspect::LandmarkCapability> capabilityOverPlay(const PlayProblem& problem,
                                                            const geometry::Station& station,
                                                            const std::vector<geometry::FixturePose>& poses)
{
    std::vector<geometry::CameraModel> cameras;
    for (const geometry::FixturePose& pose : poses) cameras.push_back(station.cameraAt(pose));
    auto worst =
        inspect::assessCapability(problem.landmarks, problem.voxelMm, problem.gauge, cameras, station.imageQuality);
    for (const geometry::RigidTransform& seat : playSeats(*problem.mesh, problem.alignment)) {
        const auto at = inspect::assessCapability(problem.landmarks, problem.voxelMm, problem.gauge,
                                                  seatedCameras(*problem.mesh, problem.alignment, station, poses, seat),
                                                  station.imageQuality);
        for (std::size_t i = 0; i < at.size() && i < worst.size(); ++i)
            if (at[i].expectedMm > worst[i].expectedMm) worst[i] = at[i];
    }
    return worst;
}

std::vector<inspect::LandmarkCapability> capabilityOverPlay(const model::PartProgram& program,
                                                            const geometry::Station& station,
                                                            const std::vector<geometry::FixturePose>& poses)
{
    const auto gauge = inspect::makeDeviationGauge(program, station.calibration);
    const PlayProblem problem{&program.solid->mesh(), inspect::mapLandmarks(program),
                              inspect::inspectionVoxelMm(program), gauge.get(), program.alignment};
    return capabilityOverPlay(problem, station, poses);
}

PlanProblem planProblem(const model::PartProgram& program, const geometry::Station& station)
{
    PlanProblem problem;
    problem.part = program.part;
    problem.solid = program.solid.get();
    problem.station = &station;
    problem.frame = {program.octree.cubeOrigin, program.octree.cubeSize, program.octree.depth};
    problem.firstViews = program.alignment.seatViews;
    const double dv = program.octree.voxelSize();
    for (const auto& lm : program.landmarks) {
        const bool toVoxel = program.inspection.deviation && lm.toleranceMm < dv;
        PlanLandmark l{{lm.id, lm.position, lm.normal, toVoxel ? dv : lm.toleranceMm}, lm.bestViews, std::nullopt};
        if (toVoxel) l.drawingToleranceMm = lm.toleranceMm;
        problem.landmarks.push_back(std::move(l));
    }
    return problem;
}

double frameMarginPx(const model::TriangleMesh& mesh, const geometry::CameraModel& camera)
{
    const cv::Size size = camera.imageSize();
    double margin = std::numeric_limits<double>::infinity();
    for (const geometry::Vec3& v : mesh.vertices) {
        const auto p = camera.project(v);
        if (!p) return -std::numeric_limits<double>::infinity();
        // Pixel centres run from 0 to size − 1; the sensor's edge lies half a pixel beyond.
        margin = std::min({margin, p->x() + 0.5, size.width - 0.5 - p->x(), p->y() + 0.5, size.height - 0.5 - p->y()});
    }
    return margin;
}

int finestResolvedDepth(const model::TriangleMesh& mesh, const geometry::Station& station, int adjacencyDepth)
{
    const Eigen::AlignedBox3d bounds = mesh.bounds();
    const geometry::Vec3 centre = bounds.center();
    double radius = 0.0;
    for (const geometry::Vec3& v : mesh.vertices) radius = std::max(radius, (v - centre).norm());
    const geometry::CameraModel camera = station.cameraAt(homePose(station.fixture));
    const double f = std::min(station.camera.K(0, 0), station.camera.K(1, 1));
    // Eq. 5.3.6-3 solved for the MED, as view_rules.h evaluates it: at the
    // part's far side and its widest angle off the axis; a telecentric
    // camera's pixel is 1/f mm everywhere and its lines of sight on the axis.
    double med = plan::telecentricMedMm(1.0 / f, 0.0);
    if (const auto eye = camera.centre()) {
        const double d = (*eye - centre).norm() + radius;
        med = plan::predictedMedMm(f, d, std::atan2(radius, d - radius));
    }
    int best = 4;
    for (int depth = 4; depth <= 15; ++depth) {
        const auto spec = model::boundingCube(bounds, depth, adjacencyDepth);
        if (spec && spec->voxelSize() >= 1.1 * med) best = depth;
    }
    return best;
}

ProgramPlan planProgram(const model::PartProgram& program, const geometry::Station& station, const PlanOptions& options)
{
    ProgramPlan out;
    out.problem = planProblem(program, station);
    out.plan = planViews(out.problem, options);
    for (const PlannedView& v : out.plan.views) {
        out.frames.push_back(checkFrame(v.id, program.solid->mesh(), v.camera, program.alignment));
        if (!out.frames.back().holdsPart()) {
            out.plan.problems.push_back(frameProblem(out.frames.back(), program.alignment));
            out.plan.feasible = false;
        }
    }
    if (!out.plan.feasible) return out;
    std::vector<geometry::FixturePose> poses;
    for (const PlannedView& v : out.plan.views) poses.push_back(v.pose);
    out.capability = capabilityOverPlay(program, station, poses);
    return out;
}

nlohmann::json toJson(const ProgramPlan& planned)
{
    nlohmann::json j = planToJson(planned.plan, planned.problem);
    if (planned.capability) {
        j["capability"] = nlohmann::json::array();
        for (const auto& c : *planned.capability) j["capability"].push_back(inspect::toJson(c));
    }
    return j;
}

} // namespace hg::plan
