#!/usr/bin/env bash
# Fetches the geometry-only benchmark meshes (CGAL's demo data: bunny, armadillo,
# ChineseDragon-10kv, fandisk, ...) from the Debian package libcgal-demo, without installing it.
#
#   scripts/fetch-bench-data.sh [DIR]     (default DIR: /tmp/duolod-data)
#
# Afterwards the meshes are in DIR/cgal/data/meshes/*.off; bench_simplify looks there by default
# (or set DUOLOD_DATA_DIR=DIR). Idempotent: does nothing when the meshes are already present.
set -euo pipefail

dir="${1:-/tmp/duolod-data}"
meshes="$dir/cgal/data/meshes"
if [ -f "$meshes/bunny00.off" ] || [ -f "$meshes/armadillo.off" ]; then
  echo "fetch-bench-data: already present in $meshes"
  exit 0
fi

mkdir -p "$dir/cgal"
work="$(mktemp -d)"
chmod 755 "$work"  # apt-get download runs as _apt and warns when it cannot write here
trap 'rm -rf "$work"' EXIT
(cd "$work" && apt-get download libcgal-demo >/dev/null)
dpkg -x "$work"/libcgal-demo_*.deb "$work/pkg"
archive="$(find "$work/pkg" -name data.tar.gz | head -n 1)"
if [ -z "$archive" ]; then
  echo "fetch-bench-data: data.tar.gz not found inside libcgal-demo" >&2
  exit 1
fi
tar xzf "$archive" -C "$dir/cgal"
echo "fetch-bench-data: meshes in $meshes"
ls "$meshes" | head -n 40
