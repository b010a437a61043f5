#include "hullgauge/calib/rail.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>
#include <sstream>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>

#include "hullgauge/common/error.h"
#include "hullgauge/common/log.h"
#include "least_squares.h"

namespace hg::calib {
namespace {

using geometry::Vec2;

std::vector<RailSeries> parseSeries(const ConfigNode& node)
{
    if (!node.isSequence()) node.fail("expected a list of {displacement_mm, samples}");
    std::vector<RailSeries> series;
    for (const auto& item : node.items()) {
        item.allowOnlyKeys({"displacement_mm", "samples"});
        RailSeries s;
        s.displacementMm = item["displacement_mm"].asDouble();
        s.samples = RailObservations::parseTrack(item["samples"]);
        series.push_back(std::move(s));
    }
    return series;
}

SampleStatistics statistics(const std::vector<double>& v)
{
    SampleStatistics s;
    s.count = static_cast<int>(v.size());
    if (v.empty()) return s;
    double sum = 0.0;
    for (double x : v) sum += x;
    s.mean = sum / static_cast<double>(v.size());
    if (v.size() > 1) {
        double ss = 0.0;
        for (double x : v) ss += (x - s.mean) * (x - s.mean);
        s.stdDev = std::sqrt(ss / static_cast<double>(v.size() - 1));
    }
    return s;
}

std::string fmtRange(double v)
{
    char b[32];
    std::snprintf(b, sizeof b, "%g", v);
    return b;
}

} // namespace

std::vector<RailSample> RailObservations::parseTrack(const ConfigNode& node)
{
    if (!node.isSequence() || node.size() == 0) node.fail("expected a list of {range_mm, pixel: [x, y]}");
    std::vector<RailSample> samples;
    std::set<double> ranges;
    for (const auto& item : node.items()) {
        item.allowOnlyKeys({"range_mm", "pixel"});
        RailSample s;
        s.rangeMm = item["range_mm"].asDouble();
        s.pixel = item["pixel"].asVector2();
        if (!ranges.insert(s.rangeMm).second) item["range_mm"].fail("range given twice in this series");
        samples.push_back(s);
    }
    return samples;
}

RailObservations RailObservations::parse(const ConfigNode& root)
{
    if (!root.isMap()) root.fail("expected a map with horizontal, vertical and optional centre_tracks");
    root.allowOnlyKeys({"horizontal", "vertical", "centre_tracks", "units", "note"});
    if (auto u = root.optional("units"); u && u->asString() != "mm")
        u->fail("only 'mm' is supported (ranges and displacements in millimetres)");
    RailObservations obs;
    obs.horizontal = parseSeries(root["horizontal"]);
    obs.vertical = parseSeries(root["vertical"]);
    if (auto t = root.optional("centre_tracks")) {
        if (!t->isSequence()) t->fail("expected a list of tracks, each a list of {range_mm, pixel}");
        for (const auto& track : t->items()) obs.centreTracks.push_back(RailObservations::parseTrack(track));
    }
    return obs;
}

RailObservations RailObservations::load(const std::filesystem::path& file)
{
    return parse(ConfigNode::loadFile(file));
}

OpticalCentreEstimate estimateOpticalCentre(const RailObservations& obs, double stationaryPx)
{
    std::vector<const std::vector<RailSample>*> tracks;
    for (const auto& s : obs.horizontal) tracks.push_back(&s.samples);
    for (const auto& s : obs.vertical) tracks.push_back(&s.samples);
    for (const auto& t : obs.centreTracks) tracks.push_back(&t);

    // Each track gives a line n·x = c (total least squares through its
    // pixels); a track that does not move gives the point itself. The centre
    // minimises the summed squared distances to all of them.
    Eigen::Matrix2d A = Eigen::Matrix2d::Zero();
    Eigen::Vector2d b = Eigen::Vector2d::Zero();
    struct Constraint {
        Vec2 normal;
        double c;
    };
    std::vector<Constraint> rows;
    OpticalCentreEstimate est;
    for (const auto* t : tracks) {
        if (t->size() < 2) continue;
        Vec2 mean = Vec2::Zero();
        for (const auto& s : *t) mean += s.pixel;
        mean /= static_cast<double>(t->size());
        Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
        for (const auto& s : *t) cov += (s.pixel - mean) * (s.pixel - mean).transpose();
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(cov);
        Vec2 direction = eig.eigenvectors().col(1);
        double extent = 0.0;
        for (const auto& s : *t) extent = std::max(extent, std::abs((s.pixel - mean).dot(direction)));
        if (2.0 * extent < stationaryPx) {
            rows.push_back({Vec2::UnitX(), mean.x()});
            rows.push_back({Vec2::UnitY(), mean.y()});
            ++est.stationary;
        } else {
            Vec2 normal = eig.eigenvectors().col(0);
            rows.push_back({normal, normal.dot(mean)});
            ++est.lines;
        }
    }
    for (const auto& r : rows) {
        A += r.normal * r.normal.transpose();
        b += r.normal * r.c;
    }
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> check(A);
    if (rows.empty() || check.eigenvalues()(0) < 1e-6 * std::max(1.0, check.eigenvalues()(1)))
        throw InputError("", "optical centre",
                         "the image tracks do not fix a point: give horizontal and vertical series (or centre "
                         "tracks) whose points move as the range changes in two different directions");
    est.centre = A.ldlt().solve(b);
    double ss = 0.0;
    for (const auto& r : rows) ss += std::pow(r.normal.dot(est.centre) - r.c, 2);
    est.rmsPx = std::sqrt(ss / static_cast<double>(rows.size()));
    return est;
}

SimilarTriangleTable similarTriangleTable(const std::vector<RailSeries>& series, double centreCoordinate, int axis)
{
    SimilarTriangleTable table;
    std::set<double> rangeSet;
    for (const auto& s : series)
        for (const auto& sample : s.samples) rangeSet.insert(sample.rangeMm);
    std::vector<double> ranges(rangeSet.begin(), rangeSet.end());
    // Rows in the dissertation's order: neighbouring ranges first, then pairs
    // two steps apart, and so on (31/25, 37/31, ..., 49/25 last).
    for (std::size_t gap = 1; gap < ranges.size(); ++gap)
        for (std::size_t i = 0; i + gap < ranges.size(); ++i) table.rangePairs.emplace_back(ranges[i + gap], ranges[i]);
    for (const auto& s : series) table.displacementsMm.push_back(s.displacementMm);

    table.values.assign(table.rangePairs.size(), std::vector<std::optional<double>>(series.size()));
    std::vector<std::vector<double>> perPair(table.rangePairs.size()), perDisplacement(series.size());
    std::vector<double> all;
    for (std::size_t col = 0; col < series.size(); ++col) {
        std::map<double, double> offsetAt; // range -> n, pixels from the optical centre
        for (const auto& sample : series[col].samples) offsetAt[sample.rangeMm] = sample.pixel[axis] - centreCoordinate;
        double v = series[col].displacementMm;
        for (std::size_t row = 0; row < table.rangePairs.size(); ++row) {
            auto [far, near] = table.rangePairs[row];
            auto nIt = offsetAt.find(near), fIt = offsetAt.find(far);
            if (nIt == offsetAt.end() || fIt == offsetAt.end() || v == 0.0) continue;
            double n = nIt->second, nPrime = fIt->second;
            // Eq. 4.3.1-1. A point that did not move between the two ranges
            // (n = n', quantisation) gives no value, as in Tables 4.3-4.4.
            if (std::abs(n - nPrime) < 1e-9) continue;
            double ratio = (far - near) / v * (n * nPrime) / (n - nPrime);
            table.values[row][col] = ratio;
            perPair[row].push_back(ratio);
            perDisplacement[col].push_back(ratio);
            all.push_back(ratio);
        }
    }
    for (const auto& v : perPair) table.byRangePair.push_back(statistics(v));
    for (const auto& v : perDisplacement) table.byDisplacement.push_back(statistics(v));
    table.overall = statistics(all);
    return table;
}

RailCalibration calibrateRail(const RailObservations& obs)
{
    auto needSeries = [](const std::vector<RailSeries>& s, const char* key) {
        bool any = std::any_of(s.begin(), s.end(),
                               [](const RailSeries& x) { return x.displacementMm != 0.0 && x.samples.size() >= 2; });
        if (!any)
            throw InputError("", key, "needs at least one displaced point (displacement_mm != 0) seen at two ranges");
    };
    needSeries(obs.horizontal, "horizontal");
    needSeries(obs.vertical, "vertical");

    RailCalibration cal;
    cal.centre = estimateOpticalCentre(obs);
    cal.horizontal = similarTriangleTable(obs.horizontal, cal.centre.centre.x(), 0);
    cal.vertical = similarTriangleTable(obs.vertical, cal.centre.centre.y(), 1);
    if (cal.horizontal.overall.count == 0 || cal.vertical.overall.count == 0)
        throw InputError("", cal.horizontal.overall.count == 0 ? "horizontal" : "vertical",
                         "no range pair moved the displaced points' images: eq. 4.3.1-1 has no value");

    // Least-squares pinhole fit over all observations. Start from the track
    // intersection, the mean similar-triangle ratios, and the rail offset that
    // those ratios imply (depth = f/Δp · v / n).
    struct Obs {
        double range, displacement, pixel;
        int axis;
    };
    std::vector<Obs> data;
    for (const auto& s : obs.horizontal)
        for (const auto& smp : s.samples) data.push_back({smp.rangeMm, s.displacementMm, smp.pixel.x(), 0});
    for (const auto& s : obs.vertical)
        for (const auto& smp : s.samples) data.push_back({smp.rangeMm, s.displacementMm, smp.pixel.y(), 1});
    double fx0 = cal.horizontal.overall.mean, fy0 = cal.vertical.overall.mean;
    std::vector<double> offsets;
    for (const auto& o : data) {
        double c = o.axis == 0 ? cal.centre.centre.x() : cal.centre.centre.y();
        double n = o.pixel - c;
        if (std::abs(n) > 5.0 && o.displacement != 0.0)
            offsets.push_back((o.axis == 0 ? fx0 : fy0) * o.displacement / n - o.range);
    }
    std::nth_element(offsets.begin(), offsets.begin() + static_cast<long>(offsets.size() / 2), offsets.end());
    double d0 = offsets.empty() ? 0.0 : offsets[offsets.size() / 2];

    Eigen::VectorXd x0(7);
    x0 << fx0, fy0, cal.centre.centre.x(), cal.centre.centre.y(), d0, 0.0, 0.0;
    Eigen::VectorXd step(7);
    step << 1e-6 * std::abs(fx0) + 1e-6, 1e-6 * std::abs(fy0) + 1e-6, 1e-4, 1e-4, 1e-5 * (std::abs(d0) + 1.0), 1e-5,
        1e-5;
    auto residuals = [&data](const Eigen::VectorXd& p, Eigen::VectorXd& r) {
        r.resize(static_cast<Eigen::Index>(data.size()));
        for (std::size_t i = 0; i < data.size(); ++i) {
            const auto& o = data[i];
            double depth = o.range + p[4];
            double predicted = o.axis == 0 ? p[2] + p[0] * (o.displacement + p[5]) / depth
                                           : p[3] + p[1] * (o.displacement + p[6]) / depth;
            r[static_cast<Eigen::Index>(i)] = predicted - o.pixel;
        }
    };
    auto ls = detail::levenbergMarquardt(residuals, x0, step, 200);
    auto& fit = cal.fit;
    fit.fx = ls.x[0];
    fit.fy = ls.x[1];
    fit.cx = ls.x[2];
    fit.cy = ls.x[3];
    fit.rangeOffsetMm = ls.x[4];
    fit.mountOffsetHMm = ls.x[5];
    fit.mountOffsetVMm = ls.x[6];
    for (int i = 0; i < 7; ++i) fit.stdDev.push_back(std::sqrt(std::max(0.0, ls.covariance(i, i))));
    fit.observations = static_cast<int>(data.size());
    fit.rmsPx = std::sqrt(ls.residuals.squaredNorm() / static_cast<double>(data.size()));
    hg::log::category("calib")->info("rail: centre ({:.2f}, {:.2f}), f/dp_h {:.1f}, f/dp_v {:.1f}, fit RMS {:.3f} px",
                                     cal.centre.centre.x(), cal.centre.centre.y(), fit.fx, fit.fy, fit.rmsPx);
    return cal;
}

namespace {

void printTable(std::ostringstream& s, const SimilarTriangleTable& t, const char* title, const char* pairTitle,
                const char* dispTitle)
{
    char b[64];
    s << title << "\n  range pair   ";
    for (double d : t.displacementsMm) {
        std::snprintf(b, sizeof b, " %12s", (fmtRange(d) + " mm").c_str());
        s << b;
    }
    s << '\n';
    for (std::size_t row = 0; row < t.rangePairs.size(); ++row) {
        std::snprintf(b, sizeof b, "  %-13s",
                      (fmtRange(t.rangePairs[row].first) + "/" + fmtRange(t.rangePairs[row].second)).c_str());
        s << b;
        for (const auto& v : t.values[row]) {
            if (v)
                std::snprintf(b, sizeof b, " %12.1f", *v);
            else
                std::snprintf(b, sizeof b, " %12s", "-");
            s << b;
        }
        s << '\n';
    }
    s << pairTitle << "\n  range pair          AVE          STD    n\n";
    for (std::size_t row = 0; row < t.rangePairs.size(); ++row) {
        const auto& st = t.byRangePair[row];
        std::snprintf(b, sizeof b, "  %-13s",
                      (fmtRange(t.rangePairs[row].first) + "/" + fmtRange(t.rangePairs[row].second)).c_str());
        s << b;
        if (st.count)
            std::snprintf(b, sizeof b, " %12.1f %12.1f %4d\n", st.mean, st.stdDev, st.count);
        else
            std::snprintf(b, sizeof b, " %12s %12s %4d\n", "-", "-", 0);
        s << b;
    }
    s << dispTitle << "\n  displacement        AVE          STD    n\n";
    for (std::size_t col = 0; col < t.displacementsMm.size(); ++col) {
        const auto& st = t.byDisplacement[col];
        std::snprintf(b, sizeof b, "  %-13s", (fmtRange(t.displacementsMm[col]) + " mm").c_str());
        s << b;
        if (st.count)
            std::snprintf(b, sizeof b, " %12.1f %12.1f %4d\n", st.mean, st.stdDev, st.count);
        else
            std::snprintf(b, sizeof b, " %12s %12s %4d\n", "-", "-", 0);
        s << b;
    }
    std::snprintf(b, sizeof b, "  all          %12.1f %12.1f %4d\n\n", t.overall.mean, t.overall.stdDev,
                  t.overall.count);
    s << b;
}

} // namespace

std::string formatRailReport(const RailCalibration& cal)
{
    std::ostringstream s;
    char b[256];
    std::snprintf(
        b, sizeof b, "optical centre (4.3 step 1, %d moving tracks, %d stationary): (%.3f, %.3f) px, RMS %.3f px\n\n",
        cal.centre.lines, cal.centre.stationary, cal.centre.centre.x(), cal.centre.centre.y(), cal.centre.rmsPx);
    s << b;
    printTable(s, cal.horizontal, "f/dp_h by similar triangles, eq. 4.3.1-1 (Table 4.3)",
               "f/dp_h by range pair (Table 4.5)", "f/dp_h by displacement (Table 4.6)");
    printTable(s, cal.vertical, "f/dp_v by similar triangles, eq. 4.3.1-1 (Table 4.4)",
               "f/dp_v by range pair (Table 4.5)", "f/dp_v by displacement (Table 4.6)");
    const auto& f = cal.fit;
    auto sd = [&](std::size_t i) { return i < f.stdDev.size() ? f.stdDev[i] : 0.0; };
    s << "least-squares pinhole fit over all " << f.observations << " observations:\n";
    std::snprintf(b, sizeof b, "  f/dp_h %.2f +- %.2f   f/dp_v %.2f +- %.2f\n", f.fx, sd(0), f.fy, sd(1));
    s << b;
    std::snprintf(b, sizeof b, "  optical centre (%.3f +- %.3f, %.3f +- %.3f) px\n", f.cx, sd(2), f.cy, sd(3));
    s << b;
    std::snprintf(b, sizeof b, "  rail zero offset d0 %.3f +- %.3f mm, mount zero offsets h0 %.4f, w0 %.4f mm\n",
                  f.rangeOffsetMm, sd(4), f.mountOffsetHMm, f.mountOffsetVMm);
    s << b;
    std::snprintf(b, sizeof b, "  RMS residual %.4f px\n", f.rmsPx);
    s << b;
    return s.str();
}

} // namespace hg::calib
