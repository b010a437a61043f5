// Alignment: the part's seat measured from its silhouettes before it is
// inspected (docs/alignment.md; the dissertation's future work 6.2, item 6,
// "automatic object registration with the optical system").
//
// The seat is the rigid motion `seat` = nominal_from_part: a point X of the
// part (CAD frame) lies at R·X + t in its nominal place, so a view whose
// calibrated camera sees the nominal place (camera_from_nominal) sees the
// seated part through camera_from_part = camera_from_nominal · seat
// (`seatedCamera`). Only the poses change; the octree map stays as built.
//
// Method (model-based edge alignment, as RAPiD / moving-edge trackers and
// region trackers with correspondence lines do it): in every view the CAD
// mesh's occluding contour at the current seat estimate — the mesh edges
// between a face turned towards the camera and one turned away, kept where
// they lie on the outline of the projected solid — is sampled every few
// pixels; along each sample's image normal the grey profile is searched for
// the crossing of the segmentation threshold (the sub-pixel silhouette edge);
// the residual is the distance of the edge from the projected sample along
// the normal. Gauss–Newton over the six parameters (rotation about and shift
// of the part's reference point) with Tukey's biweight, its scale from the
// residuals' median absolute deviation, so that the defects the inspection is
// there to find (a shifted face, a burr, missing material) do not pull the
// seat. Edges are searched again along the normals of the new estimate until
// the seat moves by less than a micrometre.
//
// Directions the views cannot determine (a rotation about the axis of a
// cylinder) are found from the normal matrix's eigenvalues; they stay at
// nominal and are reported (`fixedDofs`), never guessed.
//
// `method: datums` keeps only the samples on the CAD faces of the named datum
// landmarks and solves 3-2-1: the first datum's face takes the directions it
// determines, the second the directions left that it determines, and so on.
//
// Pure computation on values: no I/O, no threads; const methods are safe to
// call from several threads.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "hullgauge/geometry/camera.h"
#include "hullgauge/model/part_program.h"

namespace hg::align {

using geometry::Vec2;
using geometry::Vec3;

/// One view as the aligner sees it.
struct AlignmentView {
    geometry::CameraModel camera; ///< camera_from_part of the nominal seat (the calibrated view)
    cv::Mat grey{};               ///< CV_8UC1 or CV_16UC1: the sensor, or a region of it
    double threshold = 0.0;       ///< grey level of the silhouette edge (the segmentation threshold)
    bool objectIsDark = true;     ///< backlit: the part is darker than the background
    /// Sensor position of grey's pixel (0, 0): a frame that is a region of the
    /// sensor (docs/camera.md, "Regions per grab"); it must lie on the sensor.
    cv::Point origin{0, 0};
};

/// A direction of the seat the views do not determine: left at nominal.
struct FixedDof {
    enum class Kind { Rotation, Translation };
    Kind kind = Kind::Rotation;
    Vec3 axis = Vec3::UnitZ(); ///< unit, part frame
    Vec3 point = Vec3::Zero(); ///< a point of the rotation axis, part frame (rotations)
    std::string label;         ///< "rotation about z through (0, 0, 5)", "translation along x", ...
};

struct AlignmentResult {
    model::AlignmentMethod method = model::AlignmentMethod::Silhouette;
    /// A seat was estimated (false for method none and when too little of the
    /// outline was found: `message` says why; the seat is then nominal).
    bool measured = false;
    geometry::RigidTransform seat;      ///< nominal_from_part
    Vec3 referencePoint = Vec3::Zero(); ///< part frame: the centre of the mesh's bounding box
    double shiftMm = 0.0;               ///< |seat(reference) − reference|
    double rotationDeg = 0.0;           ///< angle of seat.R
    double residualPx = 0.0;            ///< RMS of the inliers' residuals at the solution
    /// The median of the inliers' (edge − outline)·outward normal at the
    /// solution, px: how much larger (positive) or smaller the silhouettes are
    /// than the CAD's outline at the seat, all round — a halo, the exposure or
    /// the threshold moving every edge, which no seat explains (docs/alignment.md,
    /// "Edge bias"; the station's health watches it, docs/health.md).
    double edgeBiasPx = 0.0;
    double shiftUncertaintyMm = 0.0;     ///< expanded (k = 2), the largest over directions
    double rotationUncertaintyDeg = 0.0; ///< expanded (k = 2), the largest over axes
    /// Covariance of (rotation vector [rad], shift of the reference point [mm]).
    Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Zero();
    std::vector<FixedDof> fixedDofs;
    int samples = 0;          ///< contour samples with an edge found (last round)
    int inliers = 0;          ///< of them, with a non-zero robust weight
    int iterations = 0;       ///< Gauss–Newton steps, all rounds
    bool withinLimits = true; ///< shift and rotation within max_shift_mm / max_rotation_deg
    std::string message;      ///< why not measured, or the limit exceeded
    double ms = 0.0;
};

/// One view's share of the work, done as soon as its frame is in (while the
/// fixture moves on): the contour samples at its nominal camera and the edges
/// found around them. Opaque; made by Aligner::prepare.
struct ViewEdges;

class Aligner {
  public:
    /// `landmarks` name the datums of `method: datums`. Throws
    /// ArgumentError for an unknown datum or bad limits.
    Aligner(std::shared_ptr<const model::Solid> solid, const std::vector<model::Landmark>& landmarks,
            model::AlignmentSettings settings);
    ~Aligner();
    Aligner(const Aligner&) = delete;
    Aligner& operator=(const Aligner&) = delete;

    /// Measures the seat from the views (each with its nominal camera).
    /// Throws ArgumentError when a frame does not match its camera.
    AlignmentResult align(const std::vector<AlignmentView>& views) const;
    /// The per-view half of align (docs/daemon.md, "The pipeline"); const and
    /// free of shared state: safe from several threads.
    std::shared_ptr<const ViewEdges> prepare(const AlignmentView& view) const;
    /// align with every view prepared (`prepared[i]` from views[i]).
    AlignmentResult align(const std::vector<AlignmentView>& views,
                          const std::vector<std::shared_ptr<const ViewEdges>>& prepared) const;

    /// How far (mm) any point of the part may lie from its nominal place
    /// within the limits: the margin the inspection's regions of interest need.
    double marginMm() const;
    const model::AlignmentSettings& settings() const;
    /// Every pixel the edge searches may read in a view through this nominal
    /// camera, at any seat within the limits (frame pixels, clipped, not
    /// merged): per contour sample its first search band along the normal
    /// (twice the limits), every later round's 3-pixel search about a seated
    /// estimate, and what the sub-pixel edge reads around them
    /// (docs/inspection.md, "Pixels in proportion to the goal"). Makes the
    /// contour samples as prepare does (ray casts: once per planned view).
    std::vector<cv::Rect> searchRegions(const geometry::CameraModel& camera) const;

  private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

/// The camera that sees the seated part: camera_from_nominal · seat.
geometry::CameraModel seatedCamera(const geometry::CameraModel& nominal, const geometry::RigidTransform& seat);

/// The result's `alignment` object (docs/contracts.md §4, docs/alignment.md).
nlohmann::json toJson(const AlignmentResult& result);
/// A seat (nominal_from_part) given, not measured — the simulated part's true
/// one — in the same terms: R, t, the pivot (`centre`) and the shift of the
/// pivot and the rotation angle to set beside the measured `shift_mm` and
/// `rotation_deg` (docs/alignment.md).
nlohmann::json seatJson(const geometry::RigidTransform& seat, const Vec3& pivot);

} // namespace hg::align
