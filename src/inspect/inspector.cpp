#include "hullgauge/inspect/inspector.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_set>

#include "hullgauge/common/clock.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/format.h"
#include "hullgauge/common/log.h"

namespace hg::inspect {
namespace {

/// "±0.05 mm", or "[-0.02, 0.08] mm" for asymmetric limits.
std::string limitsText(const MapLandmark& lm)
{
    if (!lm.limitsMm) return "±" + formatNumber(lm.toleranceMm) + " mm";
    return "[" + formatNumber(lm.lowerMm()) + ", " + formatNumber(lm.upperMm()) + "] mm";
}

/// The same camera to the last bit: the outline points found for one serve the other.
bool sameCamera(const geometry::CameraModel& a, const geometry::CameraModel& b)
{
    const auto &ia = a.intrinsics(), &ib = b.intrinsics();
    return ia.K == ib.K && ia.dist == ib.dist && ia.imageSize == ib.imageSize &&
           a.cameraFromPart().R == b.cameraFromPart().R && a.cameraFromPart().t == b.cameraFromPart().t;
}

int chebyshev(const Eigen::Vector3i& a, const Eigen::Vector3i& b)
{
    return (a - b).cwiseAbs().maxCoeff();
}

/// The network voxels the landmark's normal line crosses within `A` layers of
/// its voxel `node0`, in order along the normal (docs/inspection.md, "boundary
/// bracket"): geometry only, found once per inspector.
std::vector<std::int32_t> normalLineNodes(const InspectionMap& map, const MapLandmark& lm, std::int32_t node0, int A,
                                          int level)
{
    const Eigen::Vector3i c0 = keyIndex(map.nodes()[static_cast<std::size_t>(node0)].key);
    const double dv = map.frame().voxelSize(level);
    const double reach = (A + 1.0) * dv * std::sqrt(3.0);
    const double step = dv / 16.0;
    std::vector<std::int32_t> nodes;
    VoxelKey previous = ~VoxelKey{0};
    for (double s = -reach; s <= reach; s += step) {
        // Consecutive samples mostly share a voxel: look each voxel up once.
        const VoxelKey key = map.frame().keyAt(lm.position + s * lm.normal, level);
        if (key == previous) continue;
        previous = key;
        const std::int32_t n = map.find(key);
        if (n < 0 || chebyshev(keyIndex(map.nodes()[static_cast<std::size_t>(n)].key), c0) > A) continue;
        if (nodes.empty() || nodes.back() != n) nodes.push_back(n);
    }
    return nodes;
}

/// Per-inspection memo of reconstructed labels, parallel to the map's nodes
/// (3.3.1: "each voxel will be reconstructed only once").
class Memo {
  public:
    Memo(const InspectionMap& map, const VoxelOracle& oracle)
        : map_(map), oracle_(oracle), labels_(map.nodes().size(), VoxelLabel::Unknown)
    {
    }
    VoxelLabel label(std::int32_t node, int& counter)
    {
        VoxelLabel& l = labels_[static_cast<std::size_t>(node)];
        if (l == VoxelLabel::Unknown) {
            l = oracle_(map_.frame().box(map_.nodes()[static_cast<std::size_t>(node)].key));
            ++counter;
            ++total_;
        }
        return l;
    }
    /// A decided label that differs from the CAD's. Don't-care voxels (CAD
    /// fraction at the 50 % tie) and hidden ones (no silhouette can carve
    /// them) are never wrong.
    bool wrong(std::int32_t node, VoxelLabel l) const
    {
        if (l != VoxelLabel::Object && l != VoxelLabel::Void) return false;
        const MapNode& n = map_.nodes()[static_cast<std::size_t>(node)];
        if (n.dontCare || n.hidden) return false;
        return (l == VoxelLabel::Object) != n.expectedObject;
    }
    std::uint64_t total() const { return total_; }

