#!/usr/bin/env bash
# The Debian package (docs/daemon.md, systemd): `cpack -G DEB` on the build tree into
# a scratch folder, then, with Debian's own tools only:
#   - dpkg-deb -c: the daemon, the CLI, the unit, the sysusers file, the man
#     pages, the configuration under /etc/hullgauge, the hardware template,
#     the HMI's pages and every page of docs/ with its pictures;
#   - dpkg-deb -I: Depends lists the shared libraries the programs link
#     (dpkg-shlibdeps, CPACK_DEBIAN_PACKAGE_SHLIBDEPS), systemd and Chart.js;
#     every file under /etc is a conffile; the maintainer scripts are there
#     and parse;
#   - dpkg -x into a throwaway root: systemd-analyze verify --root on the
#     installed unit (ExecStart resolves inside the root), and the sysusers
#     file applied to that root creates the user and group hullgauge.
#
#   check_package.sh BUILD_DIR
set -euo pipefail
build=${1:?usage: check_package.sh BUILD_DIR}
scratch=$(mktemp -d "${TMPDIR:-/tmp}/hg-package.XXXXXX")
trap 'rm -rf "$scratch"' EXIT
fail=0
check() { # message command...
  local message=$1
  shift
  if ! "$@"; then
    echo "FAILED: $message" >&2
    fail=1
  fi
}

if ! cpack --config "$build/CPackConfig.cmake" -G DEB -B "$scratch/out" >"$scratch/cpack.log" 2>&1; then
  cat "$scratch/cpack.log" >&2
  echo "FAILED: cpack -G DEB" >&2
  exit 1
fi
debs=("$scratch"/out/*.deb)
[[ ${#debs[@]} -eq 1 && -f "${debs[0]}" ]] || { echo "FAILED: expected one .deb in $scratch/out" >&2; exit 1; }
deb=${debs[0]}
echo "package: $(basename "$deb"), $(du -k "$deb" | cut -f1) KiB"

dpkg-deb -c "$deb" | awk '{print $NF}' >"$scratch/files"
for f in ./usr/sbin/hullgauged ./usr/bin/hullgauge ./usr/lib/systemd/system/hullgauged.service \
  ./usr/lib/sysusers.d/hullgauge.conf ./usr/share/man/man8/hullgauged.8.gz ./usr/share/man/man1/hullgauge.1.gz \
  ./etc/hullgauge/hullgauged.yaml ./etc/hullgauge/station.yaml ./etc/hullgauge/programs/stepped-block.yaml \
  ./etc/hullgauge/programs/stepped-block-views.yaml ./etc/hullgauge/programs/stepped-block.stl \
  ./usr/share/doc/hullgauge/examples/hardware/hullgauged.yaml ./usr/share/doc/hullgauge/examples/hardware/station.yaml \
  ./usr/share/hullgauge/hmi/line.html; do
  check "$f is not in the package" grep -qxF "$f" "$scratch/files"
done
# Every page of docs/ (the source tree's, beside this script) and its pictures.
source_dir=$(cd "$(dirname "$0")/../.." && pwd)
for page in "$source_dir"/docs/*.md "$source_dir"/docs/images/*.png; do
  f=./usr/share/doc/hullgauge/${page#"$source_dir"/docs/}
  check "$f is not in the package" grep -qxF "$f" "$scratch/files"
done

dpkg-deb -I "$deb" >"$scratch/info"
depends=$(dpkg-deb -f "$deb" Depends)
echo "Depends: $depends"
# The libraries the daemon links, as dpkg-shlibdeps names their packages.
for lib in libmodbus5 libsqlite3-0 libsystemd0 libyaml-cpp0.7 libcairo2 libstdc++6 libc6 systemd libjs-chart.js libjs-three \
           fonts-dejavu-core; do
  check "Depends lacks $lib" grep -qE "(^|, )${lib//+/\\+}( |,|$)" <<<"$depends"
done
# Every file under /etc is a conffile: dpkg keeps the engineer's edits.
dpkg-deb -e "$deb" "$scratch/control"
for f in $(grep '^\./etc/.*[^/]$' "$scratch/files" | sed 's/^\.//'); do
  check "$f is not listed in conffiles" grep -qxF "$f" "$scratch/control/conffiles"
done
for script in postinst prerm; do
  check "maintainer script $script missing" grep -qE "^ +[0-9]+ bytes, +[0-9]+ lines +\* +$script " "$scratch/info"
done
for script in postinst prerm; do
  check "$script does not parse" sh -n "$scratch/control/$script"
  check "$script is not executable" test -x "$scratch/control/$script"
done

# The throwaway root: Debian's merged /usr, the host's systemd units (the targets
# the unit is ordered against) and kill (ExecReload), then the package.
root=$scratch/root
mkdir -p "$root/etc" "$root/usr/bin" "$root/usr/lib/systemd"
ln -s usr/bin "$root/bin"
ln -s usr/sbin "$root/sbin"
ln -s usr/lib "$root/lib"
cp -a /usr/lib/systemd/system "$root/usr/lib/systemd/"
cp /usr/bin/kill "$root/usr/bin/kill"
dpkg -x "$deb" "$root"
unit=$root/usr/lib/systemd/system/hullgauged.service
check "the unit's ExecStart is not the packaged daemon" grep -qx 'ExecStart=/usr/sbin/hullgauged --config /etc/hullgauge/hullgauged.yaml' "$unit"
check "the packaged daemon does not run" "$root/usr/sbin/hullgauged" --help >/dev/null
if ! systemd-analyze verify --man=no --root="$root" hullgauged.service >"$scratch/verify.log" 2>&1; then
  cat "$scratch/verify.log" >&2
  echo "FAILED: systemd-analyze verify on the installed unit" >&2
  fail=1
fi
# What the postinst does on a target (systemd-sysusers hullgauge.conf), applied to the throwaway root.
check "systemd-sysusers on the packaged file" systemd-sysusers --root="$root" hullgauge.conf
check "no user hullgauge after systemd-sysusers" grep -q '^hullgauge:x:[0-9]*:[0-9]*:.*:/var/lib/hullgauge:' "$root/etc/passwd"
check "no group hullgauge after systemd-sysusers" grep -q '^hullgauge:x:[0-9]*:' "$root/etc/group"
check "hullgauge is not in group video" grep -qE '^video:x:[0-9]+:(.*,)?hullgauge(,|$)' "$root/etc/group"

((fail == 0)) || exit 1
echo "package: contents, dependencies, maintainer scripts, installed unit and service user right"
