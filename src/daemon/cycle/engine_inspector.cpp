#include "cycle/engine_inspector.h"

#include "cycle/view_pipeline.h"
#include "hullgauge/common/clock.h"
#include "hullgauge/common/error.h"
#include "hullgauge/common/log.h"
#include "hullgauge/inspect/correction.h"
#include "hullgauge/inspect/program_inspector.h"
#include "hullgauge/model/part_program.h"
#include "hullgauge/vision/edge.h"
#include "hullgauge/vision/segmentation.h"

#include <chrono>
#include <cmath>
#include <map>

namespace hg::daemon {
namespace {

std::vector<geometry::CameraModel> plannedCameras(const station::PartProgramRef& ref, const geometry::Station& station)
{
    std::vector<geometry::CameraModel> cameras;
    for (const geometry::FixturePose& pose : ref.views) cameras.push_back(station.cameraAt(pose));
    return cameras;
}

// What of the station a program is loaded with: its calibration, and the
// capability check at the program's planned views (docs/inspection.md,
// "Capability"): a tolerance this station cannot prove there refuses the
// program (FAULT 30 at a trigger; at start, --check and reload the
// configuration) unless its entry says `force`.
inspect::InspectionStation stationFor(const station::PartProgramRef& ref, const model::PartProgram& program,
                                      const geometry::Station& station)
{
    return {station.calibration,
            inspect::CapabilityCheck{inspect::assessProgram(program, station.calibration, plannedCameras(ref, station),
                                                            station.imageQuality),
                                     ref.force, "programs." + std::to_string(ref.number) + ".force: true"}};
}

/// The journal's warning for the landmarks a forced program inspects as never ok.
void reportForced(const station::PartProgramRef& ref, const inspect::InspectionSetup& setup)
{
    if (!setup.forced.empty())
        hg::log::category("inspect")->warn("part program {}: forced: {}", ref.number, inspect::describe(setup.forced));
}

/// The program's release as the record names it (docs/commissioning.md, "Release"); none for a draft.
std::optional<station::ProgramRelease> releaseOf(const model::PartProgram& program)
{
    if (!program.release) return std::nullopt;
    return station::ProgramRelease{program.release->version, program.release->verificationSha256};
}

/// "version 3, verification 5f0c1a2b…" or "draft", for the journal.
std::string describeRelease(const model::PartProgram& program)
{
    if (!program.release) return "draft";
    return "version " + std::to_string(program.release->version) + ", verification " +
           program.release->verificationSha256.substr(0, 8) + "…";
}

/// Why `set` does not fit `program` (docs/mastering.md, "In the daemon"): a
/// master measured on another release or for another material corrects a bias
/// that is not this program's; empty when it fits.
std::string correctionMismatch(const inspect::CorrectionSet& set, const model::PartProgram& program)
{
    const std::optional<int> version =
        program.release ? std::optional<int>(program.release->version) : std::optional<int>();
    const auto describe = [](std::optional<int> v) {
        return v ? "version " + std::to_string(*v) : std::string("draft");
    };
    if (set.programVersion != version)
        return "it was mastered on " + describe(set.programVersion) + ", the program is " + describe(version);
    const std::string material = program.material ? program.material->name : std::string();
    if (set.material != material)
        return "it is for material '" + set.material + "', the program's is '" + material + "'";
    return {};
}

struct LoadedProgram {
    std::filesystem::path file;
    /// The file's SHA-256 as the configuration it was loaded for validated it
    /// (PartProgramRef::partSha256): a reload that changed it loads anew.
    std::string configuredSha256;
    model::PartProgram program;
    /// Its map, options, aligner, gauge and seat views (inspect::makeProgramInspector).
    inspect::ProgramInspector inspection;
    /// The planned poses and, per planned view, the bounds of what its
    /// inspection reads: the region the camera sends (empty with
    /// `camera.regions: false`; docs/daemon.md, "Regions per view").
    std::vector<geometry::FixturePose> poses;
    std::vector<cv::Rect> regions;
    /// The correction set file and digest the configuration named
    /// (PartProgramRef::correctionFile), and the set when it fits the program.
    std::filesystem::path correctionFile;
    std::string correctionSha256;
    std::optional<inspect::CorrectionSet> correction;
    /// The capability check at the planned views and the edge σ it predicted
    /// from the station's image quality: what the health's capability figure
    /// scales (docs/health.md, "Capability").
    std::vector<inspect::LandmarkCapability> assessment;
    double plannedSigmaPx = 0.0;
};

/// Reads the correction set the configuration names for `p` and keeps it when
/// it fits the program. One that does not is left out with a journal warning
/// rather than refused: a new release of the program outdates the set without
/// making the configuration wrong, and the line runs on uncorrected (the
/// results say so: no correction id) until the master is measured again.
/// Throws InputError when the file is no longer a correction set.
void applyCorrection(LoadedProgram& p, const station::PartProgramRef& ref)
{
    p.correctionFile = ref.correctionFile;
    p.correctionSha256 = ref.correctionSha256;
    p.correction.reset();
    if (ref.correctionFile.empty()) return;
    inspect::CorrectionSet set = inspect::loadCorrectionSet(ref.correctionFile);
    if (const std::string why = correctionMismatch(set, p.program); !why.empty()) {
        hg::log::category("inspect")->warn("part program {}: correction set {} ({}) not applied: {}; deviations "
                                           "are uncorrected until the master is measured again",
                                           ref.number, set.id, ref.correctionFile.string(), why);
        return;
    }
    hg::log::category("inspect")->info("part program {}: correction set {} applied ({} landmarks)", ref.number, set.id,
                                       set.landmarks.size());
    p.correction = std::move(set);
}

/// A landmark's surface forms the silhouette in a view whose line of sight
/// grazes it: its normal within about 3° of the image plane there.
bool grazes(const geometry::CameraModel& camera, const inspect::MapLandmark& lm)
{
    const geometry::Vec3 sight = camera.lineOfSight(lm.position);
    return std::abs(sight.dot(lm.normal)) < 0.05;
}

/// The landmarks' silhouette edges in a prepared view, where the station's
/// health reads the edge profile (docs/health.md, "In the daemon"): where the
/// CAD outline runs beside each landmark in this camera when the inspection
/// measures deviations (the outline points of docs/inspection.md, "Sub-voxel
/// deviation"), else the landmark itself where the line of sight grazes it;
/// the normal is the image of the landmark's outward normal there, as the
/// sub-voxel step and the archive's marks take it. Projected at the nominal
/// seat: a seated part's edge lies a few pixels along the normal, where the
/// profile read finds it.
std::vector<vision::EdgeProbe> edgeProbes(const inspect::SilhouetteView& view,
                                          const std::vector<inspect::MapLandmark>& landmarks)
{
    std::vector<vision::EdgeProbe> probes;
    for (std::size_t i = 0; i < landmarks.size(); ++i) {
        const auto& lm = landmarks[i];
        geometry::Vec3 at = lm.position;
        if (view.outlines) {
            if (i >= view.outlines->landmarks.size() || !view.outlines->landmarks[i]) continue;
            at = view.outlines->landmarks[i]->graze;
        } else if (!grazes(view.camera, lm)) {
            continue;
        }
        const auto pixel = view.camera.project(at);
        const auto tip = view.camera.project(at + 0.01 * lm.normal);
        if (!pixel || !tip) continue;
        const Eigen::Vector2d direction = *tip - *pixel;
        if (direction.norm() < 1e-6) continue;
        probes.push_back({*pixel, direction.normalized()});
    }
    return probes;
}

/// The bounds of every pixel the inspection reads through `camera`; empty
/// when it reads none (the camera then sends whole frames).
cv::Rect viewBounds(const inspect::Inspector& inspector, const geometry::CameraModel& camera)
{
    return inspector.regions(camera).bounds;
}

class EngineInspector : public Inspector {
  public:
    explicit EngineInspector(const station::DaemonConfig& config)
        : station_(config.station), segmentation_(config.segmentation), regions_(config.cameraRegions)
    {
    }

