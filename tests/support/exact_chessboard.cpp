// The exact chessboard renderer of hgtest/exact_render.h: a planar
// chessboard through a telecentric lens, each pixel's covered area integrated
// exactly from the squares' outlines. Written from the lens's definition in
// the header alone; it shares nothing with src/.
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "hgtest/exact_render.h"

namespace hgtest {
namespace {

/// Signed coverage of a raster: each row keeps the parts of pixels that an
/// edge crosses, and a carry that the rest of the row to the right of the
/// edge receives in full (a prefix sum adds it up).
class AreaRaster {
  public:
    explicit AreaRaster(cv::Size size) : w_(size.width), h_(size.height), partial_(size, 0.0), carry_(size, 0.0) {}

    /// Adds one directed edge of a closed polygon, in coordinates where pixel
    /// (c, r) is the square [c, c+1] x [r, r+1]. Summed over a closed
    /// outline, every pixel receives ± the area of the polygon inside it:
    /// the edge contributes, in each pixel and each row band it crosses,
    /// ±∫ (length of the pixel's part to the right of the edge at height y) dy.
    void addEdge(double x0, double y0, double x1, double y1)
    {
        if (y0 == y1) return;
        const double sign = y1 > y0 ? 1.0 : -1.0;
        if (y1 < y0) std::swap(x0, x1), std::swap(y0, y1);
        const double slope = (x1 - x0) / (y1 - y0);
        const int rowFirst = std::max(0, static_cast<int>(std::floor(y0)));
        const int rowLast = std::min(h_ - 1, static_cast<int>(std::ceil(y1)) - 1);
        for (int r = rowFirst; r <= rowLast; ++r) {
            const double yLow = std::max(y0, static_cast<double>(r)), yHigh = std::min(y1, r + 1.0);
            if (!(yHigh > yLow)) continue;
            addPiece(r, x0 + (yLow - y0) * slope, x0 + (yHigh - y0) * slope, sign * (yHigh - yLow));
        }
    }

    /// |accumulated area| per pixel, clamped to [0, 1] against rounding.
    cv::Mat coverage() const
    {
        cv::Mat out(h_, w_, CV_32FC1);
        for (int r = 0; r < h_; ++r) {
            double running = 0.0;
            for (int c = 0; c < w_; ++c) {
                running += carry_(r, c);
                out.at<float>(r, c) = static_cast<float>(std::clamp(std::abs(partial_(r, c) + running), 0.0, 1.0));
            }
        }
        return out;
    }

  private:
    /// ∫ from c to x of g, g(x') = clamp(c + 1 − x', 0, 1): the part of pixel
    /// column c right of an edge at x'.
    static double rightPartIntegral(double x, int c)
    {
        const double s = x - c;
        if (s <= 0.0) return s;
        if (s >= 1.0) return 0.5;
        return s - 0.5 * s * s;
    }

    /// A straight piece within row r from x = xa (at its low end) to xb,
    /// `dy` its signed height.
    void addPiece(int r, double xa, double xb, double dy)
    {
        const double lo = std::min(xa, xb), hi = std::max(xa, xb);
        const int cLo = static_cast<int>(std::floor(lo)), cHi = static_cast<int>(std::floor(hi));
        for (int c = std::max(cLo, 0); c <= std::min(cHi, w_ - 1); ++c) {
            // Mean over the piece's height of the right part: x is linear in
            // y, so it is the mean of g over [lo, hi].
            const double mean = hi - lo > 1e-9 ? (rightPartIntegral(hi, c) - rightPartIntegral(lo, c)) / (hi - lo)
                                               : std::clamp(c + 1.0 - 0.5 * (lo + hi), 0.0, 1.0);
            partial_(r, c) += dy * mean;
        }
        const int rest = std::max(cHi + 1, 0);
        if (rest < w_) carry_(r, rest) += dy;
    }

    int w_, h_;
    cv::Mat1d partial_, carry_;
};

void validate(const PlanarChessboard& board, const TelecentricLens& lens, double maxPiecePx)
{
    if (board.innerCols < 2 || board.innerRows < 2 || !(board.squareMm > 0))
        throw std::invalid_argument("telecentricChessboardCoverage: the board needs 2x2 inner corners or more and a "
                                    "positive square size");
    if (!(lens.fx > 0) || !(lens.fy > 0) || lens.imageSize.width < 1 || lens.imageSize.height < 1)
        throw std::invalid_argument("telecentricChessboardCoverage: fx, fy and the image size must be positive");
    if (!(maxPiecePx > 0)) throw std::invalid_argument("telecentricChessboardCoverage: maxPiecePx must be positive");
}

} // namespace

Eigen::Vector2d telecentricPixel(const TelecentricLens& lens, const Eigen::Matrix3d& R, const Eigen::Vector3d& t,
                                 double xMm, double yMm)
{
    const Eigen::Vector3d p = R * Eigen::Vector3d(xMm, yMm, 0.0) + t;
    const double x = p.x(), y = p.y(); // parallel projection: z plays no part
    const double r2 = x * x + y * y;
    const auto& d = lens.dist; // k1 k2 p1 p2 k3
    const double radial = 1.0 + d[0] * r2 + d[1] * r2 * r2 + d[4] * r2 * r2 * r2;
    const double xd = x * radial + 2.0 * d[2] * x * y + d[3] * (r2 + 2.0 * x * x);
    const double yd = y * radial + d[2] * (r2 + 2.0 * y * y) + 2.0 * d[3] * x * y;
    return {lens.fx * xd + lens.cx, lens.fy * yd + lens.cy};
}

cv::Mat telecentricChessboardCoverage(const PlanarChessboard& board, const Eigen::Matrix3d& R, const Eigen::Vector3d& t,
                                      const TelecentricLens& lens, double maxPiecePx)
{
    validate(board, lens, maxPiecePx);
    AreaRaster raster(lens.imageSize);
    const double s = board.squareMm;
    // The outline's pixel length bounds the pieces; distortion stretches an
    // edge by at most a few percent, which the factor 2 covers.
    const double pxPerMm = std::max(lens.fx, lens.fy);
    const int pieces = std::max(1, static_cast<int>(std::ceil(2.0 * s * pxPerMm / maxPiecePx)));
    for (int j = 0; j <= board.innerRows; ++j)
        for (int i = 0; i <= board.innerCols; ++i) {
            if ((i + j) % 2 != 0) continue;
            const double x0 = (i - 1) * s, y0 = (j - 1) * s;
            const double corners[5][2] = {{x0, y0}, {x0 + s, y0}, {x0 + s, y0 + s}, {x0, y0 + s}, {x0, y0}};
            // The outline, walked in the board's counter-clockwise order; +0.5
            // moves pixel (c, r)'s square [c − 0.5, c + 0.5] to [c, c + 1].
            Eigen::Vector2d previous = telecentricPixel(lens, R, t, x0, y0) + Eigen::Vector2d(0.5, 0.5);
            for (int e = 0; e < 4; ++e)
                for (int k = 1; k <= pieces; ++k) {
                    const double f = static_cast<double>(k) / pieces;
                    const double x = corners[e][0] + f * (corners[e + 1][0] - corners[e][0]);
                    const double y = corners[e][1] + f * (corners[e + 1][1] - corners[e][1]);
                    const Eigen::Vector2d p = telecentricPixel(lens, R, t, x, y) + Eigen::Vector2d(0.5, 0.5);
                    raster.addEdge(previous.x(), previous.y(), p.x(), p.y());
                    previous = p;
                }
        }
    return raster.coverage();
}

} // namespace hgtest