  private:
    const InspectionMap& map_;
    const VoxelOracle& oracle_;
    std::vector<VoxelLabel> labels_;
    std::uint64_t total_ = 0;
};

} // namespace

Inspector::Inspector(const InspectionMap& map, InspectionOptions options, std::shared_ptr<const align::Aligner> aligner,
                     std::shared_ptr<const DeviationGauge> gauge)
    : map_(&map), options_(std::move(options)), aligner_(std::move(aligner)), gauge_(std::move(gauge))
{
    const MapGeometry& g = map.geometry();
    level_ = options_.level < 0 ? g.depth : options_.level;
    if (level_ < g.coarsestLevel || level_ > g.depth)
        throw ArgumentError("inspection level " + std::to_string(level_) + " is not in the map (levels " +
                            std::to_string(g.coarsestLevel) + ".." + std::to_string(g.depth) + ")");
    adjacency_ = options_.adjacency < 0 ? g.adjacencyDepth : options_.adjacency;
    if (adjacency_ < 1 || adjacency_ > g.adjacencyDepth)
        throw ArgumentError("adjacency " + std::to_string(adjacency_) + " must be within 1.." +
                            std::to_string(g.adjacencyDepth));
    active_.assign(map.landmarks().size(), 1);
    for (const std::string& id : options_.maskedLandmarks) {
        const auto idx = map.landmarkIndex(id);
        if (!idx) throw ArgumentError("masked landmark '" + id + "' is not in the map");
        active_[*idx] = 0;
    }
    normalLines_.resize(map.landmarks().size());
    for (std::size_t l = 0; l < map.landmarks().size(); ++l)
        if (active_[l])
            normalLines_[l] = normalLineNodes(map, map.landmarks()[l], map.landmarkNode(l, level_), adjacency_, level_);
}

RegionQuery Inspector::regionQuery() const
{
    RegionQuery q;
    q.level = level_;
    q.adjacency = adjacency_;
    q.active = active_;
    // The seat moves the part by up to the aligner's margin (docs/alignment.md).
    q.marginMm = aligner_ ? aligner_->marginMm() : 0.0;
    q.edges = gauge_ != nullptr;
    return q;
}

ViewRegions Inspector::regions(const geometry::CameraModel& camera) const
{
    ViewRegions r = viewRegions(*map_, camera, regionQuery());
    if (aligner_) {
        std::vector<cv::Rect> edges = r.edges;
        for (const cv::Rect& band : aligner_->searchRegions(camera)) edges.push_back(band);
        r.edges = mergeOverlapping(edges);
        for (const cv::Rect& e : r.edges) r.bounds = r.bounds.empty() ? e : (r.bounds | e);
    }
    return r;
}

std::vector<cv::Rect> Inspector::regionsOfInterest(const geometry::CameraModel& camera) const
{
    return viewRegions(*map_, camera, regionQuery()).voxels;
}

namespace {

/// The sensor pixels a captured view's frame holds; throws naming the view
/// when they leave the sensor (docs/inspection.md, "Frames that are regions").
cv::Rect deliveredPixels(const CapturedView& v)
{
    const cv::Size sensor = v.camera.imageSize();
    const cv::Rect delivered(v.origin, v.frame.size());
    if (v.frame.empty() || (delivered & cv::Rect(cv::Point(0, 0), sensor)) != delivered)
        throw ArgumentError("view '" + v.id + "': frame " + std::to_string(v.frame.cols) + "x" +
                            std::to_string(v.frame.rows) + " at sensor (" + std::to_string(v.origin.x) + ", " +
                            std::to_string(v.origin.y) + ") does not lie on the camera's " +
                            std::to_string(sensor.width) + "x" + std::to_string(sensor.height) + " sensor");
    return delivered;
}

/// Rectangles in sensor pixels, clipped to the delivered ones (the rest is
/// unknown to the voxel test), empty ones dropped.
std::vector<cv::Rect> clippedTo(const std::vector<cv::Rect>& rects, const cv::Rect& delivered)
{
    std::vector<cv::Rect> out;
    for (const cv::Rect& r : rects)
        if (const cv::Rect c = r & delivered; !c.empty()) out.push_back(c);
    return out;
}

std::vector<cv::Rect> shifted(std::vector<cv::Rect> rects, cv::Point by)
{
    for (cv::Rect& r : rects) r -= by;
    return rects;
}

} // namespace

SilhouetteView Inspector::prepareView(const CapturedView& v, const vision::SegmentationSettings& segmentation) const
{
    const cv::Rect delivered = deliveredPixels(v);
    const cv::Mat grey = vision::toGrey(v.frame);
    // Only the regions' pixels: their statistics give the threshold, they
    // alone are segmented (docs/inspection.md, "Pixels in proportion to the
    // goal"). Regions are sensor pixels; the frame's are `origin` less.
    const std::vector<cv::Rect> rects =
        options_.wholeFrame ? std::vector<cv::Rect>{delivered} : clippedTo(regionsOfInterest(v.camera), delivered);
    const std::vector<cv::Rect> local = shifted(rects, v.origin);
    const double threshold = options_.wholeFrame ? vision::computeThreshold(grey, segmentation)
                                                 : vision::computeThreshold(grey, local, segmentation);
    const bool mask = segmentation.method == vision::SegmentationMethod::Mask;
    // A mask frame's edge lies half-way between its two values.
    const double edgeLevel = mask ? (grey.depth() == CV_8U ? 127.5 : 32767.5) : threshold;
    SilhouetteView sv{v.camera, SilhouetteIndex(v.camera.imageSize()), grey, edgeLevel,
                      !mask && segmentation.objectIsDark};
    sv.origin = v.origin;
    // The view's share of the alignment now, not after the last frame (docs/alignment.md).
    if (aligner_) sv.alignment = aligner_->prepare({sv.camera, sv.grey, sv.threshold, sv.objectIsDark, sv.origin});
    // The ray casts of the sub-voxel step: found when the program was loaded, else now (docs/inspection.md).
    if (gauge_) sv.outlines = outlinesFor(v.camera);
    for (std::size_t k = 0; k < rects.size(); ++k)
        sv.index.addRegion(rects[k], vision::segmentRegion(grey, local[k], threshold, segmentation));
    return sv;
}

InspectionResult Inspector::inspect(const std::vector<CapturedView>& views,
                                    const vision::SegmentationSettings& segmentation,
                                    const DeviationReferral& referral) const
{
    const Stopwatch watch;
    std::vector<SilhouetteView> silhouettes;
    std::vector<std::string> ids;
    silhouettes.reserve(views.size());
    for (const CapturedView& v : views) {
        silhouettes.push_back(prepareView(v, segmentation));
        ids.push_back(v.id);
    }
    const Milliseconds segmentationTime = watch.elapsed();
    InspectionResult r = inspect(std::move(silhouettes), ids, referral);
    r.segmentationTime = segmentationTime;
    r.totalTime = watch.elapsed();
    return r;
}

InspectionResult Inspector::inspect(std::vector<SilhouetteView> views, const std::vector<std::string>& viewIds,
                                    const DeviationReferral& referral) const
{
    const Stopwatch watch;
    InspectionResult seatFault;
    if (aligner_ && !seat(views, seatFault)) {
        seatFault.totalTime = watch.elapsed();
        return seatFault;
    }
    VoxelTester tester(&views, options_.method);
    InspectionResult r = run([&](const Box3& b) { return tester.classify(b); }, &views, &viewIds);
    r.alignment = std::move(seatFault.alignment);
    if (gauge_) measureDeviations(r, views, viewIds, referral);
    markUnproven(r);
    r.totalTime = watch.elapsed();
    return r;
}

// docs/mastering.md: the reading referred to 20 °C (the expansion taken
// out), then corrected by the master; U grows by root-sum-square with the
// temperature's share and the correction's, the reading's own U scaled by
// the gain.
std::optional<AppliedReferral> Inspector::refer(Deviation& d, const MapLandmark& lm,
                                                const DeviationReferral& referral) const
{
    const LandmarkCorrection* correction = referral.correction ? referral.correction->find(lm.id) : nullptr;
    const bool thermal = referral.temperatureC && options_.expansionPerK != 0.0;
    if (!correction && !thermal) return std::nullopt;
    AppliedReferral a;
    a.rawDeviationMm = d.deviationMm;
    a.rawUncertaintyMm = d.uncertaintyMm;
    if (thermal) {
        a.thermalMm = thermalOffsetMm(options_.expansionPerK, *referral.temperatureC, lm.position, lm.normal,
                                      options_.expansionCentre);
        a.thermalUncertaintyMm =
            2.0 *
            std::abs(thermalOffsetMm(options_.expansionPerK, 21.0, lm.position, lm.normal, options_.expansionCentre)) *
            referral.temperatureSigmaC;
    }
    const double reading = d.deviationMm - a.thermalMm;
    const double readingU = std::hypot(d.uncertaintyMm, a.thermalUncertaintyMm);
    d.deviationMm = reading;
    d.uncertaintyMm = readingU;
    if (correction) {
        a.correctionId = referral.correction->id;
        a.correctionGain = correction->gain();
        a.correctionOffsetMm = correction->offsetMm();
        a.correctionUncertaintyMm = correction->uncertaintyAt(reading);
        d.deviationMm = correction->correct(reading);
        d.uncertaintyMm = std::hypot(a.correctionGain * readingU, a.correctionUncertaintyMm);
    }
    return a;
}

// The sub-voxel step (docs/inspection.md, "Sub-voxel deviation",
// "Decisions"): each landmark's edge in the views that see it on their
// outline, referred and corrected (docs/mastering.md); where the bracket found
// the surface (ok or out of tolerance) the decision on the deviation, its
// uncertainty and the limits sets the status.
void Inspector::measureDeviations(InspectionResult& r, const std::vector<SilhouetteView>& views,
                                  const std::vector<std::string>& viewIds, const DeviationReferral& referral) const
{
    for (LandmarkResult& lr : r.landmarks) {
        const auto index = map_->landmarkIndex(lr.id);
        if (!index) continue;
        const MapLandmark& lm = map_->landmarks()[*index];
        lr.deviation = gauge_->measure(*index, lm, views, viewIds, r.alignment ? &*r.alignment : nullptr);
        if (!lr.deviation->measured) continue;
        lr.referral = refer(*lr.deviation, lm, referral);
        if (lr.status != LandmarkStatus::Ok && lr.status != LandmarkStatus::OutOfTolerance) continue;
        const Deviation& d = *lr.deviation;
        lr.decision = decide(d.deviationMm, d.uncertaintyMm, lm.lowerMm(), lm.upperMm(), options_.decisionRule);
        const LandmarkStatus before = lr.status;
        lr.status = *lr.decision == Decision::Conforms      ? LandmarkStatus::Ok
                    : *lr.decision == Decision::Nonconforms ? LandmarkStatus::OutOfTolerance
                                                            : LandmarkStatus::Uncertain;
        const std::string measured = "deviation " + formatNumber(d.deviationMm, 4) + " mm ± " +
                                     formatNumber(d.uncertaintyMm, 4) + " mm (k = 2) against " + limitsText(lm);
        if (lr.status == LandmarkStatus::Uncertain)
            lr.reason = measured + ": conformance not proven";
        else if (lr.status == LandmarkStatus::OutOfTolerance && before != lr.status)
            lr.reason = measured + ": out of tolerance";
        else if (lr.status == LandmarkStatus::Ok)
            lr.reason.clear();
    }
    r.pass = true;
    for (const LandmarkResult& lr : r.landmarks)
        if (lr.status != LandmarkStatus::Ok) r.pass = false;
    for (const ParameterResult& pr : r.parameters)
        if (pr.status != ParameterStatus::Ok) r.pass = false;
}

// A landmark the capability check refused and the user forced (docs/inspection.md,
// "Capability"): the station cannot prove its tolerance, so it is never ok.
void Inspector::markUnproven(InspectionResult& r) const
{
    for (LandmarkResult& lr : r.landmarks) {
        const bool unproven = std::find(options_.unprovenLandmarks.begin(), options_.unprovenLandmarks.end(), lr.id) !=
                              options_.unprovenLandmarks.end();
        if (!unproven || lr.status != LandmarkStatus::Ok) continue;
        lr.status = LandmarkStatus::Uncertain;
        if (lr.decision) lr.decision = Decision::Uncertain;
        lr.reason = "the tolerance zone is narrower than 4 U at this station (inspected with --force): "
                    "conformance cannot be proven";
        r.pass = false;
    }
}

void Inspector::prepareOutlines(const std::vector<geometry::CameraModel>& cameras)
{
    if (!gauge_) return;
    for (const geometry::CameraModel& c : cameras)
        if (!cachedOutlines(c))
            outlineCache_.emplace_back(c, std::make_shared<const ViewOutlines>(gauge_->outlines(map_->landmarks(), c)));
}

std::shared_ptr<const ViewOutlines> Inspector::cachedOutlines(const geometry::CameraModel& camera) const
{
    for (const auto& [c, outlines] : outlineCache_)
        if (sameCamera(c, camera)) return outlines;
    return nullptr;
}

std::shared_ptr<const ViewOutlines> Inspector::outlinesFor(const geometry::CameraModel& camera) const
{
    if (auto cached = cachedOutlines(camera)) return cached;
    return std::make_shared<const ViewOutlines>(gauge_->outlines(map_->landmarks(), camera));
}

// Alignment before the traversal (docs/alignment.md): the views were
// segmented through their nominal cameras with the aligner's margin, so only
// the cameras move.
std::optional<align::AlignmentResult> Inspector::measureSeat(const std::vector<SilhouetteView>& views) const
{
    if (!aligner_) return std::nullopt;
    std::vector<align::AlignmentView> frames;
    std::vector<std::shared_ptr<const align::ViewEdges>> prepared;
    frames.reserve(views.size());
    for (const SilhouetteView& v : views) {
        frames.push_back({v.camera, v.grey, v.threshold, v.objectIsDark, v.origin});
        prepared.push_back(v.alignment ? v.alignment : aligner_->prepare(frames.back()));
    }
    return aligner_->align(frames, prepared);
}

bool Inspector::seat(std::vector<SilhouetteView>& views, InspectionResult& result) const
{
    result.alignment = measureSeat(views);
    const align::AlignmentResult& a = *result.alignment;
    if (a.measured && a.withinLimits) {
        for (SilhouetteView& v : views) v.camera = align::seatedCamera(v.camera, a.seat);
        return true;
    }
    result.part = map_->partName();
    result.level = level_;
    result.adjacency = adjacency_;
    result.voxelSizeMm = map_->frame().voxelSize(level_);
    result.viewsUsed = static_cast<int>(views.size());
    result.seatingFault = true;
    for (const auto& l : map_->landmarks()) {
        LandmarkResult lr;
        lr.id = l.id;
        lr.toleranceMm = l.toleranceMm;
        lr.limitsMm = l.limitsMm;
        lr.reason = a.message;
        result.landmarks.push_back(std::move(lr));
    }
    return false;
}

InspectionResult Inspector::inspectWith(const VoxelOracle& oracle) const
{
    const Stopwatch watch;
    InspectionResult r = run(oracle, nullptr, nullptr);
    r.totalTime = watch.elapsed();
    return r;
}

namespace {

/// One landmark's share of the traversal: the voxels it labels (each once per
/// inspection through the memo), those found wrong, and the count it caused.
struct LandmarkSearch {
    const InspectionMap& map;
    Memo& memo;
    std::int32_t node0; ///< the landmark voxel
    int A;              ///< adjacency layers searched
    Eigen::Vector3i c0 = keyIndex(map.nodes()[static_cast<std::size_t>(node0)].key);
    std::unordered_set<std::int32_t> visited = {};
    std::vector<std::int32_t> wrong = {};
    int counter = 0; ///< voxels this landmark caused to be reconstructed