    Status begin(const station::PartProgramRef& ref) override
    {
        // The worker must be idle, and forget the last program's inspector, before a reload may replace it.
        idle();
        const Result<LoadedProgram*> program = load(ref);
        current_ = program.ok() ? program.value() : nullptr;
        if (!current_) return program.status();
        const inspect::Inspector* inspector = current_->inspection.inspector.get();
        pipeline_.begin([inspector, settings = segmentation_](
                            const inspect::CapturedView& view) { return inspector->prepareView(view, settings); },
                        examination());
        if (health_) health_->beginCycle();
        return Status::success();
    }

    // Between cycles (the runner's thread): the pipeline is idle, so a program
    // loaded anew may replace the one the last cycle used.
    Status prepare(const station::PartProgramRef& ref) override
    {
        if (loadedAsConfigured(ref) && correctedAsConfigured(ref)) return Status::success();
        idle();
        return load(ref).status();
    }

    std::optional<LoadedProgramInfo> loaded(std::uint16_t number) const override
    {
        const auto it = loaded_.find(number);
        if (it == loaded_.end()) return std::nullopt;
        const auto& program = it->second.program;
        return LoadedProgramInfo{number, program.part, releaseOf(program),
                                 program.material ? program.material->name : std::string()};
    }

    // A planned pose's region was found when the program was loaded; a pose
    // corrected for the seat gets the region of the camera it is taken with,
    // the one its inspection reads through (docs/daemon.md, "Regions per view").
    cv::Rect region(std::size_t index, const geometry::FixturePose& pose) override
    {
        if (!regions_ || !current_) return {};
        if (index < current_->poses.size() && current_->poses[index] == pose) return current_->regions[index];
        return viewBounds(*current_->inspection.inspector, station_.cameraAt(pose));
    }

