#!/usr/bin/env bash
# The walk-through benchmark (issue 6; Liang et al. §7.2.2, Table 2) in one command: generates the
# LOD folders each scene needs (once; existing folders are reused) and runs bench_walkthrough on
# three single-asset scenes and one mixed scene. Tables go to OUT/tables.md.
#
#   bench/walkthrough.sh [RUNS_DIR] [OUT_DIR] [extra bench_walkthrough flags...]
#
# RUNS_DIR (default /work/runs) holds walk-NAME-{sep,mesh,shader,int}/ and their .log (the
# generator's summary, where the table's generation times come from). The Dragon needs
# scripts/fetch-bench-data.sh once. Generation uses fast settings (quadric mesh candidates, a small
# GP): minutes per folder on llvmpipe, not the paper's hours.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
runs="${1:-/work/runs}"
out="${2:-$root/out/walkthrough}"
shift $(( $# < 2 ? $# : 2 ))
duolod="$root/build/tools/duolod"
bench="$root/build/bench/bench_walkthrough"
assets="$root/../shared/assets"
dragon=/tmp/duolod-data/cgal/data/meshes/ChineseDragon-10kv.off
mkdir -p "$runs" "$out"

generate() {  # NAME ASSET SHADER
  local name=$1 asset=$2 shader=$3 kind extra folder
  for kind in sep mesh shader int; do
    folder="$runs/walk-$name-$kind"
    [ -f "$folder/lod.json" ] && continue
    case $kind in
      mesh) extra="--only mesh" ;;
      shader) extra="--only shader" ;;
      int) extra="--optimizer interleaved" ;;
      *) extra="" ;;
    esac
    echo "generating $folder"
    # shellcheck disable=SC2086
    "$duolod" generate "$asset" --shader "$shader" --mesh-mode quadric --levels 4 \
      --shader-levels 2 --population 8 --generations 3 --candidates 100 --quiet --force \
      $extra --out "$folder" > "$folder.log"
  done
}

[ -f "$dragon" ] || bash "$root/scripts/fetch-bench-data.sh"
generate dragon "$dragon" noise_phong
generate spot "$assets/obj/spot/spot.obj" pbr
generate avocado "$assets/gltf/Avocado/Avocado.gltf" blend

: > "$out/tables.md"
run() {  # NAME OBJECT...
  local name=$1
  shift
  local args=()
  for object in "$@"; do args+=(--object "$object"); done
  "$bench" "${args[@]}" --name "$name" --out "$out/$name" "${EXTRA[@]}"
  cat "$out/$name/walkthrough.md" >> "$out/tables.md"
  echo >> "$out/tables.md"
}
EXTRA=("$@")
run dragon "$runs/walk-dragon:noise_phong"
run spot "$runs/walk-spot:pbr"
run avocado "$runs/walk-avocado:blend"
run mix-dragon-spot "$runs/walk-dragon:noise_phong" "$runs/walk-spot:pbr"
echo "tables: $out/tables.md"
