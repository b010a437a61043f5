// Capture manifest (docs/contracts.md §3): a set of views for offline work — one image
// per view with the camera that took it — and how to segment the images.
//
//   {"views": [{"id": "v0", "image": "v0.png", "K": [[...]], "dist": [...],
//               "R": [[...]], "t": [x, y, z]},
//              {"id": "v1", "image": "v1.png", "P": [[...4], [...4], [...4]]}],
//    "segmentation": {"method": "otsu", "object_is_dark": true}}
//
// Cameras follow docs/contracts.md: X_cam = R X_part + t, pixel = K X_cam, then
// OpenCV distortion. A view gives either K, R, t (+ optional dist) or a 3x4
// P (part frame to pixels), decomposed into K, R, t.
//
// Extensions (optional, written by `hullgauge simulate`, ignored by readers
// that do not know them): per view `image_size: [width, height]` in pixels and
// `fixture_pose: {rotation_deg, declination_deg}` or `{rail_mm}`; at the top
// level `simulation: {seat: {R, t, centre, shift_mm, rotation_deg}}`, the true
// seat `hullgauge simulate --seat` rendered the part with;
// `calibration_uncertainty: {intrinsics_std_dev: {fx, fy, cx, cy, k1, k2, p1,
// p2, k3}, fixture_rms_mm}` and `image_quality: {noise_grey, contrast_grey}`,
// the station's, which the sub-voxel deviation's budget and the capability
// check use; per view `origin: [x, y]`, where a region image lies on the
// sensor (`image_size` then the sensor's size). Any other
// key is kept out of the model and logged at warning level (category
// "vision"), so third-party additions do not stop a run but typos show.
//
// readManifest checks structure and values, not the images; every problem is
// an InputError naming the manifest and the field:
//   manifest.json: views[2].K: expected 3 rows of 3 numbers
#pragma once

#include "hullgauge/geometry/camera.h"
#include "hullgauge/geometry/fixture.h"
#include "hullgauge/geometry/station.h"
#include "hullgauge/vision/segmentation.h"

#include <filesystem>
#include <opencv2/core/mat.hpp>
#include <optional>
#include <string>
#include <vector>

namespace hg::vision {

/// Where the fixture stood when a view was taken (manifest extension).
struct ManifestFixturePose {
    geometry::FixtureType type = geometry::FixtureType::RotationDeclination;
    geometry::FixturePose pose;
};

struct ManifestView {
    std::string id;
    /// The image file; relative paths in the file are resolved against the
    /// manifest's folder when read.
    std::filesystem::path image;
    /// The posed camera. Its image size is `image_size` when the manifest
    /// gives one, else 0 x 0 until the image is read (readViewImage).
    geometry::CameraModel camera;
    /// True when the file gave the view as a 3x4 P (written back as K, R, t).
    bool fromProjectionMatrix = false;
    std::optional<ManifestFixturePose> fixturePose;
    /// Extension `origin: [x, y]`: the image is a region of the sensor, its
    /// pixel (u, v) the sensor's (x + u, y + v) (docs/contracts.md §3; the
    /// daemon's archive of frames grabbed as regions, docs/camera.md "Regions
    /// per grab"). Needs `image_size`, the sensor's size, which the camera keeps.
    std::optional<cv::Point> origin{};
};

struct CaptureManifest {
    std::vector<ManifestView> views;
    SegmentationSettings segmentation;
    /// The station's calibration records' uncertainty and image quality
    /// (extension `calibration_uncertainty`, `image_quality`: the daemon's
    /// archive carries its station's, so `inspect` budgets as it did;
    /// docs/inspection.md, "Uncertainty budget").
    geometry::CalibrationUncertainty calibration;
    std::optional<geometry::ImageQuality> imageQuality;
    /// The file it was read from (empty for a manifest built in memory).
    std::filesystem::path file;

    /// The view with `id`, or nullptr.
    const ManifestView* find(const std::string& id) const;
};

/// Reads and validates a manifest. Throws InputError(file, "views[i].field",
/// problem) for any structural or value error (JSON syntax errors name the line).
CaptureManifest readManifest(const std::filesystem::path& file);

/// Writes `manifest` to `file` as JSON (K, dist, R, t per view; image paths
/// relative to the manifest's folder where possible). Throws FaultError when
/// the file cannot be written.
void writeManifest(const CaptureManifest& manifest, const std::filesystem::path& file);
/// The JSON text writeManifest writes into a file in `folder`.
std::string manifestJson(const CaptureManifest& manifest, const std::filesystem::path& folder);

/// Reads the image of view `index` (8- or 16-bit, grey or colour, converted
/// to one channel of the same depth). An unreadable image, one whose size
/// differs from the view's image_size, or (with `origin`) one that placed at
/// its origin leaves the image_size, throws InputError naming "views[index].image".
cv::Mat readViewImage(const CaptureManifest& manifest, std::size_t index);

} // namespace hg::vision