    // Hands the frame to the pipeline's worker and returns: the fixture moves on while it is segmented.
    void addView(std::size_t index, const geometry::FixturePose& pose, cv::Mat image, cv::Point origin) override
    {
        inspect::CapturedView view{"v" + std::to_string(index), station_.cameraAt(pose), std::move(image), origin};
        // Kept (shared pixels) for the archive, with the camera and pose as inspected.
        ViewEvidence kept;
        kept.image = view.frame;
        kept.capture = vision::ManifestView{
            view.id, {}, view.camera, false, vision::ManifestFixturePose{station_.fixture.type, pose}};
        // A region of the sensor: the manifest says where (docs/contracts.md §3).
        if (view.frame.size() != view.camera.imageSize()) kept.capture->origin = origin;
        kept.segmentation = segmentation_;
        kept.calibration = station_.calibration;
        kept.imageQuality = station_.imageQuality;
        views_.push_back(std::move(kept));
        pipeline_.submit(std::move(view));
    }

    void setPartTemperature(std::optional<double> temperatureC, double sigmaC) override
    {
        temperatureC_ = temperatureC;
        temperatureSigmaC_ = sigmaC;
    }

    std::size_t seatViews() const override { return current_ ? current_->inspection.setup.seatViews : 0; }

    // Between cycles: the worker is idle once the last cycle's views are examined.
    void watchHealth(std::unique_ptr<vision::HealthMonitor> monitor) override
    {
        pipeline_.waitExamined();
        health_ = std::move(monitor);
    }

