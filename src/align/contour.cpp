// The CAD mesh's occluding contour in a view and the sub-pixel silhouette
// edge beside it (docs/alignment.md, "Contour samples", "Edges").
#include "contour.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <stdexcept>
#include <utility>

namespace hg::align {
namespace {

// Coplanar neighbours: the edge between them is no contour from anywhere.
constexpr double kFlatCos = 1.0 - 1e-9;

// Positive when the face is turned towards the camera: its normal against
// the line of sight that images the point (parallel ones for a telecentric lens).
double facing(const Vec3& normal, const Vec3& onFace, const geometry::CameraModel& camera)
{
    return -normal.dot(camera.lineOfSight(onFace));
}

} // namespace

FacesByEdge facesByEdge(const model::TriangleMesh& mesh)
{
    FacesByEdge byEdge;
    for (std::size_t f = 0; f < mesh.triangles.size(); ++f)
        for (int k = 0; k < 3; ++k) {
            const int a = mesh.triangles[f][static_cast<std::size_t>(k)];
            const int b = mesh.triangles[f][static_cast<std::size_t>((k + 1) % 3)];
            byEdge[{std::min(a, b), std::max(a, b)}].push_back(static_cast<int>(f));
        }
    return byEdge;
}

EdgeGraph::EdgeGraph(const model::TriangleMesh& mesh, std::vector<int> faceDatum)
    : mesh_(&mesh), faceDatum_(std::move(faceDatum))
{
    const std::size_t nf = mesh.triangles.size();
    if (faceDatum_.size() != nf) faceDatum_.assign(nf, -1);
    normals_.reserve(nf);
    centroids_.reserve(nf);
    for (std::size_t f = 0; f < nf; ++f) {
        const auto& t = mesh.triangles[f];
        normals_.push_back(mesh.faceNormal(f));
        centroids_.push_back((vertex(t[0]) + vertex(t[1]) + vertex(t[2])) / 3.0);
    }
    for (const auto& [key, fs] : facesByEdge(mesh)) {
        // A closed 2-manifold (model::Solid checks it) has two faces per edge.
        if (fs.size() != 2) continue;
        if (normal(fs[0]).dot(normal(fs[1])) > kFlatCos) continue;
        edges_.push_back({key.first, key.second, fs[0], fs[1]});
    }
}

int EdgeGraph::datum(const Edge& e) const
{
    const int d1 = faceDatum_[static_cast<std::size_t>(e.f1)], d2 = faceDatum_[static_cast<std::size_t>(e.f2)];
    if (d1 < 0) return d2;
    if (d2 < 0) return d1;
    return std::min(d1, d2);
}

bool EdgeGraph::isContour(const Edge& e, const geometry::CameraModel& camera) const
{
    const double s1 = facing(normal(e.f1), vertex(e.a), camera);
    const double s2 = facing(normal(e.f2), vertex(e.a), camera);
    return (s1 > 0.0) != (s2 > 0.0);
}

bool projectSample(const EdgeGraph& graph, const ContourSample& sample, const geometry::CameraModel& camera,
                   SampleImage& out)
{
    const EdgeGraph::Edge& e = graph.edges()[static_cast<std::size_t>(sample.edge)];
    const Vec3 along = (graph.vertex(e.b) - graph.vertex(e.a)).normalized();
    const double step = 0.05 * (graph.vertex(e.b) - graph.vertex(e.a)).norm();
    const auto p = camera.project(sample.point);
    const auto p0 = camera.project(sample.point - step * along);
    const auto p1 = camera.project(sample.point + step * along);
    if (!p || !p0 || !p1) return false;
    const Vec2 tangent = *p1 - *p0;
    if (tangent.norm() < 1e-9) return false;
    Vec2 n(-tangent.y(), tangent.x());
    n.normalize();
    // Both faces of a contour edge fold to the same side of it in the image:
    // the side of the face whose inside projects farther from the edge line.
    double inward = 0.0;
    for (int f : {e.f1, e.f2}) {
        const Vec3 inside = sample.point + 0.25 * (graph.centroid(f) - sample.point);
        if (const auto q = camera.project(inside)) {
            const double d = n.dot(*q - *p);
            if (std::abs(d) > std::abs(inward)) inward = d;
        }
    }
    if (inward == 0.0) return false;
    out.pixel = *p;
    out.normal = inward > 0.0 ? Vec2(-n) : n;
    return true;
}

bool imageOf(const EdgeGraph& graph, const ContourSample& sample, const geometry::CameraModel& camera, SampleImage& out)
{
    const EdgeGraph::Edge& e = graph.edges()[static_cast<std::size_t>(sample.edge)];
    return graph.isContour(e, camera) && projectSample(graph, sample, camera, out);
}

namespace {

// An edge of a face seen within `sinLimit` of edge-on: which of its edges
// is outermost flips with the seat, so both are sampled.
bool nearGrazing(const EdgeGraph& graph, const EdgeGraph::Edge& e, const geometry::CameraModel& camera, double sinLimit)
{
    for (int f : {e.f1, e.f2}) {
        const Vec3 view = camera.lineOfSight(graph.centroid(f));
        if (std::abs(graph.normal(f).dot(view)) < sinLimit) return true;
    }
    return false;
}

struct Candidate {
    int edge;
    Vec2 pa, pb;
};

std::vector<Candidate> candidateEdges(const EdgeGraph& graph, const geometry::CameraModel& camera,
                                      double nearGrazingDeg, double& totalLengthPx)
{
    const double sinLimit = std::sin(nearGrazingDeg * 3.14159265358979323846 / 180.0);
    std::vector<Candidate> out;
    totalLengthPx = 0.0;
    for (std::size_t i = 0; i < graph.edges().size(); ++i) {
        const auto& e = graph.edges()[i];
        if (!graph.isContour(e, camera) && !nearGrazing(graph, e, camera, sinLimit)) continue;
        const auto pa = camera.project(graph.vertex(e.a));
        const auto pb = camera.project(graph.vertex(e.b));
        if (!pa || !pb) continue;
        out.push_back({static_cast<int>(i), *pa, *pb});
        totalLengthPx += (*pb - *pa).norm();
    }
    return out;
}

// On the outline: the line of sight just outside the sample (one pixel along
// its outward normal) meets nothing of the solid.
bool onOutline(const model::Solid& solid, const geometry::CameraModel& camera, const SampleImage& at)
{
    const geometry::Ray ray = camera.backProject(at.pixel + at.normal);
    return !solid.firstHit(ray.origin, ray.direction);
}

} // namespace

std::vector<ContourSample> sampleContour(const EdgeGraph& graph, const model::Solid& solid,
                                         const geometry::CameraModel& camera, double nearGrazingDeg, int maxSamples)
{
    // Samples keep clear of the edge's ends, where the outline turns a corner
    // and the normal is not the edge's.
    constexpr double kEndClearancePx = 3.0, kMinSpacingPx = 3.0;
    double total = 0.0;
    const std::vector<Candidate> candidates = candidateEdges(graph, camera, nearGrazingDeg, total);
    const double spacing = std::max(kMinSpacingPx, total / std::max(1, maxSamples));
    std::vector<ContourSample> samples;
    for (const Candidate& c : candidates) {
        const double length = (c.pb - c.pa).norm();
        const double usable = length - 2.0 * kEndClearancePx;
        if (usable <= 0.0) continue;
        const int n = std::max(1, static_cast<int>(std::floor(usable / spacing)) + 1);
        const auto& e = graph.edges()[static_cast<std::size_t>(c.edge)];
        for (int k = 0; k < n; ++k) {
            const double s = (kEndClearancePx + (n == 1 ? 0.5 * usable : usable * k / (n - 1))) / length;
            ContourSample sample{(1.0 - s) * graph.vertex(e.a) + s * graph.vertex(e.b), c.edge, graph.datum(e)};
            // A candidate that is not a contour now (a near-grazing face's other
            // edge) is kept if it would be on the outline: the seat decides later.
            SampleImage at;
            if (projectSample(graph, sample, camera, at) && onOutline(solid, camera, at)) samples.push_back(sample);
        }
    }
    return samples;
}

bool findEdge(const EdgeImage& image, const SampleImage& at, double bandPx, double& offset)
{
    const auto edge = vision::findEdge(image, at.pixel, at.normal, bandPx);
    if (!edge) return false;
    offset = edge->offset;
    return true;
}

} // namespace hg::align
