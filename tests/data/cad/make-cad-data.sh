#!/usr/bin/env bash
# Regenerates the public CAD meshes of this folder (README.md lists them, with
# their sources and licences) byte for byte from Debian's packages:
#   - mcad-*.stl: OpenSCAD's MCAD library (openscad-mcad 2019.05-1) rendered
#     to binary STL by Debian's openscad 2021.01-6, one scad/*.scad per part;
#   - cgal-*.off: meshes of CGAL's data set (libcgal-demo 5.5.1-2,
#     usr/share/doc/libcgal-dev/data.tar.gz, data/meshes/), scaled to mm;
#   - hex-nut-m8-two-shells.stl, block-tjunction-*.stl: meshes with the
#     defects of a CAD export, derived from the MCAD ones (make-cad-data.py).
# CI does not run it: the committed files are what the tests read, and
# openscad and openscad-mcad are not among the project's dependencies
# (tools/setup-deps). To run it:
#   apt-get install -y --no-install-recommends openscad openscad-mcad python3
#   tests/data/cad/make-cad-data.sh            # fetches libcgal-demo with apt-get download
#   CGAL_DEMO_DEB=/path/libcgal-demo_5.5.1-2_all.deb tests/data/cad/make-cad-data.sh
# Other versions of the packages give other files: it refuses them unless
# HULLGAUGE_CAD_ANY_VERSION=1.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
cd "$here"

want_version() { # package version
  local have
  have="$(dpkg-query -W -f='${Version}' "$1" 2>/dev/null || true)"
  if [[ "$have" != "$2" && "${HULLGAUGE_CAD_ANY_VERSION:-0}" != 1 ]]; then
    echo "make-cad-data: $1 $2 needed (installed: ${have:-none}); HULLGAUGE_CAD_ANY_VERSION=1 to go on" >&2
    exit 2
  fi
}
want_version openscad 2021.01-6
want_version openscad-mcad 2019.05-1

tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT

# 1. MCAD parts, as OpenSCAD exports them (its CGAL union, no repair).
for scad in scad/mcad-*.scad; do
  part="$(basename "$scad" .scad)"
  openscad --export-format binstl -o "$part.stl" "$scad" 2>"$tmp/$part.log" ||
    { cat "$tmp/$part.log" >&2; exit 1; }
  python3 make-cad-data.py sort "$part.stl" # OpenSCAD's facet order varies between runs
  echo "make-cad-data: $part.stl"
done

# 2. Defects as an export writes them.
# An M8 nut and its washer face written as two closed shells, never unioned.
openscad --export-format binstl -o "$tmp/washer-face-m8.stl" scad/washer-face-m8.scad 2>"$tmp/washer.log" ||
  { cat "$tmp/washer.log" >&2; exit 1; }
python3 make-cad-data.py sort "$tmp/washer-face-m8.stl"
python3 make-cad-data.py concat hex-nut-m8-two-shells.stl \
  "hullgauge test data: M8 nut + washer face, two shells never unioned" \
  mcad-hex-nut-m8.stl "$tmp/washer-face-m8.stl"
echo "make-cad-data: hex-nut-m8-two-shells.stl"
# The rounded block with T-junctions on three sharp edges, closed by
# zero-area needle triangles, and the same left open.
python3 make-cad-data.py tjunction mcad-rounded-block.stl block-tjunction-needles.stl needle
python3 make-cad-data.py tjunction mcad-rounded-block.stl block-tjunction-open.stl open
echo "make-cad-data: block-tjunction-needles.stl block-tjunction-open.stl"

# 3. CGAL's meshes, scaled from their unit box to millimetres.
deb="${CGAL_DEMO_DEB:-}"
if [[ -z "$deb" ]]; then
  (cd "$tmp" && apt-get download libcgal-demo=5.5.1-2 >/dev/null)
  deb="$(ls "$tmp"/libcgal-demo_5.5.1-2_all.deb)"
fi
dpkg-deb --fsys-tarfile "$deb" | tar -xO ./usr/share/doc/libcgal-dev/data.tar.gz >"$tmp/data.tar.gz"
while read -r mesh factor; do
  tar -xzOf "$tmp/data.tar.gz" "data/meshes/$mesh.off" >"$tmp/$mesh.off"
  out="cgal-$mesh-x$factor.off"
  python3 make-cad-data.py scale-off "$tmp/$mesh.off" "$out" "$factor" \
    "CGAL 5.5.1 data/meshes/$mesh.off (Debian libcgal-demo 5.5.1-2, usr/share/doc/libcgal-dev/data.tar.gz)" \
    "scaled copy: every coordinate multiplied by $factor to millimetres; faces unchanged" \
    "licence: see tests/data/cad/README.md (CGAL's debian/copyright: CC0 1.0 for files without a notice)"
  echo "make-cad-data: $out"
done <<'EOF'
fandisk 50
joint 40
couplingdown 50
part 30
EOF