    // On the runner's thread, between a grab and the next move: waits for the
    // first views' preparation (started as each frame came in) and solves.
    std::optional<align::AlignmentResult> provisionalSeat() override
    {
        const std::size_t count = seatViews();
        if (count == 0) return std::nullopt;
        auto views = pipeline_.firstPrepared(count);
        if (!views) return std::nullopt;
        try {
            return current_->inspection.inspector->measureSeat(*views);
        } catch (const std::exception& e) {
            hg::log::category("inspect")->warn("the seat of the first {} views could not be measured: {}", count,
                                               e.what());
            return std::nullopt;
        }
    }

    InspectionOutcome finish() override
    {
        InspectionOutcome out;
        if (!current_) {
            out.error = "no part program loaded";
            return out;
        }
        try {
            auto prepared = pipeline_.wait();
            out.prepareTime = prepared.prepareTime;
            if (!prepared.error.empty()) {
                out.error = prepared.error;
                out.health = healthOfCycle();
                views_.clear();
                return out;
            }
            // Only the traversal is left once the last frame is in (dissertation 3.3.8).
            inspect::DeviationReferral referral;
            referral.correction = current_->correction ? &*current_->correction : nullptr;
            referral.temperatureC = temperatureC_;
            referral.temperatureSigmaC = temperatureSigmaC_;
            auto result = current_->inspection.inspector->inspect(std::move(prepared.views), prepared.ids, referral);
            out.ok = true;
            if (current_->correction) out.correctionId = current_->correction->id;
            out.part = result.part;
            out.release = releaseOf(current_->program);
            out.pass = result.pass;
            out.traversalTime = result.totalTime;
            out.alignment = result.alignment;
            out.seatingFault = result.seatingFault;
            out.processingTime = prepared.prepareTime + result.totalTime;
            for (const auto& l : result.landmarks) {
                station::LandmarkOutcome o{l.id, l.status, l.errorMinMm, l.errorMaxMm, l.errorMm, l.toleranceMm};
                if (l.deviation && l.deviation->measured) {
                    o.deviationMm = l.deviation->deviationMm;
                    o.uncertaintyMm = l.deviation->uncertaintyMm;
                }
                o.decision = l.decision;
                o.limitsMm = l.limitsMm;
                o.referral = l.referral;
                out.landmarks.push_back(std::move(o));
            }
            out.evidence = evidence(result, out.landmarks);
        } catch (const std::exception& e) {
            out.error = e.what();
        } catch (...) {
            out.error = "the inspection failed";
        }
        out.health = healthOfCycle();
        // The silhouettes against the CAD's outline all round, when the seat was measured
        // (docs/health.md, "Edge bias"; docs/alignment.md, "Edge bias").
        if (out.health && out.alignment && out.alignment->measured) out.health->edgeBiasPx = out.alignment->edgeBiasPx;
        // The landmarks' U at the edge σ the frames predict, against their capability bound.
        if (out.health)
            out.health->capability =
                inspect::capabilityUsed(current_->assessment, current_->plannedSigmaPx, out.health->predictedSigmaPx);
        views_.clear();
        return out;
    }

    void cancel() override
    {
        pipeline_.cancel();
        views_.clear();
    }

  private:
    /// The examination of the cycle's views for the station's health (docs/health.md,
    /// "In the daemon"): on the pipeline's worker, after each view is prepared.
    ViewPipeline::ExamineFn examination()
    {
        if (!health_) return nullptr;
        return [monitor = health_.get(), landmarks = &current_->inspection.map->landmarks()](
                   std::size_t index, const inspect::SilhouetteView& view) {
            const vision::EdgeImage image{view.grey, view.threshold, view.objectIsDark, view.origin,
                                          view.camera.imageSize()};
            monitor->addView(index, image, edgeProbes(view, *landmarks));
        };
    }

    /// The cycle's figures once its last view is examined (beside the traversal, so rarely waited for).
    std::optional<vision::HealthFigures> healthOfCycle()
    {
        if (!health_) return std::nullopt;
        pipeline_.waitExamined();
        const vision::HealthFigures figures = health_->endCycle();
        if (figures.views == 0) return std::nullopt;
        return figures;
    }

