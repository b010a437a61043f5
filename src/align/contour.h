// The pieces of silhouette alignment (docs/alignment.md): the CAD mesh's
// occluding contour in a view, the sub-pixel silhouette edge along a
// contour sample's normal, and the seat's Gauss–Newton solver.
#pragma once

#include <cstdint>
#include <map>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "hullgauge/geometry/camera.h"
#include "hullgauge/model/solid.h"
#include "hullgauge/vision/edge.h"

namespace hg::align {

using geometry::Vec2;
using geometry::Vec3;

/// Every edge of the mesh (vertex pair, smaller first) with the faces it bounds.
using FacesByEdge = std::map<std::pair<int, int>, std::vector<int>>;
FacesByEdge facesByEdge(const model::TriangleMesh& mesh);

/// The mesh's sharp edges with their two faces: the only places an occluding
/// contour of a polyhedron can run.
class EdgeGraph {
  public:
    struct Edge {
        int a = 0, b = 0;   ///< vertices
        int f1 = 0, f2 = 0; ///< the two faces
    };

    /// `faceDatum[f]`: the datum (priority index) face f belongs to, or -1.
    EdgeGraph(const model::TriangleMesh& mesh, std::vector<int> faceDatum);

    const std::vector<Edge>& edges() const { return edges_; }
    const Vec3& vertex(int v) const { return mesh_->vertices[static_cast<std::size_t>(v)]; }
    const Vec3& normal(int f) const { return normals_[static_cast<std::size_t>(f)]; }
    const Vec3& centroid(int f) const { return centroids_[static_cast<std::size_t>(f)]; }
    /// The datum an edge lies on: the higher-priority datum of its faces, or -1.
    int datum(const Edge& e) const;
    /// True when one face of `e` is turned towards `camera` and the other away.
    bool isContour(const Edge& e, const geometry::CameraModel& camera) const;

  private:
    const model::TriangleMesh* mesh_;
    std::vector<Edge> edges_;
    std::vector<Vec3> normals_;
    std::vector<Vec3> centroids_;
    std::vector<int> faceDatum_;
};

/// A point of a contour edge (part frame) and its datum (-1 none).
struct ContourSample {
    Vec3 point;
    int edge = 0;
    int datum = -1;
};

/// Where a sample is seen in a view at the current seat.
struct SampleImage {
    Vec2 pixel;  ///< projected sample
    Vec2 normal; ///< unit image normal, pointing out of the silhouette
};

/// The contour samples of one view: material points on the contour edges
/// that lie on the outline of the projected solid, about `spacingPx` apart,
/// at most `maxSamples`. `nearGrazingDeg`: edges of a face within this angle
/// of being seen edge-on are sampled too (whichever of such a face's two
/// edges is outermost depends on the seat).
std::vector<ContourSample> sampleContour(const EdgeGraph& graph, const model::Solid& solid,
                                         const geometry::CameraModel& camera, double nearGrazingDeg, int maxSamples);

/// The sample's pixel and outward normal (the side its faces fold away from)
/// in `camera`; false when it is behind the camera.
bool projectSample(const EdgeGraph& graph, const ContourSample& sample, const geometry::CameraModel& camera,
                   SampleImage& out);
/// As projectSample, and false when its edge is no occluding contour from there.
bool imageOf(const EdgeGraph& graph, const ContourSample& sample, const geometry::CameraModel& camera,
             SampleImage& out);

/// Grey frame access for the edge search.
using vision::EdgeImage;

/// The silhouette edge along the sample's normal within `bandPx`
/// (vision::findEdge); false when there is no clean crossing. `offset`
/// receives its distance along the normal, pixels.
bool findEdge(const EdgeImage& image, const SampleImage& at, double bandPx, double& offset);

} // namespace hg::align
