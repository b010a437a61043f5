// Silhouette and datum alignment of the seated part (docs/alignment.md;
// dissertation 6.2, item 6).
#include "hullgauge/align/alignment.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <deque>
#include <map>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include "contour.h"
#include "hullgauge/common/clock.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/format.h"
#include "hullgauge/geometry/json.h"
#include "seat_solver.h"

namespace hg::align {
namespace {

constexpr int kMaxSamplesPerView = 160;
constexpr int kMinInliers = 12;
constexpr int kMaxRounds = 4;
constexpr int kMaxIterations = 20;
// Edges are searched again this far (px) around the new estimate in later rounds.
constexpr double kRefineBandPx = 3.0;
// The first search reaches twice the limits, so a part seated beyond them is
// measured (and refused as such), not lost.
constexpr double kSearchReach = 2.0;

struct DatumPlane {
    Vec3 normal;
    Vec3 centroid;
};

// The CAD face of a datum landmark: the triangles connected to the one
// nearest the landmark that lie in its plane (within 1°).
std::vector<int> growDatumFace(const model::TriangleMesh& mesh, const FacesByEdge& byEdge, std::size_t seed,
                               DatumPlane& plane)
{
    const double cosLimit = std::cos(geometry::degToRad(1.0));
    const Vec3 n0 = mesh.faceNormal(seed);
    std::vector<int> face{static_cast<int>(seed)};
    std::vector<char> seen(mesh.triangles.size(), 0);
    seen[seed] = 1;
    std::deque<int> queue{static_cast<int>(seed)};
    Vec3 weighted = Vec3::Zero(), centre = Vec3::Zero();
    double area = 0.0;
    while (!queue.empty()) {
        const auto f = static_cast<std::size_t>(queue.front());
        queue.pop_front();
        const auto& t = mesh.triangles[f];
        const Vec3 &p0 = mesh.vertices[static_cast<std::size_t>(t[0])],
                   &p1 = mesh.vertices[static_cast<std::size_t>(t[1])],
                   &p2 = mesh.vertices[static_cast<std::size_t>(t[2])];
        const double a = 0.5 * (p1 - p0).cross(p2 - p0).norm();
        weighted += a * mesh.faceNormal(f);
        centre += a * (p0 + p1 + p2) / 3.0;
        area += a;
        for (int k = 0; k < 3; ++k) {
            const int va = t[static_cast<std::size_t>(k)], vb = t[static_cast<std::size_t>((k + 1) % 3)];
            for (int g : byEdge.at({std::min(va, vb), std::max(va, vb)})) {
                const auto gi = static_cast<std::size_t>(g);
                if (seen[gi] || mesh.faceNormal(gi).dot(n0) < cosLimit) continue;
                seen[gi] = 1;
                face.push_back(g);
                queue.push_back(g);
            }
        }
    }
    plane.normal = weighted.normalized();
    plane.centroid = centre / area;
    return face;
}

// What a datum plane can fix: its normal shift and its two tilts, and nothing
// of the motions that slide or turn it in itself (3-2-1). The oblique
// projection onto those along the plane's own motions, in θ = (L·ω, v).
Matrix6 datumProjection(const DatumPlane& plane, const Vec3& reference, double lever)
{
    const Vec3 m = plane.normal;
    const Vec3 a1 = m.unitOrthogonal(), a2 = m.cross(a1);
    const Vec3 arm = reference - plane.centroid;
    auto rotation = [&](const Vec3& axis) {
        Vector6 v;
        v << lever * axis, axis.cross(arm);
        return v;
    };
    auto shift = [](const Vec3& d) {
        Vector6 v;
        v << Vec3::Zero(), d;
        return v;
    };
    Matrix6 sees, all;
    sees << rotation(a1), rotation(a2), shift(m), Vector6::Zero(), Vector6::Zero(), Vector6::Zero();
    all << rotation(a1), rotation(a2), shift(m), rotation(m), shift(a1), shift(a2);
    return sees * all.inverse();
}

geometry::RigidTransform applyStep(const geometry::RigidTransform& seat, const Vector6& delta, const Vec3& reference,
                                   double lever)
{
    const Vec3 omega = delta.head<3>() / lever;
    const Vec3 v = delta.tail<3>();
    const Vec3 centre = seat.apply(reference);
    const double angle = omega.norm();
    const geometry::Mat3 R =
        angle > 0.0 ? Eigen::AngleAxisd(angle, omega / angle).toRotationMatrix() : geometry::Mat3::Identity();
    return {R * seat.R, R * (seat.t - centre) + centre + v};
}

} // namespace

struct ViewEdges {
    struct Found {
        std::size_t sample;
        Vec2 edge, normal;
    };
    std::vector<ContourSample> samples; ///< at the nominal camera
    std::vector<Found> first;           ///< edges found around the nominal outline
};

struct Aligner::Impl {
    std::shared_ptr<const model::Solid> solid;
    model::AlignmentSettings settings;
    std::unique_ptr<EdgeGraph> graph;
    Vec3 reference = Vec3::Zero();
    double lever = 1.0;
    std::vector<ObservationGroup> groups;

