// The daemon's configuration (hullgauged.yaml): which station, which part
// programs by number, the PLC server, the result store, image retention, the
// sequencer's timeouts, the maintenance socket and the watchdog. Every key is
// listed with type, unit and default in docs/daemon.md.
//
// loadDaemonConfig validates everything it can without hardware, at start and
// on SIGHUP: the station file loads, every part program and view plan exists
// and the view plans load against the station's fixture, addresses parse,
// ranges hold. Errors throw hg::InputError naming file, line and key; on
// reload the daemon keeps the configuration it runs with.
#pragma once

#include "hullgauge/common/enum_names.h"
#include "hullgauge/geometry/fixture.h"
#include "hullgauge/geometry/station.h"
#include "hullgauge/station/mastering_due.h"
#include "hullgauge/vision/health.h"
#include "hullgauge/vision/segmentation.h"
#include "plant/mqtt_config.h"
#include "shifts.h"

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace hg::station {

/// An IPv4 network (address/prefix); a plain address is a /32.
struct Ipv4Network {
    std::uint32_t address = 0; ///< host byte order
    int prefix = 32;
    bool contains(std::uint32_t hostOrderAddress) const;
};
/// Parses "192.168.0.10" or "10.1.0.0/16"; std::nullopt when malformed.
std::optional<Ipv4Network> parseIpv4Network(const std::string& text);

struct PartProgramRef {
    std::uint16_t number = 0;
    std::filesystem::path partFile;           ///< part program YAML (docs/contracts.md §1), absolute
    std::filesystem::path viewsFile;          ///< view plan: a poses file (docs/contracts.md §5), absolute
    std::vector<geometry::FixturePose> views; ///< loaded and range-checked
    /// SHA-256 of the part program file as this configuration validated it: a
    /// reload that finds the file changed (a new release written over the old,
    /// docs/commissioning.md) loads the program anew; one that refuses it keeps
    /// the configuration, and so the program, it had (docs/daemon.md).
    std::string partSha256;
    /// A released part of the workbench's workspace (docs/workbench.md,
    /// "Released parts on the station"): its name; empty for a program of the
    /// `programs:` table.
    std::string workbenchPart;
    /// The CAD model a workbench part's program names: what the simulated
    /// camera renders as its nominal part (docs/workbench.md).
    std::filesystem::path simulatedNominal;
    /// The master's correction set in force for this program
    /// (`<mastering.folder>/program-<N>.json`, docs/mastering.md "In the
    /// daemon"), absolute; empty: none. Checked to be a correction set of this
    /// program; whether it fits the program's version and material is decided
    /// where the program is loaded (the engine inspector).
    std::filesystem::path correctionFile;
    /// Its SHA-256 as this configuration read it: a reload that finds a new set
    /// (a new mastering) applies it from the next cycle.
    std::string correctionSha256;
    /// The set's identity, computed time and release as read with it: what
    /// re-mastering due judges it by (docs/mastering.md, "Re-mastering due").
    std::string correctionId;
    std::int64_t correctionCreatedUnixMs = 0;
    std::optional<int> correctionProgramVersion;
    /// The mean temperature of its master cycles (°C), when they recorded one.
    std::optional<double> correctionTemperatureC;
    /// Run the program although the capability check finds a tolerance this
    /// station cannot prove (those landmarks are then never ok; docs/inspection.md, "Capability").
    bool force = false;
};

struct PlcConfig {
    std::string bindAddress = "0.0.0.0";
    int port = 502;
    int unitId = 1;
    /// Empty = any client may connect.
    std::vector<Ipv4Network> allowedClients;
    int maxClients = 8;
    /// A request whose bytes straggle longer than this is dropped (its client closed).
    std::chrono::milliseconds frameTimeout{500};
    /// A connection without a complete request for this long is closed.
    std::chrono::milliseconds idleTimeout{60'000};
    /// When every slot is taken, the connection silent the longest yields to a
    /// new one if it has been silent this long (a polling PLC never is).
    std::chrono::milliseconds yieldAfter{5'000};
    std::chrono::milliseconds heartbeatPeriod{500};
};

struct RetentionConfig {
    std::size_t maxCount = 2000; ///< archived part folders kept
    /// The folders of the newest this many failed parts are never removed by
    /// count, age or bytes (the evidence of a reject outlives the audit trail).
    std::size_t keepFailed = 50;
    std::chrono::hours maxAge{24 * 30};  ///< older image sets are removed
    std::uint64_t maxBytes = 2ull << 30; ///< total size of the archive folder
    /// Free space the archive leaves on its volume (the result store's too when it shares it):
    /// the oldest folders give way, failed ones too, and a part's images are not kept while
    /// less is free, so the verdict and its record always find room (docs/daemon.md).
    std::uint64_t minFreeBytes = 1ull << 30;
};

struct ResultsConfig {
    std::filesystem::path database;
    std::filesystem::path imageDir;
    bool saveFailedImages = true;
    /// Archive every part, passed or failed, as a re-inspectable capture (audits).
    bool archiveAll = false;
    /// The audit trail (docs/audit.md); empty: `audit.sqlite` beside the database (auditFile).
    std::filesystem::path audit;
    RetentionConfig retention;
};

struct SequencerConfig {
    std::chrono::milliseconds moveTimeout{10000};
    std::chrono::milliseconds grabTimeout{2000};
    std::chrono::milliseconds settle{50};
    int retries = 1;
    /// SIGTERM during a cycle: wait this long for it to finish before aborting it.
    std::chrono::milliseconds shutdownGrace{2000};
};

struct MaintenanceConfig {
    std::filesystem::path socket = "/run/hullgauge/hullgauged.sock";
    /// Group owning the socket (mode 0660); empty = the daemon's own group.
    std::string group;
};

/// The web HMI (docs/hmi.md): read-only pages and the JSON API for everyone
/// who can reach the address; maintenance actions for a signed-in engineer.
struct HmiConfig {
    bool enabled = false; ///< the `http` section is present
    std::string bindAddress = "127.0.0.1";
    int port = 8080; ///< 0: a free port the kernel chooses (announced in the log and `ctl status`)
    std::filesystem::path assets = "/usr/share/hullgauge/hmi";
    /// Debian's JavaScript libraries (libjs-chart.js installs chart.js/ there).
    std::filesystem::path javascript = "/usr/share/javascript";
    /// crypt(3) hash of the maintenance password (yescrypt `$y$`, SHA-512 `$6$`);
    /// empty: no maintenance actions over HTTP.
    std::string passwordHash;
    /// The accounts with their roles (docs/audit.md, "Roles"); empty: `users.yaml` beside the result store (usersFile).
    std::filesystem::path usersFile;
    std::size_t maxRequestBytes = 64 * 1024;
    double requestsPerSecond = 50.0; ///< per client address, sustained
    int burst = 200;                 ///< per client address, at once
    int threads = 4;
    std::chrono::seconds sessionIdle{1800};
    /// Host names a request may give in Host and Origin (docs/hmi.md, "Bounded"),
    /// lower-case; empty in the file: the bind address, localhost and, bound to
    /// 0.0.0.0, the PC's host name and its interfaces' addresses (allowedHostsFor).
    std::vector<std::string> allowedHosts;
    std::chrono::milliseconds requestTimeout{5000}; ///< the whole request, head and body
    std::size_t maxPendingRequests = 64;            ///< requests being received at once
};

struct DaemonConfig;
/// `results.audit`, or `audit.sqlite` beside the result store when not given (docs/audit.md).
std::filesystem::path auditFile(const DaemonConfig& config);
/// `http.users_file`, or `users.yaml` beside the result store when not given (docs/audit.md, "Roles").
std::filesystem::path usersFile(const DaemonConfig& config);
/// `http.allowed_hosts` as given, or its default for `bindAddress`.
std::vector<std::string> allowedHostsFor(const HmiConfig& http);

/// The part workbench (docs/workbench.md, "Configuration").
struct WorkbenchConfig {
    std::filesystem::path folder;                     ///< the workspace; empty: no workbench
    std::filesystem::path cli = "/usr/bin/hullgauge"; ///< the command its jobs run
    std::size_t maxUploadBytes = 64u << 20;
    int maxJobs = 1;
    bool enabled() const { return !folder.empty(); }
};

/// Mastering (docs/mastering.md, "In the daemon").
struct MasteringConfig {
    /// The folder of the correction sets, one per program (`program-<N>.json`); empty: none applied.
    std::filesystem::path folder;
    /// `mastering.due` (docs/mastering.md, "Re-mastering due"); absent: never due, nothing signalled.
    std::optional<MasteringDuePolicy> due;
};

/// Station health (docs/health.md, "In the daemon"): every cycle's frames
/// examined against the flat-field reference and the limits.
struct HealthConfig {
    bool enabled = true;
    /// The flat-field reference (`health.reference`, default `flat-field.json`
    /// beside the station file), absolute: read here when it exists, written by
    /// the maintenance action `flat-field`.
    std::filesystem::path reference;
    vision::HealthLimits limits;
    /// The reference as this configuration read it (absent: no file there yet)
    /// and the file's SHA-256: a reload that finds another file uses it from the
    /// next cycle, one that finds the same keeps the reference in use.
    std::optional<vision::FlatField> referenceRead;
    std::string referenceSha256;
};

/// Where the part's temperature comes from (docs/mastering.md, "Temperature").
enum class TemperatureSource { Plc, File };
constexpr auto nameTable(TemperatureSource)
{
    using enum TemperatureSource;
    return std::to_array<EnumName<TemperatureSource>>({{Plc, "plc"}, {File, "file"}});
}

/// `temperature`: the part's temperature read at every trigger, recorded with
/// the result and the deviations referred to 20 °C with it (docs/mastering.md,
/// "Temperature"). Its `mastering_step_c` is MasteringDuePolicy::maxTemperatureStepC.
struct TemperatureConfig {
    TemperatureSource source = TemperatureSource::Plc;
    /// File: the sensor file, one number; times `scale` it is °C (0.001: millidegrees).
    std::filesystem::path file;
    double scale = 1.0;
    /// File: a file last written longer ago than this is stale (no reading); none: never stale.
    std::optional<std::chrono::milliseconds> maxAge;
    double sigmaC = 0.5; ///< the reading's standard uncertainty (°C)
};

struct WatchdogConfig {
    /// The daemon stops pinging the systemd watchdog when a cycle runs longer
    /// than this (the sequencer is stuck) or the PLC server loop stalls.
    std::chrono::milliseconds maxCycle{60000};
};

struct DaemonConfig {
    std::filesystem::path file; ///< the configuration file itself
    std::filesystem::path stationFile;
    geometry::Station station;
    /// The station file's `segmentation` section (vision::stationSegmentation).
    vision::SegmentationSettings segmentation;
    /// Name of the station section that lists the operator lamps (default "lamps").
    std::string lampsSection = "lamps";
    /// The station file's `camera.regions` (default true): per view the camera
    /// sends only the bounds of what its inspection reads (docs/daemon.md,
    /// "Regions per view"); false: whole frames.
    bool cameraRegions = true;
    std::map<std::uint16_t, PartProgramRef> programs;
    PlcConfig plc;
    ResultsConfig results;
    SequencerConfig sequencer;
    MaintenanceConfig maintenance;
    HmiConfig http;
    WorkbenchConfig workbench;
    /// The plant link (docs/mqtt.md): results, state and counters published to a broker.
    MqttConfig mqtt;
    WatchdogConfig watchdog;
    MasteringConfig mastering;
    HealthConfig health;
    /// The part's temperature input; absent: none (results without a temperature, nothing referred).
    std::optional<TemperatureConfig> temperature;
    /// The station's shifts in the order of the day (docs/daemon.md, `shifts`): the line view's shift counters.
    std::vector<Shift> shifts = defaultShifts();
    /// Simulated line only (`camera.driver.backend: sim`): the parts the
    /// simulated camera can render, by name ("nominal" first, then defect
    /// variants), as mesh files. Empty on real hardware.
    std::vector<std::pair<std::string, std::filesystem::path>> simulatedParts;
    /// Simulated line only: `simulation.seating`, the play within which every
    /// new part is seated at random (docs/daemon.md, "Seating"); absent: every
    /// part is seated exactly as drawn.
    struct Seating {
        double shiftMm = 0.0;     ///< largest shift of the part's bounding-box centre
        double rotationDeg = 0.0; ///< largest rotation angle about it
        std::uint64_t seed = 1;   ///< the draws repeat from run to run
    };
    std::optional<Seating> simulatedSeating;
};

/// What loading a configuration does with the workbench's workspace.
enum class WorkspaceUse {
    Open,    ///< created when missing, its released parts added to the programs
    LeaveBe, ///< neither created nor read: the foreground mode's first reading as root
             ///< (docs/daemon.md, "Without systemd") must not make the state folder root's
};

/// Loads and validates a daemon configuration. Relative paths are relative to
/// the configuration file. Throws hg::InputError (file:line: key: problem).
DaemonConfig loadDaemonConfig(const std::filesystem::path& file, WorkspaceUse workspace = WorkspaceUse::Open);

} // namespace hg::station

/// A network as "192.168.10.0/24" (a plain address as "10.1.0.7/32"): fmt::format("{}", network).
template <> struct fmt::formatter<hg::station::Ipv4Network> : hg::ValueFormatter {
    fmt::format_context::iterator format(const hg::station::Ipv4Network& network, fmt::format_context& ctx) const;
};
