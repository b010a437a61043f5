// Calibration targets: a chessboard or a ChArUco board, described on the
// command line as `chessboard:COLSxROWS:SQUARE_MM` (COLS x ROWS inner corners)
// or `charuco:COLSxROWS:SQUARE_MM:MARKER_MM[:DICTIONARY]` (COLS x ROWS squares;
// dictionary default DICT_5X5_100), and their detection in grey images.
//
// Target frame: origin at the first inner corner, x along the columns, y along
// the rows, z = 0 on the board (mm). Corner i of a chessboard is at column
// i % COLS, row i / COLS; a ChArUco corner with id k is at column k % (COLS-1),
// row k / (COLS-1) (OpenCV's numbering).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "hullgauge/common/format.h"

namespace hg::calib {

enum class TargetKind { Chessboard, Charuco };

struct TargetSpec {
    TargetKind kind = TargetKind::Chessboard;
    int cols = 0; ///< chessboard: inner corners per row; ChArUco: squares per row
    int rows = 0; ///< chessboard: inner corners per column; ChArUco: squares per column
    double squareMm = 0.0;
    double markerMm = 0.0;  ///< ChArUco only
    std::string dictionary; ///< ChArUco only, e.g. "DICT_5X5_100"

    /// Parses a pattern description; errors throw hg::InputError naming `field`.
    static TargetSpec parse(const std::string& text, const std::string& field = "--pattern");

    /// Number of inner corners of the full board.
    int cornerCount() const;
    /// Position of corner `id` in the target frame (mm, z = 0).
    cv::Point3f cornerPosition(int id) const;
};

/// The target found in one image: corner pixels and the matching target-frame
/// points (same order), and the corner ids (chessboard: 0..N-1 in order).
struct TargetView {
    std::string name;
    std::vector<cv::Point2f> imagePoints;
    std::vector<cv::Point3f> objectPoints;
    std::vector<int> ids;
};

/// Finds the target in a grey (or colour) image with sub-pixel corners
/// (chessboard: findChessboardCorners + cornerSubPix; ChArUco: marker
/// detection + corner interpolation). std::nullopt when the board is not
/// found, or fewer than 6 ChArUco corners are seen.
std::optional<TargetView> detectTarget(const cv::Mat& image, const TargetSpec& spec, const std::string& name);

/// A view from corner pixels given in a file (`ids` empty: all corners in order).
TargetView viewFromCorners(const TargetSpec& spec, const std::string& name, const std::vector<cv::Point2f>& pixels,
                           const std::vector<int>& ids = {});

} // namespace hg::calib

/// A target as its description, which TargetSpec::parse reads back: fmt::format("{}", spec),
/// "chessboard:9x6:25" or "charuco:8x6:30:22:DICT_5X5_100".
template <> struct fmt::formatter<hg::calib::TargetSpec> : hg::ValueFormatter {
    fmt::format_context::iterator format(const hg::calib::TargetSpec& spec, fmt::format_context& ctx) const;
};
