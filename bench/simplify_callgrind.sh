#!/bin/sh
# Instruction counts of duolod's quadric mode (simplifyQuadric) against meshoptimizer 0.18's
# meshopt_simplify, same process, same input, same target (bench/RESULTS.md, issue 3), under
# callgrind (deterministic, unlike wall clock on a shared machine). Positions-only rows.
# Usage: bench/simplify_callgrind.sh [BUILD_DIR] [RATIOS] [MESHES...]
#   defaults: build, "0.5 0.1 0.01", CGAL's bunny, armadillo, ChineseDragon-10kv, fandisk
#   (scripts/fetch-bench-data.sh) and the shared WaterBottle, Avocado, spot.
# Prints: mesh ratio ours meshopt ours/meshopt (instructions, inclusive).
set -eu
command -v valgrind >/dev/null 2>&1 || {
  echo "simplify_callgrind.sh: needs valgrind (apt-get install valgrind)" >&2
  exit 2
}
build=${1:-build}
ratios=${2:-"0.5 0.1 0.01"}
[ $# -ge 2 ] && shift 2 || shift $#
data=${DUOLOD_DATA_DIR:-/tmp/duolod-data}/cgal/data/meshes
assets=$(dirname "$0")/../../shared/assets
[ -d "$assets" ] || assets=/work/shared/assets
if [ $# -eq 0 ]; then
  set -- "$data/bunny00.off" "$data/armadillo.off" "$data/ChineseDragon-10kv.off" \
    "$data/fandisk.off" "$assets/gltf/WaterBottle/WaterBottle.gltf" \
    "$assets/gltf/Avocado/Avocado.gltf" "$assets/obj/spot/spot.obj"
fi
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
for mesh in "$@"; do
  for ratio in $ratios; do
    LP_NUM_THREADS=0 valgrind --tool=callgrind --callgrind-out-file="$out/cg" \
      "$build/bench/bench_simplify" "$mesh" --gltfpack "" --samples 0 --repeats 1 \
      --ratios "$ratio" --no-progressive --rows positions >/dev/null 2>&1
    callgrind_annotate --inclusive=yes "$out/cg" 2>/dev/null | awk -v m="$(basename "$mesh")" -v r="$ratio" '
      /duolod::mesh::simplifyQuadric\(/ && !ours { gsub(",", "", $1); ours = $1 }
      /:meshopt_simplify[ (]/ && !theirs { gsub(",", "", $1); theirs = $1 }
      END { printf "%s %s %.1fM %.1fM %.2f\n", m, r, ours / 1e6, theirs / 1e6, ours / theirs }'
  done
done
