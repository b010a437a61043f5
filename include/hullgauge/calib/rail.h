// The dissertation's rail calibration (4.3, 4.3.1, after Tan): the camera
// moves along a rail towards a target point that a movable mount displaces
// horizontally or vertically from the optical axis.
//
//  Step 1, optical centre: the image point that stays fixed as the range
//  changes. Every point's image track is a straight line through it (the
//  focus of expansion of a motion along the optical axis), so the centre is
//  the least-squares intersection of the tracks.
//
//  Step 2, f/Δp by similar triangles, eq. 4.3.1-1:
//      f/Δp = (Δd / v) · n n' / (n − n')
//  for a point displaced v from the axis, seen n pixels from the centre at the
//  nearer range and n' at the farther one, Δd = farther − nearer range. Every
//  pair of ranges and every displacement gives one value (Tables 4.3, 4.4);
//  their means and standard deviations per range pair (Table 4.5) and per
//  displacement (Table 4.6) follow the dissertation.
//
//  Beside it, a least-squares pinhole fit to all observations at once:
//      u = cx + fx (h + h0) / (d + d0),  v = cy + fy (w + w0) / (d + d0)
//  with the rail's zero offset d0 and the mount's zero offsets (h0, w0) free,
//  which removes the quantisation and pairing noise that made the
//  dissertation's per-pair values scatter so widely.
//
// Units: ranges and displacements in mm (any one length unit works: f/Δp is
// unitless); pixels in OpenCV's convention (x right, y down).
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "hullgauge/common/config_node.h"
#include "hullgauge/geometry/transform.h"

namespace hg::calib {

struct RailSample {
    double rangeMm = 0.0; ///< rail reading: camera-to-target distance up to a constant, growing away from the target
    geometry::Vec2 pixel; ///< image of the target point (x = column, y = row)
};

/// One mount position: the point displaced `displacementMm` from the optical
/// axis (horizontal series: along image +x; vertical series: along image +y),
/// imaged at several ranges.
struct RailSeries {
    double displacementMm = 0.0;
    std::vector<RailSample> samples;
};

struct RailObservations {
    std::vector<RailSeries> horizontal;
    std::vector<RailSeries> vertical;
    /// Extra tracks for step 1 (points anywhere, no displacement needed).
    std::vector<std::vector<RailSample>> centreTracks;

    /// Reads the observations file (docs/calibration.md); errors name file, line and key.
    static RailObservations load(const std::filesystem::path& file);
    static RailObservations parse(const ConfigNode& root);
    /// One track: a list of {range_mm, pixel: [x, y]}, each range once.
    static std::vector<RailSample> parseTrack(const ConfigNode& node);
};

struct OpticalCentreEstimate {
    geometry::Vec2 centre = geometry::Vec2::Zero();
    double rmsPx = 0.0; ///< RMS distance of the tracks (and stationary points) from the centre
    int lines = 0;      ///< tracks used as lines
    int stationary = 0; ///< tracks that did not move (used as points)
};

/// Step 1 (4.3): least-squares intersection of the image tracks of every
/// series and centre track. Tracks shorter than `stationaryPx` count as a
/// point observed at the centre. Throws hg::InputError when the tracks do
/// not fix a point (all parallel, or none).
OpticalCentreEstimate estimateOpticalCentre(const RailObservations& obs, double stationaryPx = 2.0);

struct SampleStatistics {
    double mean = 0.0;
    double stdDev = 0.0; ///< sample standard deviation (n − 1); 0 for one value
    int count = 0;
};

/// Table 4.3 (horizontal) or 4.4 (vertical): f/Δp for every range pair (rows,
/// "far/near") and displacement (columns), with Tables 4.5 and 4.6 beside it.
struct SimilarTriangleTable {
    std::vector<double> displacementsMm;
    std::vector<std::pair<double, double>> rangePairs; ///< (far, near)
    /// values[row][column]; empty where undefined (on the axis, or n = n').
    std::vector<std::vector<std::optional<double>>> values;
    std::vector<SampleStatistics> byRangePair;    ///< Table 4.5
    std::vector<SampleStatistics> byDisplacement; ///< Table 4.6
    SampleStatistics overall;
};

/// Eq. 4.3.1-1 for every range pair and displacement; `axis` 0 uses image x
/// (horizontal series, f/Δp_h), 1 uses image y (vertical, f/Δp_v).
SimilarTriangleTable similarTriangleTable(const std::vector<RailSeries>& series, double centreCoordinate, int axis);

struct RailPinholeFit {
    double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0;
    double rangeOffsetMm = 0.0;                        ///< d0: depth = range + d0
    double mountOffsetHMm = 0.0, mountOffsetVMm = 0.0; ///< h0, w0
    /// One standard deviation of fx, fy, cx, cy, d0, h0, w0.
    std::vector<double> stdDev;
    double rmsPx = 0.0;
    int observations = 0;
};

struct RailCalibration {
    OpticalCentreEstimate centre;
    SimilarTriangleTable horizontal; ///< f/Δp_h
    SimilarTriangleTable vertical;   ///< f/Δp_v
    RailPinholeFit fit;
};

/// Runs steps 1 and 2 and the least-squares fit. Needs horizontal and vertical
/// series with at least two ranges each; throws hg::InputError otherwise.
RailCalibration calibrateRail(const RailObservations& obs);

/// The tables of 4.3.1 as text (Tables 4.3–4.6 layout) and the fit.
std::string formatRailReport(const RailCalibration& cal);

} // namespace hg::calib
