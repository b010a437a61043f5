// The part record as a PDF (docs/hmi.md, "Part record"): one inspected part
// on A4 portrait pages for an audit — the station, serial, part, program and
// the release it was judged with, the time, the verdict, fault code and cycle
// time, the measured seat, every landmark (status in words, deviation with
// its U, the tolerance zone, the decision; the voxel bracket where no
// deviation was measured) and the annotated views, one whole view per page
// place. Drawn with cairo's PDF surface, text in DejaVu Sans (embedded as a
// subset); the station, serial and time repeated at the top of every page.
//
// Formatting on values only, no HTTP and no files: the caller reads the row
// (store::ResultReader::byId, the shape GET /api/results/{id} answers —
// docs/daemon.md "Results") and the views' PNG bytes; the web HMI sends the
// bytes as a download, `hullgauge record` writes them to a file (docs/cli.md).
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <ostream>
#include <string>
#include <string_view>
#include <vector>

namespace hg::report {

/// One annotated view of the part: its file name (view_<k>.png) and its PNG bytes.
struct RecordView {
    std::string name;
    std::vector<unsigned char> png;
};

struct RecordOptions {
    /// The station's name in every page's running header (empty: left out).
    std::string station;
    /// When the record was made (Unix ms, UTC), in every page's footer; none: left out.
    std::optional<std::int64_t> generatedUnixMs;
};

/// Writes the record of `row` with its `views` (in their order) as PDF to `out`.
///
/// The row needs id, time, serial, program, part, verdict and landmarks (each
/// with id, status and a tolerance zone: limits_mm or tolerance_mm); the other
/// fields of a stored row are shown when present. A missing or mistyped field
/// is hg::InputError naming it ("landmarks[1].status"), a view that is not a
/// PNG is hg::InputError naming the view; both before a byte is written.
/// hg::FaultError when cairo fails or `out` refuses the bytes.
void writeRecordPdf(std::ostream& out, const nlohmann::json& row, const std::vector<RecordView>& views,
                    const RecordOptions& options = {});

/// The download's file name: hullgauge-record-<id>-<serial>.pdf, the serial's
/// characters other than A-Z a-z 0-9 - as _ (as the image archive names folders).
std::string recordFileName(const nlohmann::json& row);

/// A landmark status in plain words ("out_of_tolerance" → "out of tolerance");
/// the same words as the Record page (share/hmi/record.js).
std::string statusWords(std::string_view status);
/// An ISO 14253-1 decision in plain words ("nonconforms" → "does not conform").
std::string decisionWords(std::string_view decision);

} // namespace hg::report
