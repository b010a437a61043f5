#!/usr/bin/env bash
# The inside of install_package.sh: runs as PID 1 of fresh mount, PID and
# network namespaces (unshare), builds the throwaway root there, installs the
# package with apt and runs the installed station. See install_package.sh.
#
#   install_package_root.sh SCRATCH DEB
set -euo pipefail
scratch=${1:?}
deb=${2:?}
fail=0
check() { # message command...
  local message=$1
  shift
  if ! "$@"; then
    echo "FAILED: $message" >&2
    fail=1
  fi
}
die() {
  echo "FAILED: $*" >&2
  exit 1
}

# The root: this machine's / read-only below, a tmpfs above, fresh /proc, /run, /tmp.
mount --make-rprivate /
layers=$scratch/layers
mkdir -p "$layers"
mount -t tmpfs -o size=2g tmpfs "$layers"
mkdir -p "$layers/upper" "$layers/work" "$layers/root"
root=$layers/root
mount -t overlay overlay -o "lowerdir=/,upperdir=$layers/upper,workdir=$layers/work" "$root"
mount -t proc proc "$root/proc"
mount --rbind /dev "$root/dev"
mount -t tmpfs tmpfs "$root/run"
mount -t tmpfs tmpfs "$root/tmp"
ip link set lo up
# A line PC's environment, not this shell's (no tool folders of a developer's PATH).
in_root() { chroot "$root" env -i PATH=/usr/sbin:/usr/bin:/sbin:/bin LANG=C.UTF-8 "$@"; }

# A root that already holds the package would prove nothing.
if in_root dpkg-query -W -f='${Status}' hullgauge 2>/dev/null | grep -q "install ok installed"; then
  in_root dpkg --purge hullgauge >/dev/null
fi
rm -rf "$root/etc/hullgauge" "$root/var/lib/hullgauge"
sed -i '/^hullgauge:/d' "$root/etc/passwd" "$root/etc/group" "$root/etc/shadow" "$root/etc/gshadow" 2>/dev/null || true

cp "$deb" "$root/tmp/"
pkg=/tmp/$(basename "$deb")
echo "install_package: apt-get install $pkg"
if ! in_root env DEBIAN_FRONTEND=noninteractive apt-get install -y "$pkg" >"$scratch/apt.log" 2>&1; then
  cat "$scratch/apt.log" >&2
  die "apt-get install of the package (a Depends this machine cannot satisfy from Debian's packages, or a maintainer script failed)"
fi
installed() { in_root dpkg-query -W -f='${Status}' hullgauge | grep -qx 'install ok installed'; }
check "dpkg does not list hullgauge as installed" installed
check "apt-get check: broken dependencies after the install" in_root apt-get check -q
conffiles=$(in_root dpkg-query -W -f='${Conffiles}' hullgauge)
for f in /etc/hullgauge/hullgauged.yaml /etc/hullgauge/station.yaml /etc/hullgauge/programs/stepped-block.yaml; do
  check "$f is not a conffile of the package" grep -q " $f " <<<"$conffiles"
done
check "the postinst made no user hullgauge" in_root getent passwd hullgauge
for f in /usr/share/man/man8/hullgauged.8.gz /usr/share/man/man1/hullgauge.1.gz \
  /usr/share/hullgauge/hmi/line.html /usr/share/doc/hullgauge/hmi.md \
  /usr/share/doc/hullgauge/examples/hardware/station.yaml; do
  check "$f not installed" test -s "$root$f"
done
man_renders() { in_root man -l /usr/share/man/man8/hullgauged.8.gz 2>/dev/null | grep -q -- '--config'; }
check "man hullgauged does not render its options" man_renders

# Without systemd (docs/daemon.md, "Without systemd"): started as root in the
# foreground, the daemon makes its folders and becomes the unit's user itself;
# its --check reads the configuration as that user.
check "the root already holds the daemon's folders" test ! -e "$root/run/hullgauge" -a ! -e "$root/var/lib/hullgauge"
if ! in_root /usr/sbin/hullgauged --foreground --check --config /etc/hullgauge/hullgauged.yaml >"$scratch/check.log" 2>&1; then
  cat "$scratch/check.log" >&2
  die "hullgauged --check refused the installed configuration"
fi

