// The inspection pipeline of the installed daemon over the core's goal-driven
// inspection (include/hullgauge/inspect): the part program and its octree
// inspection map are loaded once per program and kept; each grabbed view goes
// with its posed camera to the ViewPipeline's worker (view_pipeline.h), which
// segments its regions of interest while the fixture moves to the next view;
// finish() waits for the worker and runs only the traversal. The map and the
// options are those `hullgauge inspect --part` takes from the part program, the
// segmentation the station file's (DaemonConfig::segmentation); the frames are
// kept, with the cameras as inspected, for the part's archive (docs/daemon.md).
#pragma once

#include "cycle/inspector.h"
#include "daemon_config.h"

#include <memory>

namespace hg::daemon {

std::unique_ptr<Inspector> makeEngineInspector(const station::DaemonConfig& config);
/// The part program and the inspection options begin() loads (mesh, landmarks,
/// parameters) and its capability at the station; throws InputError naming
/// the file and field, or the landmarks the station cannot prove.
void checkEngineProgram(const station::PartProgramRef& ref, const geometry::Station& station);

} // namespace hg::daemon
