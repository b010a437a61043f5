#include "hullgauge/calib/target.h"

#include <array>
#include <charconv>
#include <sstream>
#include <utility>

#include <opencv2/aruco/charuco.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "hullgauge/common/error.h"

namespace hg::calib {
namespace {

constexpr std::array<std::pair<const char*, int>, 21> kDictionaries{{
    {"DICT_4X4_50", cv::aruco::DICT_4X4_50},
    {"DICT_4X4_100", cv::aruco::DICT_4X4_100},
    {"DICT_4X4_250", cv::aruco::DICT_4X4_250},
    {"DICT_4X4_1000", cv::aruco::DICT_4X4_1000},
    {"DICT_5X5_50", cv::aruco::DICT_5X5_50},
    {"DICT_5X5_100", cv::aruco::DICT_5X5_100},
    {"DICT_5X5_250", cv::aruco::DICT_5X5_250},
    {"DICT_5X5_1000", cv::aruco::DICT_5X5_1000},
    {"DICT_6X6_50", cv::aruco::DICT_6X6_50},
    {"DICT_6X6_100", cv::aruco::DICT_6X6_100},
    {"DICT_6X6_250", cv::aruco::DICT_6X6_250},
    {"DICT_6X6_1000", cv::aruco::DICT_6X6_1000},
    {"DICT_7X7_50", cv::aruco::DICT_7X7_50},
    {"DICT_7X7_100", cv::aruco::DICT_7X7_100},
    {"DICT_7X7_250", cv::aruco::DICT_7X7_250},
    {"DICT_7X7_1000", cv::aruco::DICT_7X7_1000},
    {"DICT_ARUCO_ORIGINAL", cv::aruco::DICT_ARUCO_ORIGINAL},
    {"DICT_APRILTAG_16h5", cv::aruco::DICT_APRILTAG_16h5},
    {"DICT_APRILTAG_25h9", cv::aruco::DICT_APRILTAG_25h9},
    {"DICT_APRILTAG_36h10", cv::aruco::DICT_APRILTAG_36h10},
    {"DICT_APRILTAG_36h11", cv::aruco::DICT_APRILTAG_36h11},
}};

std::vector<std::string> split(const std::string& s, char sep)
{
    std::vector<std::string> parts;
    std::stringstream ss(s);
    std::string item;
    while (std::getline(ss, item, sep)) parts.push_back(item);
    return parts;
}

double parseNumber(const std::string& s, const std::string& field, const std::string& what)
{
    double v = 0.0;
    auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    if (ec != std::errc() || ptr != s.data() + s.size() || !(v > 0.0))
        throw InputError("", field, what + " must be a positive number, got '" + s + "'");
    return v;
}

int parseCount(const std::string& s, const std::string& field, const std::string& what)
{
    int v = 0;
    auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    if (ec != std::errc() || ptr != s.data() + s.size() || v < 2 || v > 200)
        throw InputError("", field, what + " must be a whole number from 2 to 200, got '" + s + "'");
    return v;
}

int dictionaryId(const std::string& name)
{
    for (const auto& [n, id] : kDictionaries)
        if (name == n) return id;
    return -1;
}

cv::Ptr<cv::aruco::CharucoBoard> makeBoard(const TargetSpec& spec)
{
    auto dict = cv::aruco::getPredefinedDictionary(dictionaryId(spec.dictionary));
    return cv::aruco::CharucoBoard::create(spec.cols, spec.rows, static_cast<float>(spec.squareMm),
                                           static_cast<float>(spec.markerMm), dict);
}

} // namespace

TargetSpec TargetSpec::parse(const std::string& text, const std::string& field)
{
    const std::string usage = "expected chessboard:COLSxROWS:SQUARE_MM or charuco:COLSxROWS:SQUARE_MM:MARKER_MM[:DICT]";
    auto parts = split(text, ':');
    if (parts.size() < 3) throw InputError("", field, usage + ", got '" + text + "'");
    TargetSpec spec;
    if (parts[0] == "chessboard") {
        if (parts.size() != 3) throw InputError("", field, usage + ", got '" + text + "'");
        spec.kind = TargetKind::Chessboard;
    } else if (parts[0] == "charuco") {
        if (parts.size() != 4 && parts.size() != 5) throw InputError("", field, usage + ", got '" + text + "'");
        spec.kind = TargetKind::Charuco;
    } else {
        throw InputError("", field, "unknown target '" + parts[0] + "' (chessboard or charuco)");
    }
    auto size = split(parts[1], 'x');
    if (size.size() != 2) throw InputError("", field, "board size must be COLSxROWS, got '" + parts[1] + "'");
    spec.cols = parseCount(size[0], field, "COLS");
    spec.rows = parseCount(size[1], field, "ROWS");
    spec.squareMm = parseNumber(parts[2], field, "square size");
    if (spec.kind == TargetKind::Charuco) {
        if (spec.cols < 3 || spec.rows < 3) throw InputError("", field, "a ChArUco board needs at least 3x3 squares");
        spec.markerMm = parseNumber(parts[3], field, "marker size");
        if (spec.markerMm >= spec.squareMm) throw InputError("", field, "the marker must be smaller than the square");
        spec.dictionary = parts.size() == 5 ? parts[4] : "DICT_5X5_100";
        if (dictionaryId(spec.dictionary) < 0)
            throw InputError("", field, "unknown ArUco dictionary '" + spec.dictionary + "' (e.g. DICT_5X5_100)");
        // Every white square carries its own marker.
        auto dict = cv::aruco::getPredefinedDictionary(dictionaryId(spec.dictionary));
        int markers = spec.cols * spec.rows / 2;
        if (markers > dict->bytesList.rows)
            throw InputError("", field,
                             "dictionary " + spec.dictionary + " has too few markers for a " +
                                 std::to_string(spec.cols) + "x" + std::to_string(spec.rows) + " board");
    }
    return spec;
}

int TargetSpec::cornerCount() const
{
    return kind == TargetKind::Chessboard ? cols * rows : (cols - 1) * (rows - 1);
}

cv::Point3f TargetSpec::cornerPosition(int id) const
{
    int perRow = kind == TargetKind::Chessboard ? cols : cols - 1;
    // ChArUco corners start one square in from the board's corner; the target
    // frame puts its origin on the first inner corner for both kinds.
    return {static_cast<float>((id % perRow) * squareMm), static_cast<float>((id / perRow) * squareMm), 0.0f};
}

TargetView viewFromCorners(const TargetSpec& spec, const std::string& name, const std::vector<cv::Point2f>& pixels,
                           const std::vector<int>& ids)
{
    TargetView v;
    v.name = name;
    v.imagePoints = pixels;
    for (std::size_t i = 0; i < pixels.size(); ++i) {
        int id = ids.empty() ? static_cast<int>(i) : ids[i];
        v.ids.push_back(id);
        v.objectPoints.push_back(spec.cornerPosition(id));
    }
    return v;
}

std::optional<TargetView> detectTarget(const cv::Mat& image, const TargetSpec& spec, const std::string& name)
{
    cv::Mat grey;
    if (image.channels() == 3)
        cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
    else if (image.channels() == 4)
        cv::cvtColor(image, grey, cv::COLOR_BGRA2GRAY);
    else
        grey = image;
    if (grey.depth() == CV_16U) {
        // Mono12 sits in the low bits of the word, Mono16 uses them all:
        // stretch the frame's own range to 8 bits for the detectors.
        double lo = 0.0, hi = 0.0;
        cv::minMaxLoc(grey, &lo, &hi);
        double scale = hi > lo ? 255.0 / (hi - lo) : 1.0;
        grey.convertTo(grey, CV_8U, scale, -lo * scale);
    }
    if (grey.depth() != CV_8U) throw InputError(name, "image", "unsupported pixel type (8- or 16-bit grey or colour)");

    if (spec.kind == TargetKind::Chessboard) {
        std::vector<cv::Point2f> corners;
        cv::Size pattern(spec.cols, spec.rows);
        if (!cv::findChessboardCorners(grey, pattern, corners,
                                       cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE))
            return std::nullopt;
        // The window of OpenCV's calibration sample (11x11): its published
        // results for the sample images were obtained with it.
        cv::cornerSubPix(grey, corners, cv::Size(11, 11), cv::Size(-1, -1),
                         cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 30, 1e-4));
        return viewFromCorners(spec, name, corners);
    }

