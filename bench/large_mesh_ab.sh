#!/bin/sh
# Side-by-side wall clock of two duolod CLIs on large inputs: loading (`duolod info`) and
# `duolod simplify` with its geometry report (bench/RESULTS.md, session 41). The inputs are made
# here: a 700 x 700 height-field grid (490k vertices, 977k triangles) as .gltf + .bin, as .gltf
# with its buffer in a data: URI and as an OBJ with normals (written by NEW), plus CGAL's bunny00
# and refined_elephant (scripts/fetch-bench-data.sh) and spot when they exist. Each command runs
# on both binaries alternately, RUNS times (default 3); the table gives the median wall clock, the
# geometry line's own seconds, and whether every printed number other than a time is the same.
# Usage: bench/large_mesh_ab.sh BASE_CLI NEW_CLI   (e.g. /tmp/base/build/tools/duolod build/tools/duolod)
set -eu
if [ $# -ne 2 ]; then
  echo "usage: $0 BASE_CLI NEW_CLI" >&2
  exit 2
fi
base=$(realpath "$1")
new=$(realpath "$2")
here=$(cd "$(dirname "$0")/.." && pwd)
runs=${RUNS:-3}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"
# The grid: z = 0.1 sin(0.05 i) cos(0.05 j) over [0, 1)^2, two triangles a cell (perl-base is part
# of every Debian system).
perl -e '
  use MIME::Base64;
  my $n = 700; my ($pos, $idx) = ("", "");
  for my $j (0 .. $n - 1) { for my $i (0 .. $n - 1) {
    $pos .= pack("f<3", $i / $n, $j / $n, 0.1 * sin($i * 0.05) * cos($j * 0.05)); } }
  for my $j (0 .. $n - 2) { for my $i (0 .. $n - 2) {
    my $a = $j * $n + $i; my ($b, $c, $d) = ($a + 1, $a + $n, $a + $n + 1);
    $idx .= pack("L<6", $a, $b, $d, $a, $d, $c); } }
  my $buf = $pos . $idx; my $nv = $n * $n; my $ni = ($n - 1) * ($n - 1) * 6;
  my $doc = sub { my $uri = shift; sprintf(q({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],"meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":1}]}],"accessors":[{"bufferView":0,"componentType":5126,"count":%d,"type":"VEC3","min":[0,0,-0.1],"max":[1,1,0.1]},{"bufferView":1,"componentType":5125,"count":%d,"type":"SCALAR"}],"bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":%d},{"buffer":0,"byteOffset":%d,"byteLength":%d}],"buffers":[{"byteLength":%d,"uri":"%s"}]}), $nv, $ni, length($pos), length($pos), length($idx), length($buf), $uri) };
  open(my $f, ">", "grid.bin") or die; binmode $f; print $f $buf; close $f;
  open($f, ">", "grid.gltf") or die; print $f $doc->("grid.bin"); close $f;
  open($f, ">", "grid_embedded.gltf") or die;
  print $f $doc->("data:application/octet-stream;base64," . encode_base64($buf, "")); close $f;'
"$new" simplify grid.gltf grid.obj --ratio 1 >/dev/null  # the same surface, with normals
run() {  # label, then the command's arguments; OUT stands for an output name per side
  label=$1
  shift
  : >times_base
  : >times_new
  i=0
  while [ "$i" -lt "$runs" ]; do
    for side in base new; do
      binary=$base
      [ "$side" = new ] && binary=$new
      args=$(printf '%s\n' "$@" | sed "s/^OUT/out_$side/")
      start=$(date +%s.%N)
      # shellcheck disable=SC2086
      "$binary" $args >"printed_$side" 2>&1 || true
      end=$(date +%s.%N)
      echo "$end - $start" | bc >>"times_$side"
      sed -e "s/out_$side/out/g" -e 's/[0-9.]* s\b//g' "printed_$side" >"figures_$side"
    done
    i=$((i + 1))
  done
  median() { sort -n "$1" | awk '{ v[NR] = $1 } END { print v[int((NR + 1) / 2)] }'; }
  geometry() { sed -n 's/^geometry.*, \([0-9.]*\) s$/\1/p' "printed_$1"; }
  mb=$(median times_base)
  mn=$(median times_new)
  same=DIFFERENT
  cmp -s figures_base figures_new && same=same
  printf '| %s | %.2f | %.2f | %.2f | %s | %s | %s |\n' "$label" "$mb" "$mn" \
    "$(echo "$mn / $mb" | bc -l)" "$(geometry base)" "$(geometry new)" "$same"
}
echo "| command | base s | new s | new/base | geometry base s | geometry new s | printed figures |"
echo "|---|---:|---:|---:|---:|---:|---|"
run "info grid (.gltf + .bin)" info grid.gltf
run "info grid (.gltf, data: URI)" info grid_embedded.gltf
run "info grid (.obj with normals)" info grid.obj
run "simplify grid.gltf --ratio 0.1" simplify grid.gltf OUT.obj --ratio 0.1 --force
meshes=/tmp/duolod-data/cgal/data/meshes
for mesh in "$meshes/bunny00.off" "$meshes/refined_elephant.off" "$here/../shared/assets/obj/spot/spot.obj"; do
  [ -f "$mesh" ] || { echo "(skipped: $mesh not found)"; continue; }
  run "simplify $(basename "$mesh") --ratio 0.1" simplify "$mesh" OUT.obj --ratio 0.1 --force
done