    void idle()
    {
        pipeline_.begin(nullptr);
        views_.clear();
        current_ = nullptr;
    }

    bool loadedAsConfigured(const station::PartProgramRef& ref) const
    {
        auto it = loaded_.find(ref.number);
        return it != loaded_.end() && it->second.file == ref.partFile && it->second.configuredSha256 == ref.partSha256;
    }

    /// The loaded program holds the correction set the configuration names (a reload may name a new one).
    bool correctedAsConfigured(const station::PartProgramRef& ref) const
    {
        auto it = loaded_.find(ref.number);
        return it != loaded_.end() && it->second.correctionFile == ref.correctionFile &&
               it->second.correctionSha256 == ref.correctionSha256;
    }

    /// The program, loaded unless it is loaded from the same file already (a
    /// reload may point the number at another file, or find a new version in
    /// the same one: rebuilt then); a failure with the reason when it cannot be loaded.
    Result<LoadedProgram*> load(const station::PartProgramRef& ref)
    {
        try {
            if (loadedAsConfigured(ref)) {
                LoadedProgram& loaded = loaded_.at(ref.number);
                if (!correctedAsConfigured(ref)) applyCorrection(loaded, ref);
                return &loaded;
            }
            const Stopwatch watch;
            LoadedProgram p;
            p.file = ref.partFile;
            p.configuredSha256 = ref.partSha256;
            p.program = model::loadPartProgram(ref.partFile);
            // The inspector `hullgauge inspect --part` configures (docs/inspection.md).
            const inspect::InspectionStation station = stationFor(ref, p.program, station_);
            p.assessment = station.capability->assessment;
            p.plannedSigmaPx = vision::edgeSigmaPx(station_.imageQuality.noiseGrey, station_.imageQuality.contrastGrey);
            p.inspection = inspect::makeProgramInspector(p.program, station);
            reportForced(ref, p.inspection.setup);
            // The sub-voxel step's ray casts for the planned views, once (docs/inspection.md).
            const std::vector<geometry::CameraModel> cameras = plannedCameras(ref, station_);
            p.inspection.inspector->prepareOutlines(cameras);
            // The region the camera sends per planned view (docs/daemon.md, "Regions per view").
            p.poses = ref.views;
            for (const geometry::CameraModel& c : cameras)
                p.regions.push_back(regions_ ? viewBounds(*p.inspection.inspector, c) : cv::Rect());
            applyCorrection(p, ref);
            // The version loaded, and the one it replaces (a reload, docs/daemon.md).
            const auto before = loaded_.find(ref.number);
            hg::log::category("inspect")->info(
                "part program {} ({}, {}) loaded in {:.0f} ms{}", ref.number, p.program.part,
                describeRelease(p.program), watch.ms(),
                before == loaded_.end() ? std::string() : "; it replaces " + describeRelease(before->second.program));
            return &loaded_.insert_or_assign(ref.number, std::move(p)).first->second;
        } catch (const std::exception& e) {
            return Status::failure(e.what());
        } catch (...) {
            // Whatever the program's load throws is the program's fault (FAULT 30), never the daemon's end.
            return Status::failure("the part program could not be loaded");
        }
    }