    auto board = makeBoard(spec);
    std::vector<std::vector<cv::Point2f>> markerCorners;
    std::vector<int> markerIds;
    cv::aruco::detectMarkers(grey, board->dictionary, markerCorners, markerIds);
    if (markerIds.size() < 2) return std::nullopt;
    std::vector<cv::Point2f> corners;
    std::vector<int> ids;
    cv::aruco::interpolateCornersCharuco(markerCorners, markerIds, grey, board, corners, ids);
    if (corners.size() < 6) return std::nullopt;
    return viewFromCorners(spec, name, corners, ids);
}

} // namespace hg::calib

fmt::format_context::iterator fmt::formatter<hg::calib::TargetSpec>::format(const hg::calib::TargetSpec& spec,
                                                                            fmt::format_context& ctx) const
{
    using hg::formatNumber;
    using hg::calib::TargetKind;
    if (spec.kind == TargetKind::Chessboard)
        return fmt::format_to(ctx.out(), "chessboard:{}x{}:{}", spec.cols, spec.rows, formatNumber(spec.squareMm));
    return fmt::format_to(ctx.out(), "charuco:{}x{}:{}:{}:{}", spec.cols, spec.rows, formatNumber(spec.squareMm),
                          formatNumber(spec.markerMm), spec.dictionary);
}