# The real-station template is valid as shipped once its EDIT values are the
# station's: here its programs are the installed simulated line's, and the HMI's
# password hash comes as the unit's credential would bring it.
template=$root/etc/hullgauge-template
mkdir -p "$template/credentials"
cp "$root"/usr/share/doc/hullgauge/examples/hardware/*.yaml "$template/"
sed -i 's#programs/part-1.yaml#/etc/hullgauge/programs/stepped-block.yaml#; s#programs/part-1-views.yaml#/etc/hullgauge/programs/stepped-block-views.yaml#' \
  "$template/hullgauged.yaml"
openssl passwd -6 "template-check" >"$template/credentials/hmi-password-hash"
if ! in_root env CREDENTIALS_DIRECTORY=/etc/hullgauge-template/credentials \
  /usr/sbin/hullgauged --check --config /etc/hullgauge-template/hullgauged.yaml >"$scratch/template.log" 2>&1; then
  cat "$scratch/template.log" >&2
  echo "FAILED: hullgauged --check refused the hardware template with its programs filled in" >&2
  fail=1
fi

(exec chroot "$root" env -i PATH=/usr/sbin:/usr/bin:/sbin:/bin LANG=C.UTF-8 \
  /usr/sbin/hullgauged --foreground --config /etc/hullgauge/hullgauged.yaml) >"$scratch/daemon.log" 2>&1 &
daemon=$!
ready=0
deadline=$((SECONDS + 120)) # the first start prepares the program's map and outlines
while ((SECONDS < deadline)); do
  kill -0 "$daemon" 2>/dev/null || break
  if in_root hullgauge ctl status 2>/dev/null | grep -qE '^state: +ready'; then
    ready=1
    break
  fi
  sleep 0.2
done
if ((ready == 0)); then
  tail -40 "$scratch/daemon.log" >&2
  die "the installed daemon did not become ready within 120 s"
fi
echo "install_package: the installed daemon is ready"
echo "install_package: $(grep -o 'foreground: .*' "$scratch/daemon.log" | head -1)"

# What the unit would give it, as the kernel and the file system see it: user and group
# hullgauge, the groups video and dialout (the sysusers file), CAP_NET_BIND_SERVICE
# (capability 10: mask 0x400) alone in every set, no new privileges, its two folders.
uid=$(in_root id -u hullgauge)
gid=$(in_root id -g hullgauge)
proc() { sed -n "s/^$1:[[:space:]]*//p" "$root/proc/$daemon/status" | tr -s '[:space:]' ' ' | sed 's/ $//'; }
check "the daemon runs as uid $(proc Uid), not hullgauge's $uid" test "$(proc Uid)" = "$uid $uid $uid $uid"
check "the daemon runs as gid $(proc Gid), not hullgauge's $gid" test "$(proc Gid)" = "$gid $gid $gid $gid"
for group in video dialout; do
  check "the daemon is not in group $group (its groups: $(proc Groups))" \
    grep -qw "$(in_root getent group "$group" | cut -d: -f3)" <<<"$(proc Groups)"
done
for set in CapEff CapPrm CapInh CapBnd CapAmb; do
  check "$set of the daemon is $(proc "$set"), not CAP_NET_BIND_SERVICE alone" test "$(proc "$set")" = 0000000000000400
done
check "the daemon may gain privileges (NoNewPrivs $(proc NoNewPrivs))" test "$(proc NoNewPrivs)" = 1
for folder in /run/hullgauge /var/lib/hullgauge; do
  made=$(in_root stat -c '%U:%G %a' "$folder")
  echo "install_package: $folder $made"
  check "$folder is $made, not hullgauge:hullgauge 750 as the unit makes it" test "$made" = "hullgauge:hullgauge 750"
done
check "the daemon did not log to stderr" grep -q 'foreground: user hullgauge' "$scratch/daemon.log"
parts=$(in_root stat -c '%U:%G' /var/lib/hullgauge/parts)
check "the workbench's workspace is $parts, not the user's" test "$parts" = hullgauge:hullgauge

in_root /usr/share/doc/hullgauge/examples/plc-client --port 502 cycles 4 --bad-every 2 \
  --sim-socket /run/hullgauge/hullgauged.sock >"$scratch/plc.log" 2>&1 || {
  cat "$scratch/plc.log" >&2
  tail -40 "$scratch/daemon.log" >&2
  die "the example PLC client's cycles on port 502"
}
check "a PLC cycle's verdict was wrong or inconsistent" python3 - "$scratch/plc.log" <<'EOF'
import json, sys
lines = [json.loads(l) for l in open(sys.argv[1]) if l.startswith("{")]
cycles = [l for l in lines if "serial" in l]
bad = [c for c in cycles if c["verdict"] != c["expected"] or not c["consistent"]]
for c in cycles:
    print(f"install_package: PLC cycle {c['serial']}: {c['verdict']} ({c['cycle_ms']} ms)")
