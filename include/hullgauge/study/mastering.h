// Mastering (docs/mastering.md): a master part's certificate, and the
// correction set computed from the station's readings of one master
// (one-point: an offset per landmark) or two (two-point: offset and gain).
// Computation on values, like the studies; the certificate is read at the
// edge (loadMasterCertificate).
#pragma once

#include "hullgauge/inspect/correction.h"
#include "hullgauge/study/gauge_study.h"

#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace hg::study {

/// One landmark's certified deviation: the CMM's value (outward positive,
/// mm, as the station measures it) and its expanded uncertainty U (k = 2).
struct CertifiedValue {
    double valueMm = 0.0;
    double uncertaintyMm = 0.0;
    int line = 0; ///< where the certificate gives it (for messages)
};

/// A master part's certificate (docs/mastering.md, "The certificate").
struct MasterCertificate {
    std::filesystem::path file;
    std::string serial;      ///< `master`: the serial its cycles carry
    std::string certificate; ///< `certificate`: the CMM report's reference, free text
    std::map<std::string, CertifiedValue> landmarks;
};

/// Reads and validates a certificate strictly; InputError naming file, key and line.
MasterCertificate loadMasterCertificate(const std::filesystem::path& file);
/// The same from the certificate's text (the daemon's mastering run is sent it,
/// docs/mastering.md "The mastering run"); `name` stands for the file in messages.
MasterCertificate parseMasterCertificate(const std::string& text, const std::string& name);

/// The study records with each landmark's `deviation_mm` replaced by the
/// uncorrected reading referred to 20 °C (raw − thermal, docs/mastering.md):
/// what a master is measured by, whatever correction the cycles were given.
std::vector<StudyRecord> uncorrectedRecords(std::vector<StudyRecord> records);

/// What the correction set is for.
struct MasteringTarget {
    int program = 0;
    std::optional<int> programVersion;
    std::string material;
    std::int64_t createdUnixMs = 0;
    std::string createdUtc; ///< "20260412T081500Z", for the id
    std::optional<double> temperatureC;
};

/// The correction set from each master's certificate and its cycles
/// (uncorrected records, one list per master, in the certificates' order):
/// one master gives one point per landmark, two masters two. Every landmark
/// of the certificates must be read by every cycle with a deviation (else
/// InputError naming the master's file, the landmark and the line); two
/// masters must certify the same landmarks and differ at each by more than
/// their U (else InputError: no gain can be told).
inspect::CorrectionSet computeCorrections(const std::vector<MasterCertificate>& masters,
                                          const std::vector<std::vector<StudyRecord>>& cycles,
                                          const MasteringTarget& target);

} // namespace hg::study
