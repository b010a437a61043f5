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
#   - lintian, Debian's package checker: no error, and no warning but those
#     docs/daemon.md accepts ("Installing the package": none today); the
#     changelog is this version's, compressed with gzip -9n; no file of the
#     source tree's third-party test data (tests/data) is in the package, so the
#     copyright file, which names none, stays true;
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
for script in postinst prerm postrm; do
  check "maintainer script $script missing" grep -qE "^ +[0-9]+ bytes, +[0-9]+ lines +\* +$script " "$scratch/info"
done
for script in postinst prerm postrm; do
  check "$script does not parse" sh -n "$scratch/control/$script"
  check "$script is not executable" test -x "$scratch/control/$script"
done

# lintian's verdict: E: is an error, W: a warning; I: (information) and the
# rest are not counted. The warnings docs/daemon.md accepts, by tag: none.
accepted_warnings=()
lintian_rc=0
lintian --tag-display-limit 0 "$deb" >"$scratch/lintian.log" 2>&1 || lintian_rc=$?
grep '^E: ' "$scratch/lintian.log" >"$scratch/lintian.errors" || true
grep '^W: ' "$scratch/lintian.log" >"$scratch/lintian.warnings" || true
for tag in "${accepted_warnings[@]}"; do
  sed -i "/^W: hullgauge: $tag\( \|\$\)/d" "$scratch/lintian.warnings"
done
echo "lintian: $(wc -l <"$scratch/lintian.errors") errors, $(grep -c '^W: ' "$scratch/lintian.log") warnings" \
  "($(wc -l <"$scratch/lintian.warnings") not accepted)"
check "lintian did not run (exit status $lintian_rc): $(head -3 "$scratch/lintian.log")" test "$lintian_rc" -le 1
check "lintian reports errors: $(cat "$scratch/lintian.errors")" test ! -s "$scratch/lintian.errors"
check "lintian reports warnings docs/daemon.md does not accept: $(cat "$scratch/lintian.warnings")" \
  test ! -s "$scratch/lintian.warnings"
# The changelog: Debian's format, this package's version, gzip -9n (no name, no time: header bytes 3-7 zero).
changelog=./usr/share/doc/hullgauge/changelog.gz
check "$changelog is not in the package" grep -qxF "$changelog" "$scratch/files"
dpkg-deb --fsys-tarfile "$deb" | tar -xO "$changelog" >"$scratch/changelog.gz"
check "the changelog's version is not the package's" test "$(zcat "$scratch/changelog.gz" | dpkg-parsechangelog -l - -S Version)" = "$(dpkg-deb -f "$deb" Version)"
check "the changelog was not compressed with gzip -n (a name or a time in its header)" \
  test "$(od -An -tx1 -j3 -N5 "$scratch/changelog.gz" | tr -d ' \n')" = 0000000000
check "the changelog was not compressed with gzip -9 (XFL byte not 02)" test "$(od -An -tx1 -j8 -N1 "$scratch/changelog.gz" | tr -d ' \n')" = 02
check "./usr/share/doc/hullgauge/copyright is not in the package" grep -qxF ./usr/share/doc/hullgauge/copyright "$scratch/files"
for data in "$source_dir"/tests/data/*/*; do
  name=$(basename "$data")
  [[ -f $data ]] || continue
  check "test data $name is in the package: the copyright file does not name it" \
    bash -c '! grep -q "/$1\$" "$2"' _ "$name" "$scratch/files"
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
