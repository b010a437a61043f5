#!/usr/bin/env bash
# The package as a line PC gets it (docs/daemon.md, "Installing the package"):
# `apt-get install ./hullgauge_*.deb` into a throwaway root, then the installed
# simulated line started from the installed files only and used as a plant
# would use it.
#
# The throwaway root is container-like: an overlay whose lower layer is this
# machine's root (read-only) and whose upper layer is a tmpfs, in private mount,
# PID and network namespaces (its own loopback, so port 502 and 8080 are its
# own). apt and dpkg in it are Debian's own: they resolve the package's
# Depends against the dpkg database, unpack, register the conffiles and run the
# maintainer scripts. Then, as the unit's user would:
#   - hullgauged --check on the installed /etc/hullgauge/hullgauged.yaml;
#   - hullgauged started as root without systemd, `--foreground`
#     (docs/daemon.md, "Without systemd"): it makes /run/hullgauge and
#     /var/lib/hullgauge (hullgauge:hullgauge 0750), runs as user hullgauge in
#     video and dialout with CAP_NET_BIND_SERVICE alone and no new privileges
#     (read from /proc), logs to stderr, is ready on its maintenance socket
#     (hullgauge ctl status);
#   - the packaged example PLC client (python3-pymodbus) runs cycles on port 502,
#     nominal and defective parts: every verdict right and consistent;
#   - the web HMI answers on 127.0.0.1:8080 from the installed assets and
#     Debian's Chart.js; the result store holds every cycle;
#   - SIGTERM stops it cleanly; `apt-get purge` removes the programs, the
#     conffiles, the HMI's password hash, /etc/hullgauge and /run/hullgauge and
#     keeps the result store (its 4 cycles) and the user hullgauge; installed
#     again the user keeps its uid and the store; purged with
#     HULLGAUGE_PURGE_RESULTS=yes the store, the user and the group go.
#
#   install_package.sh BUILD_DIR
# Exit 0 when every check passed, 1 on a failure, 77 (skipped) when not run as
# root (namespaces and overlay mounts need it).
set -euo pipefail
build=${1:?usage: install_package.sh BUILD_DIR}
build=$(cd "$build" && pwd)
here=$(cd "$(dirname "$0")" && pwd)

if [[ $(id -u) -ne 0 ]]; then
  echo "install_package: needs root for the throwaway root's namespaces and overlay: skipped"
  exit 77
fi

scratch=$(mktemp -d "${TMPDIR:-/tmp}/hg-install.XXXXXX")
trap 'rm -rf "$scratch"' EXIT
if ! cpack --config "$build/CPackConfig.cmake" -G DEB -B "$scratch/out" >"$scratch/cpack.log" 2>&1; then
  cat "$scratch/cpack.log" >&2
  echo "FAILED: cpack -G DEB" >&2
  exit 1
fi
debs=("$scratch"/out/*.deb)
[[ ${#debs[@]} -eq 1 && -f "${debs[0]}" ]] || { echo "FAILED: expected one .deb in $scratch/out" >&2; exit 1; }

# Everything below runs in the new namespaces; their mounts vanish with them.
unshare --mount --pid --net --fork --kill-child "$here/install_package_root.sh" "$scratch" "${debs[0]}"