    // An edge point found beside a contour sample.
    struct Correspondence {
        std::size_t view;
        const ContourSample* sample;
        Vec2 edge;
        Vec2 normal;
    };

    // The first round's edges of one view, around its nominal outline.
    ViewEdges firstEdges(const AlignmentView& view) const;
    // Edges again, around the outline of the seat found so far.
    std::vector<Correspondence> measure(const std::vector<AlignmentView>& views,
                                        const std::vector<std::shared_ptr<const ViewEdges>>& prepared,
                                        const geometry::RigidTransform& seat) const;
    Observation observe(const Correspondence& c, const AlignmentView& view, const geometry::RigidTransform& seat) const;
    std::vector<Observation> observeAll(const std::vector<Correspondence>& cs, const std::vector<AlignmentView>& views,
                                        const geometry::RigidTransform& seat) const;
    int solve(const std::vector<Correspondence>& cs, const std::vector<AlignmentView>& views, Loss loss,
              geometry::RigidTransform& seat) const;
    void report(const std::vector<Correspondence>& cs, const std::vector<AlignmentView>& views,
                AlignmentResult& out) const;
    struct Fit {
        geometry::RigidTransform seat;
        std::vector<Correspondence> edges; ///< found around the fitted outline
        int iterations = 0;
    };
    // Rounds of solve and edge search from nominal, the first with `firstLoss`.
    Fit refine(const std::vector<AlignmentView>& views, const std::vector<std::shared_ptr<const ViewEdges>>& prepared,
               const std::vector<Correspondence>& first, Loss firstLoss) const;
    // Rounds of edge search and solve (the biweight) from `start`.
    Fit refineFrom(const std::vector<AlignmentView>& views,
                   const std::vector<std::shared_ptr<const ViewEdges>>& prepared,
                   const geometry::RigidTransform& start) const;
    // The fit again from its mirror images where a rotation is seen only by its size (below).
    void resolveMirrors(const std::vector<AlignmentView>& views,
                        const std::vector<std::shared_ptr<const ViewEdges>>& prepared, std::size_t samples,
                        Fit& fit) const;
    // How much of the outline disagrees with a fit: every sample without an
    // edge near it counts 1, every edge its biweight loss at a fixed scale.
    double disagreement(const Fit& fit, const std::vector<AlignmentView>& views, std::size_t samples) const;
    double searchBandPx(const geometry::CameraModel& camera, const Vec3& point) const;
    std::vector<ContourSample> samplesOf(const geometry::CameraModel& camera) const;
    double marginMm() const { return settings.maxShiftMm + geometry::degToRad(settings.maxRotationDeg) * lever; }
    SolverLimits solverLimits() const
    {
        SolverLimits l;
        l.maxShiftMm = settings.maxShiftMm;
        l.maxTurnMm = geometry::degToRad(settings.maxRotationDeg) * lever;
        return l;
    }
};

Aligner::Aligner(std::shared_ptr<const model::Solid> solid, const std::vector<model::Landmark>& landmarks,
                 model::AlignmentSettings settings)
    : impl_(std::make_unique<Impl>())
{
    // Broken preconditions, not bad input: the part program's loader checks these values and names their
    // lines, and a caller that loaded them reports them as its input (docs/style.md point 4).
    if (!solid) throw ArgumentError("solid: none given (alignment needs the CAD solid)");
    if (!(settings.maxShiftMm > 0.0) || !std::isfinite(settings.maxShiftMm))
        throw ArgumentError("max_shift_mm must be a positive number, found " + formatNumber(settings.maxShiftMm));
    if (!(settings.maxRotationDeg > 0.0) || !std::isfinite(settings.maxRotationDeg))
        throw ArgumentError("max_rotation_deg must be a positive number, found " +
                            formatNumber(settings.maxRotationDeg));
    const model::TriangleMesh& mesh = solid->mesh();
    impl_->reference = mesh.bounds().center();
    double lever = 0.0;
    for (const Vec3& v : mesh.vertices) lever = std::max(lever, (v - impl_->reference).norm());
    impl_->lever = std::max(lever, 1e-3);
    std::vector<int> faceDatum(mesh.triangles.size(), -1);
    if (settings.method == model::AlignmentMethod::Datums) {
        if (settings.datums.empty()) throw ArgumentError("method datums needs at least one datum, found none");
        // Every edge's faces, built once for all datums.
        const FacesByEdge byEdge = facesByEdge(mesh);
        for (std::size_t k = 0; k < settings.datums.size(); ++k) {
            const auto it = std::find_if(landmarks.begin(), landmarks.end(),
                                         [&](const model::Landmark& l) { return l.id == settings.datums[k]; });
            if (it == landmarks.end()) throw ArgumentError("datum '" + settings.datums[k] + "' is not a landmark");
            DatumPlane plane;
            for (int f : growDatumFace(mesh, byEdge, solid->closestPoint(it->position).triangle, plane))
                if (faceDatum[static_cast<std::size_t>(f)] < 0)
                    faceDatum[static_cast<std::size_t>(f)] = static_cast<int>(k);
            impl_->groups.push_back({datumProjection(plane, impl_->reference, impl_->lever)});
        }
    } else {
        impl_->groups.push_back({});
    }
    impl_->graph = std::make_unique<EdgeGraph>(mesh, std::move(faceDatum));
    impl_->solid = std::move(solid);
    impl_->settings = std::move(settings);
}

Aligner::~Aligner() = default;

const model::AlignmentSettings& Aligner::settings() const
{
    return impl_->settings;
}

double Aligner::marginMm() const
{
    return impl_->marginMm();
}

std::vector<cv::Rect> Aligner::searchRegions(const geometry::CameraModel& camera) const
{
    const cv::Rect frame(0, 0, camera.imageSize().width, camera.imageSize().height);
    const double turn = std::sin(geometry::degToRad(impl_->settings.maxRotationDeg));
    std::vector<cv::Rect> out;
    for (const ContourSample& s : impl_->samplesOf(camera)) {
        SampleImage at;
        if (!projectSample(*impl_->graph, s, camera, at)) continue;
        // A seat within the limits moves the sample by at most the margin,
        // seen from no nearer than its depth less the margin (at any depth
        // through a telecentric lens); later rounds search kRefineBandPx about
        // the seated sample, along a normal turned by at most the rotation limit.
        const double depth = camera.depthOf(s.point) - impl_->marginMm();
        const double moved = camera.depthInFront(depth) && (camera.isTelecentric() || depth > 1e-6)
                                 ? impl_->marginMm() / camera.millimetresPerPixelAt(depth).minCoeff() + 1.0
                                 : 1e6;
        const double band = std::max(impl_->searchBandPx(camera, s.point), moved + kRefineBandPx);
        const vision::EdgeReach reach = vision::findEdgeReach(band);
        const Vec2 a = at.pixel - reach.inside * at.normal, b = at.pixel + reach.outside * at.normal;
        const double pad = reach.lateral + moved + (reach.inside + reach.outside) * turn;
        const cv::Point lo(static_cast<int>(std::floor(std::min(a.x(), b.x()) - pad)),
                           static_cast<int>(std::floor(std::min(a.y(), b.y()) - pad)));
        const cv::Point hi(static_cast<int>(std::ceil(std::max(a.x(), b.x()) + pad)) + 1,
                           static_cast<int>(std::ceil(std::max(a.y(), b.y()) + pad)) + 1);
        const cv::Rect r = cv::Rect(lo, hi) & frame;
        if (!r.empty()) out.push_back(r);
    }
    return out;
}

double Aligner::Impl::searchBandPx(const geometry::CameraModel& camera, const Vec3& point) const
{
    const double margin = marginMm();
    const double mmPerPx = camera.millimetresPerPixelAt(camera.depthOf(point)).x();
    return std::min(250.0, kSearchReach * margin / std::max(mmPerPx, 1e-9) + 2.0);
}

std::vector<ContourSample> Aligner::Impl::samplesOf(const geometry::CameraModel& camera) const
{
    std::vector<ContourSample> samples =
        sampleContour(*graph, *solid, camera, settings.maxRotationDeg * kSearchReach + 0.5, kMaxSamplesPerView);
    if (settings.method == model::AlignmentMethod::Datums)
        samples.erase(
            std::remove_if(samples.begin(), samples.end(), [](const ContourSample& c) { return c.datum < 0; }),
            samples.end());
    return samples;
}

ViewEdges Aligner::Impl::firstEdges(const AlignmentView& view) const
{
    ViewEdges out;
    out.samples = samplesOf(view.camera);
    const EdgeImage image{view.grey, view.threshold, view.objectIsDark, view.origin, view.camera.imageSize()};
    for (std::size_t k = 0; k < out.samples.size(); ++k) {
        SampleImage at;
        if (!imageOf(*graph, out.samples[k], view.camera, at)) continue;
        double offset = 0.0;
        if (findEdge(image, at, searchBandPx(view.camera, out.samples[k].point), offset))
            out.first.push_back({k, at.pixel + offset * at.normal, at.normal});
    }
    return out;
}

std::vector<Aligner::Impl::Correspondence>
Aligner::Impl::measure(const std::vector<AlignmentView>& views,
                       const std::vector<std::shared_ptr<const ViewEdges>>& prepared,
                       const geometry::RigidTransform& seat) const
{
    std::vector<Correspondence> out;
    for (std::size_t v = 0; v < views.size(); ++v) {
        const geometry::CameraModel camera = seatedCamera(views[v].camera, seat);
        const EdgeImage image{views[v].grey, views[v].threshold, views[v].objectIsDark, views[v].origin,
                              views[v].camera.imageSize()};
        for (const ContourSample& s : prepared[v]->samples) {
            SampleImage at;
            if (!imageOf(*graph, s, camera, at)) continue;
            double offset = 0.0;
            if (!findEdge(image, at, kRefineBandPx, offset)) continue;
            out.push_back({v, &s, at.pixel + offset * at.normal, at.normal});
        }
    }
    return out;
}

// Residual: the edge's distance from the projected sample along the normal;
// its gradient through the undistorted projection, pinhole or telecentric
// (distortion changes it by far less than the step matters: the residual
// itself is exact).
Observation Aligner::Impl::observe(const Correspondence& c, const AlignmentView& view,
                                   const geometry::RigidTransform& seat) const
{
    const geometry::RigidTransform& cam = view.camera.cameraFromPart();
    const Vec3 Y = seat.apply(c.sample->point);
    const Vec3 Z = cam.apply(Y);
    Observation o;
    o.group = std::max(0, c.sample->datum);
    const auto u = view.camera.projectCameraPoint(Z);
    if (!u) {
        o.gradient.setZero();
        o.residual = 0.0;
        return o;
    }
    o.residual = c.normal.dot(*u - c.edge);
    const Eigen::Matrix<double, 2, 3> Jp = view.camera.undistortedPointJacobian(Z);
    const Vec3 g = (c.normal.transpose() * Jp * cam.R).transpose();
    const Vec3 arm = Y - seat.apply(reference);
    o.gradient << arm.cross(g) / lever, g;
    return o;
}

std::vector<Observation> Aligner::Impl::observeAll(const std::vector<Correspondence>& cs,
                                                   const std::vector<AlignmentView>& views,
                                                   const geometry::RigidTransform& seat) const
{
    std::vector<Observation> obs;
    obs.reserve(cs.size());
    for (const Correspondence& c : cs) obs.push_back(observe(c, views[c.view], seat));
    return obs;
}

// Gauss–Newton on fixed correspondences until the step is below 0.01 µm.
int Aligner::Impl::solve(const std::vector<Correspondence>& cs, const std::vector<AlignmentView>& views, Loss loss,
                         geometry::RigidTransform& seat) const
{
    const SolverLimits limits = solverLimits();
    int it = 0;
    for (; it < kMaxIterations; ++it) {
        const Step step = robustStep(observeAll(cs, views, seat), groups, limits, loss);
        seat = applyStep(seat, step.delta, reference, lever);
        if (step.delta.norm() < 1e-5) return it + 1;
    }
    return it;
}

Aligner::Impl::Fit Aligner::Impl::refine(const std::vector<AlignmentView>& views,
                                         const std::vector<std::shared_ptr<const ViewEdges>>& prepared,
                                         const std::vector<Correspondence>& first, Loss firstLoss) const
{
    Fit fit;
    fit.edges = first;
    for (int round = 0; round < kMaxRounds; ++round) {
        if (round > 0) fit.edges = measure(views, prepared, fit.seat);
        if (static_cast<int>(fit.edges.size()) < kMinInliers) break;
        const geometry::RigidTransform before = fit.seat;
        fit.iterations += solve(fit.edges, views, round == 0 ? firstLoss : Loss::Tukey, fit.seat);
        const double moved = (fit.seat.apply(reference) - before.apply(reference)).norm() +
                             geometry::degToRad(geometry::rotationAngleDeg(before.R, fit.seat.R)) * lever;
        if (round > 0 && moved < 1e-4) break;
    }
    return fit;
}

Aligner::Impl::Fit Aligner::Impl::refineFrom(const std::vector<AlignmentView>& views,
                                             const std::vector<std::shared_ptr<const ViewEdges>>& prepared,
                                             const geometry::RigidTransform& start) const
{
    Fit fit;
    fit.seat = start;
    for (int round = 0; round < kMaxRounds; ++round) {
        fit.edges = measure(views, prepared, fit.seat);
        if (static_cast<int>(fit.edges.size()) < kMinInliers) break;
        const geometry::RigidTransform before = fit.seat;
        fit.iterations += solve(fit.edges, views, Loss::Tukey, fit.seat);
        const double moved = (fit.seat.apply(reference) - before.apply(reference)).norm() +
                             geometry::degToRad(geometry::rotationAngleDeg(before.R, fit.seat.R)) * lever;
        if (moved < 1e-4) break;
    }
    return fit;
}

// A rotation about an axis that lies in the image plane of every view moves
// an outline only through which edges form it: for a part symmetric about the
// plane of that axis and the line of sight (an extrusion seen along it), +θ
// and −θ cast the same outline wherever the lines of sight are parallel, and
// the seat has two minima (a telecentric lens shows no perspective that would
// tell them apart; docs/alignment.md, "Mirror seats"). For each of the
// seat's rotation components (about the fixture's axes, through the
// reference point) of at least kMirrorMinDeg, the seat with that component
// negated is tried when the outline's edges already fit it nearly as well,
// refined, and kept when the whole outline agrees with it more.
void Aligner::Impl::resolveMirrors(const std::vector<AlignmentView>& views,
                                   const std::vector<std::shared_ptr<const ViewEdges>>& prepared, std::size_t samples,
                                   Fit& fit) const
{
    constexpr double kMirrorMinDeg = 0.01;
    double best = disagreement(fit, views, samples);
    const Eigen::AngleAxisd turn(fit.seat.R);
    const Vec3 rotation = turn.angle() * turn.axis();
    const Vec3 centre = fit.seat.apply(reference);
    for (int axis = 0; axis < 3; ++axis) {
        if (geometry::radToDeg(std::abs(rotation[axis])) < kMirrorMinDeg) continue;
        Vec3 mirrored = rotation;
        mirrored[axis] = -mirrored[axis];
        Fit start = fit;
        const double angle = mirrored.norm();
        start.seat.R = Eigen::AngleAxisd(angle, mirrored / angle).toRotationMatrix();
        start.seat.t = centre - start.seat.R * reference;
        // Cheap first: the edges already found, at the mirror seat. A rotation the
        // views see directly leaves most of them beyond the biweight's cut.
        if (disagreement(start, views, samples) > best + 0.25 * static_cast<double>(fit.edges.size())) continue;
        const Fit other = refineFrom(views, prepared, start.seat);
        const double cost = disagreement(other, views, samples);
        if (static_cast<int>(other.edges.size()) >= kMinInliers && cost < best) {
            fit = other;
            best = cost;
        }
    }
}

double Aligner::Impl::disagreement(const Fit& fit, const std::vector<AlignmentView>& views, std::size_t samples) const
{
    constexpr double kCutPx = 2.0; // biweight cut-off: four edge noise floors
    double cost = static_cast<double>(samples) - static_cast<double>(fit.edges.size());
    for (const Observation& o : observeAll(fit.edges, views, fit.seat)) {
        const double u = std::min(1.0, std::abs(o.residual) / kCutPx);
        cost += 1.0 - std::pow(1.0 - u * u, 3);
    }
    return cost;
}

void Aligner::Impl::report(const std::vector<Correspondence>& cs, const std::vector<AlignmentView>& views,
                           AlignmentResult& out) const
{
    const std::vector<Observation> obs = observeAll(cs, views, out.seat);
    const Step step = robustStep(obs, groups, solverLimits(), Loss::Tukey, true);
    double sum = 0.0;
    std::vector<double> growth; // (edge − outline)·n = −residual
    for (std::size_t j = 0; j < obs.size(); ++j)
        if (step.weights[j] > 0.0) {
            ++out.inliers;
            sum += obs[j].residual * obs[j].residual;
            growth.push_back(-obs[j].residual);
        }
    out.samples = static_cast<int>(obs.size());
    out.residualPx = out.inliers > 0 ? std::sqrt(sum / out.inliers) : 0.0;
    if (!growth.empty()) {
        const auto mid = growth.begin() + static_cast<std::ptrdiff_t>(growth.size() / 2);
        std::nth_element(growth.begin(), mid, growth.end());
        out.edgeBiasPx = *mid;
    }
    // θ = (L·ω, v) to (ω, v).
    Matrix6 S = Matrix6::Identity();
    S.topLeftCorner<3, 3>() /= lever;
    out.covariance = S * step.covariance * S.transpose();
    Eigen::SelfAdjointEigenSolver<geometry::Mat3> rot(out.covariance.topLeftCorner<3, 3>());
    Eigen::SelfAdjointEigenSolver<geometry::Mat3> shift(out.covariance.bottomRightCorner<3, 3>());
    out.rotationUncertaintyDeg = 2.0 * geometry::radToDeg(std::sqrt(std::max(0.0, rot.eigenvalues().maxCoeff())));
    out.shiftUncertaintyMm = 2.0 * std::sqrt(std::max(0.0, shift.eigenvalues().maxCoeff()));
    // θ moves the seated part about its seated reference point, in the
    // nominal frame; the report names the part's own axes and points.
    const Vec3 centre = out.seat.apply(reference);
    const geometry::RigidTransform partFromNominal = out.seat.inverse();
    for (const Vector6& u : step.undetermined) {
        const Vec3 omega = u.head<3>() / lever, v = u.tail<3>();
        FixedDof d;
        if (lever * omega.norm() >= v.norm()) {
            d.kind = FixedDof::Kind::Rotation;
            const Vec3 axis = omega.normalized();
            const Vec3 across = v - v.dot(axis) * axis;
            d.axis = partFromNominal.applyToDirection(axis);
            d.point = partFromNominal.apply(centre + omega.cross(across) / omega.squaredNorm());
        } else {
            d.kind = FixedDof::Kind::Translation;
            d.axis = partFromNominal.applyToDirection(v.normalized());
        }
        out.fixedDofs.push_back(d);
    }
}

namespace {

std::string axisName(const Vec3& axis)
{
    const char* names[] = {"x", "y", "z"};
    for (int i = 0; i < 3; ++i)
        if (std::abs(axis(i)) > std::cos(geometry::degToRad(1.0))) return names[i];
    return "(" + formatNumber(axis.x(), 3) + ", " + formatNumber(axis.y(), 3) + ", " + formatNumber(axis.z(), 3) + ")";
}

void label(FixedDof& d)
{
    if (d.kind == FixedDof::Kind::Rotation)
        d.label = "rotation about " + axisName(d.axis) + " through (" + formatNumber(d.point.x(), 3) + ", " +
                  formatNumber(d.point.y(), 3) + ", " + formatNumber(d.point.z(), 3) + ")";
    else
        d.label = "translation along " + axisName(d.axis);
}

void checkViews(const std::vector<AlignmentView>& views)
{
    for (std::size_t v = 0; v < views.size(); ++v) {
        const AlignmentView& view = views[v];
        const std::string name = "alignment view " + std::to_string(v);
        if (view.grey.empty()) throw ArgumentError(name + ": no frame");
        if (view.grey.type() != CV_8UC1 && view.grey.type() != CV_16UC1)
            throw ArgumentError(name + ": the frame must be 8- or 16-bit grey, found " +
                                cv::typeToString(view.grey.type()));
        const cv::Rect sensor(cv::Point(0, 0), view.camera.imageSize());
        const cv::Rect delivered(view.origin, view.grey.size());
        if ((delivered & sensor) != delivered)
            throw ArgumentError(name + ": frame " + std::to_string(view.grey.cols) + "x" +
                                std::to_string(view.grey.rows) + " at sensor (" + std::to_string(view.origin.x) + ", " +
                                std::to_string(view.origin.y) + ") leaves the camera's " +
                                std::to_string(sensor.width) + "x" + std::to_string(sensor.height) + " sensor");
    }
}

} // namespace

std::shared_ptr<const ViewEdges> Aligner::prepare(const AlignmentView& view) const
{
    checkViews({view});
    return std::make_shared<const ViewEdges>(impl_->firstEdges(view));
}

AlignmentResult Aligner::align(const std::vector<AlignmentView>& views) const
{
    std::vector<std::shared_ptr<const ViewEdges>> prepared;
    for (const AlignmentView& v : views) prepared.push_back(prepare(v));
    return align(views, prepared);
}

AlignmentResult Aligner::align(const std::vector<AlignmentView>& views,
                               const std::vector<std::shared_ptr<const ViewEdges>>& prepared) const
{
    const Stopwatch watch;
    checkViews(views);
    if (prepared.size() != views.size() ||
        std::any_of(prepared.begin(), prepared.end(), [](const auto& p) { return !p; }))
        throw ArgumentError("prepared: " + std::to_string(prepared.size()) + " preparations for " +
                            std::to_string(views.size()) + " views (every view must be prepared)");
    const Impl& m = *impl_;
    AlignmentResult out;
    out.method = m.settings.method;
    out.referencePoint = m.reference;
    std::vector<Impl::Correspondence> first;
    std::size_t total = 0;
    for (std::size_t v = 0; v < views.size(); ++v) {
        total += prepared[v]->samples.size();
        for (const ViewEdges::Found& f : prepared[v]->first)
            first.push_back({v, &prepared[v]->samples[f.sample], f.edge, f.normal});
    }
    // Two starts: the convex loss first (it reaches a seat far from nominal),
    // and the biweight straight from nominal (when half the outline disagrees
    // with the other half — a face raised along its whole length — the convex
    // loss settles between them, the biweight on the side that agrees with
    // the nest). The one whose outline agrees with more of the edges wins.
    Impl::Fit fit = m.refine(views, prepared, first, Loss::Huber);
    const Impl::Fit fromNominal = m.refine(views, prepared, first, Loss::Tukey);
    if (m.disagreement(fromNominal, views, total) < m.disagreement(fit, views, total)) fit = fromNominal;
    m.resolveMirrors(views, prepared, total, fit);
    out.seat = fit.seat;
    out.iterations = fit.iterations;
    const std::vector<Impl::Correspondence>& cs = fit.edges;
    if (static_cast<int>(cs.size()) >= kMinInliers) m.report(cs, views, out);
    for (FixedDof& d : out.fixedDofs) label(d);
    out.measured = out.inliers >= kMinInliers;
    out.shiftMm = (out.seat.apply(m.reference) - m.reference).norm();
    out.rotationDeg = geometry::rotationAngleDeg(geometry::Mat3::Identity(), out.seat.R);
    if (!out.measured) {
        out.message = "the seat could not be measured: " + std::to_string(out.inliers) +
                      " edge points on the outline agree (at least " + std::to_string(kMinInliers) + " needed)";
        out.seat = {};
        out.shiftMm = out.rotationDeg = 0.0;
        out.withinLimits = false;
    } else if (out.shiftMm > m.settings.maxShiftMm || out.rotationDeg > m.settings.maxRotationDeg) {
        out.withinLimits = false;
        out.message = "part not seated: shift " + formatNumber(out.shiftMm, 3) + " mm (max_shift_mm " +
                      formatNumber(m.settings.maxShiftMm) + "), rotation " + formatNumber(out.rotationDeg, 3) +
                      "° (max_rotation_deg " + formatNumber(m.settings.maxRotationDeg) + ")";
    }
    out.ms = watch.ms();
    return out;
}

geometry::CameraModel seatedCamera(const geometry::CameraModel& nominal, const geometry::RigidTransform& seat)
{
    return geometry::CameraModel(nominal.intrinsics(), nominal.cameraFromPart() * seat);
}

} // namespace hg::align