    /// 26-neighbour layers from the landmark voxel.
    int layer(std::int32_t n) const { return chebyshev(keyIndex(map.nodes()[static_cast<std::size_t>(n)].key), c0); }
    bool within(std::int32_t n) const { return layer(n) <= A; }
    bool seen(std::int32_t n) const { return visited.count(n) != 0; }
    VoxelLabel visit(std::int32_t n)
    {
        const VoxelLabel lab = memo.label(n, counter);
        visited.insert(n);
        if (memo.wrong(n, lab)) wrong.push_back(n);
        return lab;
    }
};

struct TraversalOutcome {
    VoxelLabel landmarkLabel = VoxelLabel::Unknown;
    bool objectFound = false;
    bool frontAtLimit = false; ///< wrong voxels reach the outermost layer
};

/// The traversal of 3.3.8 for one landmark: reconstruct the landmark voxel;
/// if it is object (or void as the map expects: a landmark in the outer half
/// of its voxel, or in a don't-care voxel), check its neighbours; if it
/// should be object but is void, look ring by ring for object voxels nearby
/// — the candidate places of the displaced landmark. From each object seed,
/// reconstruct the neighbours and go on only from those reconstructed wrongly
/// (the walk prunes every branch that matches the map), out to A layers.
TraversalOutcome traverseLandmark(const InspectionMap& map, LandmarkSearch& search)
{
    TraversalOutcome out;
    const std::int32_t n0 = search.node0;
    const VoxelLabel l0 = search.visit(n0);
    out.landmarkLabel = l0;
    out.objectFound = l0 == VoxelLabel::Object;
    std::vector<std::int32_t> seeds;
    if (l0 == VoxelLabel::Object || (l0 == VoxelLabel::Void && !search.memo.wrong(n0, l0))) {
        seeds.push_back(n0);
    } else if (l0 == VoxelLabel::Void) {
        map.walkNetwork(
            {n0},
            [&](std::int32_t v) {
                if (search.seen(v) || !search.within(v)) return false;
                if (search.visit(v) != VoxelLabel::Object) return true;
                seeds.push_back(v);
                return false;
            },
            [&] { return !seeds.empty(); });
        out.objectFound = !seeds.empty();
    }
    map.walkNetwork(
        std::move(seeds),
        [&](std::int32_t v) {
            if (search.seen(v) || !search.within(v)) return false;
            if (!search.memo.wrong(v, search.visit(v))) return false;
            if (search.layer(v) >= search.A) out.frontAtLimit = true;
            return true;
        },
        [] { return false; });
    return out;
}

/// Discrimination (4.5.2): which views observe the landmark, and the best
/// eq. 4.4.4-19 MED among them.
void discriminate(LandmarkResult& lr, const MapLandmark& lm, const std::vector<SilhouetteView>& views,
                  const std::vector<std::string>& viewIds)
{
    for (std::size_t v = 0; v < views.size(); ++v) {
        ViewReport vr{viewIds[v], viewDiscrimination(views[v].camera, lm.position)};
        if (vr.discrimination.observes && (!lr.medMm || vr.discrimination.medRangeMm < *lr.medMm))
            lr.medMm = vr.discrimination.medRangeMm;
        lr.views.push_back(std::move(vr));
    }
}

/// The network voxels on the landmark's normal line, in order, with their
/// labels and normal coordinates s_c (docs/inspection.md, "boundary bracket").
struct NormalLine {
    std::vector<VoxelLabel> labels;
    std::vector<double> sc;
    bool undecided = false;
    bool hidden = false; ///< a hidden voxel next to the landmark voxel
};

NormalLine reconstructNormalLine(const InspectionMap& map, LandmarkSearch& search, const MapLandmark& lm,
                                 const std::vector<std::int32_t>& nodes)
{
    NormalLine line;
    for (std::int32_t n : nodes) {
        const MapNode& node = map.nodes()[static_cast<std::size_t>(n)];
        const VoxelLabel lab = search.visit(n);
        line.undecided = line.undecided || lab == VoxelLabel::Undecided;
        // The void next to the landmark is enclosed by the part: no view can carve it.
        line.hidden = line.hidden || (node.hidden && search.layer(n) <= 1);
        line.labels.push_back(lab);
        line.sc.push_back((map.frame().box(node.key).center() - lm.position).dot(lm.normal));
    }
    return line;
}

/// The bracket [sLow, sHigh] of the surface along the normal and the error
/// measures over it (3.3.6, 4.6.2), then the status they give.
/// Asymmetric limits decide on the bracket's signed middle (docs/inspection.md).
bool withinLimits(double offsetMm, const MapLandmark& lm)
{
    return offsetMm >= lm.lowerMm() && offsetMm <= lm.upperMm();
}

void measureAlongNormal(LandmarkResult& lr, const MapLandmark& lm, const NormalLine& line, bool objectFound, double dv)
{
    const auto& labels = line.labels;
    const auto& sc = line.sc;
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (std::size_t i = 0; i + 1 < labels.size(); ++i)
        if (labels[i] != labels[i + 1]) {
            lo = std::min({lo, sc[i], sc[i + 1]});
            hi = std::max({hi, sc[i], sc[i + 1]});
        }
    const bool anyObject = std::find(labels.begin(), labels.end(), VoxelLabel::Object) != labels.end();
    const bool changes = lo <= hi;
    lr.overflowLow = !labels.empty() && labels.front() == VoxelLabel::Void;
    lr.overflowHigh = !labels.empty() && labels.back() == VoxelLabel::Object;
    if (lr.overflowLow) lo = sc.front() - 0.5 * dv;
    if (lr.overflowHigh) hi = sc.back() + 0.5 * dv;
    // A line of one label: the surface lies beyond its outermost object voxel's
    // centre, or short of its innermost void voxel's centre.
    if (!changes && lr.overflowHigh) lo = sc.back();
    if (!changes && lr.overflowLow) hi = sc.front();
    if (!(lo <= hi)) lo = hi = 0.0;
    lr.offsetLowMm = lo;
    lr.offsetHighMm = hi;
    lr.errorMinMm = (lo <= 0.0 && hi >= 0.0) ? 0.0 : std::min(std::abs(lo), std::abs(hi));
    lr.errorMaxMm = std::max(std::abs(lo), std::abs(hi));
    lr.errorMm = 0.5 * (lr.errorMinMm + lr.errorMaxMm);
    lr.measured = true;
    if (!anyObject && !objectFound) {
        lr.status = LandmarkStatus::NotFound;
        lr.reason = "no object voxel within the adjacency layers of the landmark";
    } else if (lr.overflowLow || lr.overflowHigh) {
        lr.status = LandmarkStatus::Overflow;
        lr.reason = "the boundary lies beyond the adjacency layers";
    } else if (lm.limitsMm ? !withinLimits(0.5 * (lo + hi), lm) : lr.errorMm > lm.toleranceMm) {
        lr.status = LandmarkStatus::OutOfTolerance;
    } else {
        lr.status = LandmarkStatus::Ok;
    }
}

/// A landmark no view can measure (docs/inspection.md, status order): hidden
/// void beside it, undecided voxels, or no view resolving ΔV (eq. 4.4.4-19).
/// Returns false when the landmark is observable.
bool notObservable(LandmarkResult& lr, const TraversalOutcome& t, const NormalLine& line, bool checkResolution,
                   double dv)
{
    if (line.hidden) {
        lr.reason = "the void next to the landmark is enclosed by the part: no line of sight through it misses "
                    "the part, so no silhouette can reconstruct it (not weakly convex, 3.3.8)";
    } else if (t.landmarkLabel == VoxelLabel::Undecided || line.undecided) {
        lr.reason = "no view decides the voxels at the landmark (footprints outside the frames or behind a camera)";
    } else if (checkResolution && (!lr.medMm || *lr.medMm > dv)) {
        lr.reason = lr.medMm ? "no view resolves the voxel size (eq. 4.4.4-19: best MED " + std::to_string(*lr.medMm) +
                                   " mm > ΔV " + std::to_string(dv) + " mm)"
                             : "no view sees the landmark";
    } else {
        return false;
    }
    lr.status = LandmarkStatus::NotObservable;
    return true;
}

/// Statistics (4.6.3) over the landmarks with a measured error; the volume
/// error counts distinct wrong voxels (3.3.6).
Statistics errorStatistics(const std::vector<LandmarkResult>& landmarks, std::size_t wrongVoxels, double dv)
{
    Statistics st;
    std::vector<const LandmarkResult*> measured;
    for (const LandmarkResult& lr : landmarks)
        if (lr.measured) measured.push_back(&lr);
    st.landmarksMeasured = static_cast<int>(measured.size());
    const double N = static_cast<double>(measured.size());
    // Mean and population standard deviation of one measure (eq. 4.6.3-1..6).
    auto meanAndStd = [&](double LandmarkResult::*f, double& mean, double& sd) {
        for (const LandmarkResult* m : measured) mean += m->*f / N;
        for (const LandmarkResult* m : measured) sd += (m->*f - mean) * (m->*f - mean) / N;
        sd = std::sqrt(sd);
    };
    if (!measured.empty()) {
        meanAndStd(&LandmarkResult::errorMinMm, st.aveErrorMin, st.stdErrorMin);
        meanAndStd(&LandmarkResult::errorMaxMm, st.aveErrorMax, st.stdErrorMax);
        meanAndStd(&LandmarkResult::errorMm, st.aveError, st.stdError);
        st.minError = std::numeric_limits<double>::infinity();
        for (const LandmarkResult* m : measured) {
            st.maxError = std::max(st.maxError, m->errorMaxMm);
            st.minError = std::min(st.minError, m->errorMinMm);
        }
    }
    st.totalVolumeError = static_cast<double>(wrongVoxels) * dv * dv * dv;
    return st;
}

/// One geometric parameter (4.6.4) from its landmarks' bounded brackets.
ParameterResult measureParameter(const InspectionMap& map, const MapParameter& p,
                                 const std::vector<LandmarkResult>& landmarks)
{
    ParameterResult pr;
    pr.id = p.id;
    pr.kind = p.kind;
    pr.nominal = p.nominal;
    pr.tolerance = p.tolerance;
    std::vector<LandmarkEstimate> est;
    for (const std::string& id : p.landmarks) {
        const auto idx = map.landmarkIndex(id);
        const auto it =
            std::find_if(landmarks.begin(), landmarks.end(), [&](const LandmarkResult& x) { return x.id == id; });
        if (!idx || it == landmarks.end() || !it->measured || it->overflowLow || it->overflowHigh) return pr;
        const MapLandmark& lm = map.landmarks()[*idx];
        est.push_back({lm.position, lm.normal, it->offsetLowMm, it->offsetHighMm});
    }
    if (est.empty()) return pr;
    switch (p.kind) {
    case ParameterKind::Distance:
        if (est.size() != 2) return pr;
        pr.value = distanceBracket(est[0], est[1]);
        break;
    case ParameterKind::Perimeter:
        pr.value = perimeterBracket(est);
        break;
    case ParameterKind::Area:
        pr.value = areaBracket(est);
        break;
    }
    pr.measured = true;
    pr.status =
        std::abs(pr.value.mid() - p.nominal) > p.tolerance ? ParameterStatus::OutOfTolerance : ParameterStatus::Ok;
    return pr;
}

/// One landmark (3.3.8, then 4.5.2 and 4.6.2): discrimination of the views,
/// the traversal, the bracket along the normal and the status.
LandmarkResult inspectLandmark(const InspectionMap& map, const MapLandmark& lm, LandmarkSearch& search, int level,
                               const std::vector<std::int32_t>& normalLine, const std::vector<SilhouetteView>* views,
                               const std::vector<std::string>* viewIds, bool checkResolution,
                               std::unordered_set<std::int32_t>& allWrong)
{
    const double dv = map.frame().voxelSize(level);
    LandmarkResult lr;
    lr.id = lm.id;
    lr.toleranceMm = lm.toleranceMm;
    lr.limitsMm = lm.limitsMm;
    if (views) discriminate(lr, lm, *views, *viewIds);
    const TraversalOutcome t = traverseLandmark(map, search);
    lr.errorNumber = static_cast<int>(search.wrong.size());
    allWrong.insert(search.wrong.begin(), search.wrong.end());
    const NormalLine line = reconstructNormalLine(map, search, lm, normalLine);
    lr.voxelsReconstructed = search.counter;
    if (!notObservable(lr, t, line, checkResolution, dv)) measureAlongNormal(lr, lm, line, t.objectFound, dv);
    if (t.frontAtLimit && lr.status != LandmarkStatus::Ok && lr.reason.empty())
        lr.reason = "wrongly reconstructed voxels reach the outermost adjacency layer";
    return lr;
}

} // namespace

InspectionResult Inspector::run(const VoxelOracle& oracle, const std::vector<SilhouetteView>* views,
                                const std::vector<std::string>* viewIds) const
{
    const Stopwatch watch;
    const InspectionMap& map = *map_;
    const double dv = map.frame().voxelSize(level_);
    Memo memo(map, oracle);
    InspectionResult result;
    result.part = map.partName();
    result.level = level_;
    result.adjacency = adjacency_;
    result.voxelSizeMm = dv;
    result.viewsUsed = views ? static_cast<int>(views->size()) : 0;

    std::unordered_set<std::int32_t> allWrong;
    bool stopped = false;
    for (std::size_t l = 0; l < map.landmarks().size(); ++l) {
        if (!active_[l]) continue;
        if (stopped) {
            LandmarkResult lr;
            lr.id = map.landmarks()[l].id;
            lr.toleranceMm = map.landmarks()[l].toleranceMm;
            lr.limitsMm = map.landmarks()[l].limitsMm;
            lr.reason = "inspection stopped at an earlier failing landmark";
            result.landmarks.push_back(std::move(lr));
            continue;
        }
        LandmarkSearch search{map, memo, map.landmarkNode(l, level_), adjacency_};
        result.landmarks.push_back(inspectLandmark(map, map.landmarks()[l], search, level_, normalLines_[l], views,
                                                   viewIds, views && options_.requireResolution, allWrong));
        stopped = options_.earlyExit && result.landmarks.back().status != LandmarkStatus::Ok;
    }
    result.statistics = errorStatistics(result.landmarks, allWrong.size(), dv);
    for (const MapParameter& p : map.parameters())
        result.parameters.push_back(measureParameter(map, p, result.landmarks));

    result.pass = true;
    for (const LandmarkResult& lr : result.landmarks)
        if (lr.status != LandmarkStatus::Ok) result.pass = false;
    for (const ParameterResult& pr : result.parameters)
        if (pr.status != ParameterStatus::Ok) result.pass = false;
    result.voxelsReconstructed = memo.total();
    result.reconstructionTime = watch.elapsed();
    log::category("inspect")->debug("inspected {} landmarks at level {}: {} voxels reconstructed, {}",
                                    result.landmarks.size(), level_, result.voxelsReconstructed,
                                    result.pass ? "pass" : "fail");
    return result;
}

} // namespace hg::inspect
