// hullgauged: the station daemon (docs/daemon.md): the drivers chosen by the
// station file and the core's goal-driven inspection.
#include "cycle/driver_devices.h"
#include "cycle/engine_inspector.h"
#include "daemon.h"

#include <malloc.h>

int main(int argc, char** argv)
{
    // Memory stays bounded (docs/daemon.md, "Memory"): a block of 1 MiB or
    // more — a whole frame, the simulated camera's rendering — is mapped on
    // its own and given back when freed. glibc would otherwise raise this
    // threshold to the largest block freed so far, and the next frames of
    // that size would come from the heap, whose high-water mark stays.
    mallopt(M_MMAP_THRESHOLD, 1 << 20);
    return hg::daemon::runDaemon(argc, argv, hg::daemon::makeDriverDevices, hg::daemon::makeEngineInspector,
                                 hg::daemon::checkEngineProgram);
}