    // The part's archive (docs/daemon.md): frames, cameras, silhouettes, landmark
    // projections and the overlay the HMI draws (docs/hmi.md, "Reject views"). The
    // projections are taken now (they need the program); the whole-frame segmentation
    // and the nominal outline are left to the returned function, which the cycle runs
    // after the result is shown, if it archives the part.
    std::function<std::vector<ViewEvidence>()> evidence(const inspect::InspectionResult& result,
                                                        const std::vector<station::LandmarkOutcome>& outcomes)
    {
        std::map<std::string, const station::LandmarkOutcome*> outcome;
        for (const auto& l : outcomes) outcome[l.id] = &l;
        std::vector<ViewEvidence> views = std::move(views_);
        // The archive's manifest keeps the nominal cameras (`hullgauge inspect` aligns again from
        // them); the landmarks and the outline are drawn where the seated part shows them.
        const bool measured = result.alignment && result.alignment->measured;
        const geometry::RigidTransform seat =
            result.alignment ? result.alignment->seat : geometry::RigidTransform::identity();
        for (auto& e : views) {
            e.seatMeasured = measured;
            const geometry::CameraModel seated = align::seatedCamera(e.capture->camera, seat);
            for (const auto& l : current_->program.landmarks) {
                const auto it = outcome.find(l.id);
                // A landmark the result does not hold (masked) is drawn as not inspected.
                if (auto mark = landmarkMark(l, seated, e.capture->origin.value_or(cv::Point(0, 0)),
                                             it == outcome.end() ? nullptr : it->second))
                    e.landmarks.push_back(std::move(*mark));
            }
        }
        return [views = std::move(views), solid = current_->program.solid, seat]() mutable {
            for (auto& e : views) {
                e.silhouette = vision::segment(e.image, e.segmentation);
                // The frame is the sensor's region at its origin: the outline in its pixels.
                const cv::Rect window(e.capture->origin.value_or(cv::Point(0, 0)), e.image.size());
                if (solid)
                    e.outline =
                        vision::projectedOutline(solid->mesh(), align::seatedCamera(e.capture->camera, seat), {window});
            }
            return views;
        };
    }

    /// Where landmark `l` shows in the archived image of the seated camera (sensor pixels less `origin`)
    /// and which way it measures there: the image direction of its outward normal, taken from the
    /// projection of P + 0.01 mm·n as the sub-voxel deviation takes it (docs/inspection.md, "Sub-voxel
    /// deviation", step 1); nullopt when it lies behind the camera.
    static std::optional<LandmarkMark> landmarkMark(const model::Landmark& l, const geometry::CameraModel& seated,
                                                    cv::Point origin, const station::LandmarkOutcome* outcome)
    {
        const auto px = seated.project(l.position);
        if (!px) return std::nullopt;
        LandmarkMark mark{cv::Point2d(px->x() - origin.x, px->y() - origin.y), l.id,
                          outcome ? outcome->status : inspect::LandmarkStatus::NotInspected};
        if (const auto tip = seated.project(l.position + 0.01 * l.normal)) {
            const cv::Point2d d(tip->x() - px->x(), tip->y() - px->y());
            const double length = std::hypot(d.x, d.y);
            if (length > 1e-6) mark.direction = d / length;
        }
        if (outcome) mark.outcome = *outcome;
        return mark;
    }

    geometry::Station station_;
    vision::SegmentationSettings segmentation_;
    bool regions_ = true; ///< `camera.regions`: the camera sends each view's bounds
    std::map<std::uint16_t, LoadedProgram> loaded_;
    LoadedProgram* current_ = nullptr;
    std::vector<ViewEvidence> views_;
    /// The station's health monitor (watchHealth); null: not watched.
    std::unique_ptr<vision::HealthMonitor> health_;
    /// The part's temperature and its standard uncertainty (°C) the deviations are referred with.
    std::optional<double> temperatureC_;
    double temperatureSigmaC_ = 0.0;
    // Declared last: destroyed first, so its worker has stopped before the programs it prepares with go.
    ViewPipeline pipeline_;
};

} // namespace

std::unique_ptr<Inspector> makeEngineInspector(const station::DaemonConfig& config)
{
    return std::make_unique<EngineInspector>(config);
}

void checkEngineProgram(const station::PartProgramRef& ref, const geometry::Station& station)
{
    const model::PartProgram program = model::loadPartProgram(ref.partFile);
    reportForced(ref, inspect::setUpInspection(program, stationFor(ref, program, station)));
}

} // namespace hg::daemon
