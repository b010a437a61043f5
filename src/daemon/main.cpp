// hullgauged: the station daemon (docs/daemon.md): the drivers chosen by the
// station file and the core's goal-driven inspection.
#include "daemon.h"
#include "driver_devices.h"
#include "engine_inspector.h"

int main(int argc, char** argv)
{
    return hg::daemon::runDaemon(argc, argv, hg::daemon::makeDriverDevices, hg::daemon::makeEngineInspector,
                                 hg::daemon::checkEngineProgram);
}
