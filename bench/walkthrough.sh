#!/usr/bin/env bash
# The walk-through benchmark (issue 6; Liang et al. §7.2.2, Table 2) in one command: generates the
# LOD folders each scene needs (once; existing folders are reused) and runs bench_walkthrough on
# four single-asset scenes, two mixed scenes and one of compound models (Table 4's kind). Tables go
# to OUT/tables.md.
#
#   bench/walkthrough.sh [RUNS_DIR] [OUT_DIR] [extra bench_walkthrough flags...]
#
# RUNS_DIR (default /work/runs) holds walk-NAME-{sep,mesh,shader,int}/ and their .log (the
# generator's summary, where the table's generation times come from). The Dragon needs
# scripts/fetch-bench-data.sh once. Generation uses `duolod generate`'s defaults (10 levels,
# image-driven mesh candidates, the full GP search): about 21 minutes for all 16 folders on 2 cores
# with llvmpipe (Intel Xeon, session 30), half of it the interleaved optimizer. The walk-through
# stands its objects on the ground (+Y up) and walks at eye height, so the LODs are trained on
# `--views upright`; WALK_VIEWS=sphere trains them on the paper's sphere of views instead. WALK_FAST=1 uses the fast
# settings of session 4 (quadric mesh candidates, 4 levels, a small GP) for a quick look.
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
settings="--views ${WALK_VIEWS:-upright}"
if [ "${WALK_FAST:-0}" = 1 ]; then
  settings="$settings --mesh-mode quadric --levels 4 --shader-levels 2 --population 8 --generations 3 --candidates 100"
fi

generate() {  # NAME ASSET SHADER
  local name=$1 asset=$2 shader=$3 kind extra folder cache
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
    # A cold Mesa shader cache per folder, so the generation times compare.
    cache="$(mktemp -d)"
    # shellcheck disable=SC2086
    MESA_SHADER_CACHE_DIR="$cache" "$duolod" generate "$asset" --shader "$shader" $settings \
      --quiet --force $extra --out "$folder" > "$folder.log"
    rm -rf "$cache"
  done
}

[ -f "$dragon" ] || bash "$root/scripts/fetch-bench-data.sh"
generate dragon "$dragon" noise_phong
generate spot "$assets/obj/spot/spot.obj" pbr
generate avocado "$assets/gltf/Avocado/Avocado.gltf" blend
generate bottle "$assets/gltf/WaterBottle/WaterBottle.gltf" pbr

: > "$out/tables.md"
run() {  # NAME [bench flags...] OBJECT...
  local name=$1
  shift
  local args=()
  for object in "$@"; do
    case $object in -*) args+=("$object") ;; *) args+=(--object "$object") ;; esac
  done
  "$bench" "${args[@]}" --name "$name" --out "$out/$name" "${EXTRA[@]}"
  cat "$out/$name/walkthrough.md" >> "$out/tables.md"
  echo >> "$out/tables.md"
}
EXTRA=("$@")
run dragon "$runs/walk-dragon:noise_phong"
run spot "$runs/walk-spot:pbr"
run avocado "$runs/walk-avocado:blend"
run bottle "$runs/walk-bottle:pbr"
run mix-dragon-spot "$runs/walk-dragon:noise_phong" "$runs/walk-spot:pbr"
run mix-avocado-bottle-spot "$runs/walk-avocado:blend" "$runs/walk-bottle:pbr" "$runs/walk-spot:pbr"
# Table 4's kind of scene (the Trooper: one model whose parts each have their own LOD): 134 models
# of three parts each (about 400 parts, as in the other scenes), a wider grid for the wider models.
run compound-avocado-bottle-spot --compound --objects=134 --spacing=8 \
  "$runs/walk-avocado:blend" "$runs/walk-bottle:pbr" "$runs/walk-spot:pbr"
echo "tables: $out/tables.md"
