// What turns a landmark's measured sub-voxel deviation into the one the
// station decides on (docs/mastering.md): the deviation referred to 20 °C
// (ISO 1) with the material's expansion coefficient, then the station's
// systematic bias taken out by the correction a master part gave (one-point:
// an offset; two-point: an offset and a gain), its uncertainty added to U by
// root-sum-square. The voxel bracket is never corrected: it stays a bound on
// the raw geometry (docs/contracts.md §4).
//
// Pure computation on values; the correction set's file is read and written
// at the edge of the module (loadCorrectionSet, saveCorrectionSet).
#pragma once

#include "hullgauge/common/enum_names.h"
#include "hullgauge/geometry/transform.h"

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

namespace hg::inspect {

/// One master part's share of a landmark's correction (docs/mastering.md):
/// its certified deviation (the CMM's value and expanded U, k = 2) and the
/// mean of the station's uncorrected readings over the master cycles with the
/// standard uncertainty of that mean (s / √n).
struct MasterPoint {
    std::string master; ///< the master's serial
    double certifiedMm = 0.0;
    double certifiedUMm = 0.0; ///< expanded, k = 2
    double measuredMm = 0.0;   ///< mean of the n readings, referred to 20 °C
    double spreadMm = 0.0;     ///< s of the n readings
    int cycles = 0;            ///< n
    /// The standard uncertainty of the reading's mean, s / √n.
    double meanSigmaMm() const;
};

/// The correction of one landmark: one point (an offset) or two (an offset
/// and a gain through both masters' points).
struct LandmarkCorrection {
    std::string id;
    std::vector<MasterPoint> points; ///< 1 or 2

    /// The gain g (1 for one point) and offset a of corrected = a + g·reading.
    double gain() const;
    double offsetMm() const;
    /// The corrected value of an uncorrected reading.
    double correct(double readingMm) const;
    /// The expanded uncertainty (k = 2) the correction adds at `readingMm`
    /// (docs/mastering.md, "Uncertainty"); the reading's own U scales by the gain.
    double uncertaintyAt(double readingMm) const;
};

enum class MasteringMethod { OnePoint, TwoPoint };
constexpr auto nameTable(MasteringMethod)
{
    using enum MasteringMethod;
    return std::to_array<EnumName<MasteringMethod>>({{OnePoint, "one_point"}, {TwoPoint, "two_point"}});
}

/// A program's correction set, as `hullgauge master` writes it and the daemon
/// applies it (docs/mastering.md, "The correction set").
struct CorrectionSet {
    std::string id; ///< unique: program, version, material and time, e.g. "p1-v3-steel-20260412T081500Z"
    int program = 0;
    std::optional<int> programVersion; ///< the release it was mastered on; none for a draft
    std::string material;              ///< the program's material name, when it names one
    std::int64_t createdUnixMs = 0;
    /// The mean temperature of the master cycles (°C) when they recorded one.
    std::optional<double> temperatureC;
    std::vector<LandmarkCorrection> landmarks;

    MasteringMethod method() const;
    const LandmarkCorrection* find(const std::string& landmarkId) const;
};

nlohmann::json toJson(const CorrectionSet& set);
/// Throws InputError naming `name` and the field when the JSON is not a correction set.
CorrectionSet correctionSetFromJson(const nlohmann::json& j, const std::string& name);
/// The file a correction set is kept in; durable (written, synced, then renamed into place).
void saveCorrectionSet(const CorrectionSet& set, const std::filesystem::path& file);
CorrectionSet loadCorrectionSet(const std::filesystem::path& file);

/// The part's thermal expansion at a landmark (docs/mastering.md, "Temperature"):
/// the change of the surface's position along its outward normal between
/// 20 °C and `temperatureC`, α·(T − 20 °C)·((p − c)·n) for a part that grows
/// about `centre` (mm).
double thermalOffsetMm(double expansionPerK, double temperatureC, const geometry::Vec3& position,
                       const geometry::Vec3& normal, const geometry::Vec3& centre);

/// How a measured deviation is referred and corrected in one inspection.
struct DeviationReferral {
    const CorrectionSet* correction = nullptr;
    std::optional<double> temperatureC; ///< the part's temperature at the trigger
    double temperatureSigmaC = 0.0;     ///< the reading's standard uncertainty (°C)
};

/// What was done to a landmark's measured deviation (the result records both
/// numbers and the correction, docs/mastering.md "In the result").
struct AppliedReferral {
    double rawDeviationMm = 0.0;       ///< as measured, at the part's temperature
    double rawUncertaintyMm = 0.0;     ///< its expanded U
    double thermalMm = 0.0;            ///< the expansion taken out (0 without a temperature)
    double thermalUncertaintyMm = 0.0; ///< expanded, k = 2: the temperature reading's share
    std::string correctionId;          ///< empty: no correction for this landmark
    double correctionOffsetMm = 0.0;
    double correctionGain = 1.0;
    double correctionUncertaintyMm = 0.0; ///< expanded, k = 2, at this reading
};

/// The referral's fields of a landmark's JSON (docs/contracts.md §4, docs/mastering.md
/// "In the result"): `raw_deviation_mm`, `raw_uncertainty_mm`, `thermal_mm` and
/// `correction` {id, offset_mm, gain, uncertainty_mm} (null without a correction).
void addReferral(nlohmann::json& landmark, const AppliedReferral& referral);
/// The referral a landmark's JSON holds; nullopt without `raw_deviation_mm`.
/// Throws InputError naming `name` when a field has the wrong type.
std::optional<AppliedReferral> referralOf(const nlohmann::json& landmark, const std::string& name);

} // namespace hg::inspect