sys.exit(1 if len(cycles) != 4 or bad else 0)
EOF

http_get() { # path -> prints "status bytes content-type"
  in_root python3 - "$1" <<'EOF'
import http.client, sys
c = http.client.HTTPConnection("127.0.0.1", 8080, timeout=10)
c.request("GET", sys.argv[1])
r = c.getresponse()
body = r.read()
print(r.status, len(body), r.getheader("Content-Type"))
EOF
}
page=$(http_get /)
chart=$(grep -o 'src="[^"]*chart[^"]*"' "$root/usr/share/hullgauge/hmi/spc.html" | head -1 | sed 's/^src="//; s/"$//')
check "the SPC page names no Chart.js script" test -n "$chart"
chart_answer=$(http_get "$chart")
status=$(http_get /api/status)
echo "install_package: HMI / -> $page; $chart -> $chart_answer; /api/status -> $status"
check "the line view not 200 text/html" grep -q '^200 [1-9][0-9]* text/html' <<<"$page"
check "Debian's Chart.js not served" grep -q '^200 [1-9][0-9]* ' <<<"$chart_answer"
check "/api/status not 200" grep -q '^200 ' <<<"$status"
rows=$(in_root python3 -c "import sqlite3; print(sqlite3.connect('file:/var/lib/hullgauge/results.db?mode=ro', uri=True).execute('SELECT COUNT(*) FROM inspections').fetchone()[0])")
check "the result store holds $rows cycles, not the 4 run" test "$rows" = 4

kill -TERM "$daemon"
code=0
wait "$daemon" || code=$?
check "hullgauged ended with $code after SIGTERM" test "$code" = 0

# Purge as docs/daemon.md ("Installing the package") says: programs, conffiles, the
# HMI's password hash and the runtime folder go; the result store and its user stay.
echo '$6$x$y' >"$root/etc/hullgauge/hmi-password-hash"
purge() { # log [VAR=value...]
  local log=$1
  shift
  if ! in_root env DEBIAN_FRONTEND=noninteractive "$@" apt-get purge -y hullgauge >"$scratch/$log" 2>&1; then
    cat "$scratch/$log" >&2
    die "apt-get purge hullgauge $*"
  fi
}
purge purge.log
check "the daemon is still there after the purge" test ! -e "$root/usr/sbin/hullgauged"
check "conffiles are still there after the purge" test ! -e "$root/etc/hullgauge/hullgauged.yaml"
check "/etc/hullgauge is still there after the purge" test ! -e "$root/etc/hullgauge"
check "/run/hullgauge is still there after the purge" test ! -e "$root/run/hullgauge"
check "the purge did not keep the result store" test -s "$root/var/lib/hullgauge/results.db"
check "the purge did not keep the user hullgauge" in_root getent passwd hullgauge
check "the purge did not say what it kept" grep -q 'kept the result store /var/lib/hullgauge' "$scratch/purge.log"
kept=$(in_root python3 -c "import sqlite3; print(sqlite3.connect('file:/var/lib/hullgauge/results.db?mode=ro', uri=True).execute('SELECT COUNT(*) FROM inspections').fetchone()[0])")
echo "install_package: purged; kept /var/lib/hullgauge ($kept cycles) and user hullgauge (uid $(in_root id -u hullgauge))"
check "the kept result store holds $kept cycles, not the 4 run" test "$kept" = 4

# Installed again, the station finds its store and its user; purged with
# HULLGAUGE_PURGE_RESULTS=yes, both go.
if ! in_root env DEBIAN_FRONTEND=noninteractive apt-get install -y "$pkg" >"$scratch/apt2.log" 2>&1; then
  cat "$scratch/apt2.log" >&2
  die "apt-get install of the package over the kept result store"
fi
check "the user hullgauge changed its uid on the second install" test "$(in_root id -u hullgauge)" = "$uid"
check "the kept store is no longer hullgauge's" test "$(in_root stat -c %U /var/lib/hullgauge/results.db)" = hullgauge
purge purge-results.log HULLGAUGE_PURGE_RESULTS=yes
check "/var/lib/hullgauge is still there after the purge with HULLGAUGE_PURGE_RESULTS=yes" test ! -e "$root/var/lib/hullgauge"
check "the user hullgauge is still there after the purge with HULLGAUGE_PURGE_RESULTS=yes" \
  bash -c '! grep -q "^hullgauge:" "$1/etc/passwd" "$1/etc/group"' _ "$root"

((fail == 0)) || exit 1
echo "install_package: installed with apt, the simulated line ran from the installed files in the foreground, purged keeping its results, purged with them"
