// The draft part program as the workbench reads and edits it: its YAML
// document (every key of a part program kept as written), the landmarks as
// written, and as loaded (the landmark cache). Internal to the workbench.
#pragma once

#include "hullgauge/workbench/workspace.h"

#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <optional>
#include <string>

namespace hg::model {
struct PartProgram;
}

namespace hg::workbench::draft {

/// A number as the draft writes it: 12 significant digits, so a value read
/// back is the value written (yaml-cpp would write 0.1 as 0.10000000000000001).
YAML::Node number(double v);
/// [x, y, z] in flow style, each rounded to 10⁻⁶ mm.
YAML::Node vector3(const Eigen::Vector3d& v);

/// The draft's octree and landmarks as written (positions as written, normals
/// only where given, `on` unknown: Face).
Draft parse(const YAML::Node& node, const fs::path& file, double defaultToleranceMm);

/// The landmark cache of a loaded draft: per landmark its position, normal
/// and where it lies, keyed by the draft's digest.
nlohmann::json cacheOf(const model::PartProgram& program, const std::string& draftSha256);
/// Fills the draft's landmarks from the cache when it is of this draft (its
/// digest); false when it is not.
bool applyCache(Draft& draft, const nlohmann::json& cache, const std::string& draftSha256);

/// The landmark entry of `id` in the draft's `landmarks`, or an invalid node.
std::optional<std::size_t> indexOf(const YAML::Node& landmarks, const std::string& id);

/// `L<n>`, the lowest n not taken.
std::string freshId(const YAML::Node& landmarks);

} // namespace hg::workbench::draft
