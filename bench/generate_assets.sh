#!/usr/bin/env bash
# Issue 5's generation benchmark: `duolod generate` on the three kinds of asset (procedural
# ChineseDragon-10kv + noise_phong, textured WaterBottle + pbr, multi-texture Avocado + blend),
# the Dragon also with the interleaved optimizer, and a reduced Dragon (5 levels, K = 40) with the
# 1D walk against the 2D brute force. Prints one table row per run (stage times from duolod's own
# summary, levels kept, held-out verdicts); keeps each run's folder and log in OUT.
#
#   bench/generate_assets.sh [OUT [RUN...]]   (default OUT: /tmp/duolod-generate-bench; RUN names
#                                               pick rows, e.g. waterbottle-pbr; default all)
#
# Needs the build (scripts/build.sh) and the CGAL meshes (scripts/fetch-bench-data.sh, run here).
# Takes tens of minutes on a 2-core llvmpipe machine; run it on an otherwise idle machine when the
# times matter. Every run starts with an empty Mesa shader cache (cold compiles); a user's re-run
# of the same command is much faster (measured: the GP stage of a small WaterBottle run took
# 68 s cold and 5.5 s warm).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
out="${1:-/tmp/duolod-generate-bench}"
duolod="${DUOLOD_BIN:-$root/build/tools/duolod}"
assets="$root/../shared/assets"
[ -d "$assets" ] || assets="${DUOLOD_ASSET_DIR:-$root/assets}"
"$root/scripts/fetch-bench-data.sh" >/dev/null
dragon="${DUOLOD_DATA_DIR:-/tmp/duolod-data}/cgal/data/meshes/ChineseDragon-10kv.off"
mkdir -p "$out"

selected=("${@:2}")
run() {
  local name="$1"
  shift
  if [ ${#selected[@]} -gt 0 ] && [[ " ${selected[*]} " != *" $name "* ]]; then return; fi
  rm -rf "${out:?}/$name"
  local start end
  # A cold Mesa shader cache per run: llvmpipe keeps compiled shaders on disk, and a re-run of
  # the same command (same seed, same variants) would otherwise skip most compiles.
  rm -rf "${out:?}/mesa-cache-$name"
  start=$(date +%s.%N)
  if ! MESA_SHADER_CACHE_DIR="$out/mesa-cache-$name" "$duolod" generate "$@" --out "$out/$name" --verbose >"$out/$name.log" 2>&1; then
    echo "| $name | failed: see $out/$name.log |"
    return
  fi
  end=$(date +%s.%N)
  local times kept within
  times=$(grep '^time ' "$out/$name.log" |
          sed -E 's/.*mesh ([0-9.]+) s, shader ([0-9.]+) s, optimization ([0-9.]+) s, export ([0-9.]+) s, total ([0-9.]+) s.*/\1 | \2 | \3 | \5/')
  kept=$(grep '^levels ' "$out/$name.log" | sed -E 's/levels +([0-9]+ of [0-9]+) kept.*/\1/')
  within=$(awk '/held-out views and lights/{f=1;next} f&&/^ +[0-9]/{n++; if($4=="yes")y++} /^time/{f=0} END{printf "%d/%d", y, n}' "$out/$name.log")
  local dropped
  dropped=$(grep -c '^  dropped:' "$out/$name.log" || true)
  [ "$dropped" = 0 ] || within="$within ($dropped dropped)"
  local searches
  searches=$(grep -m1 'the shader searches took' "$out/$name.log" | sed -E 's/.*took ([0-9.]+) s.*/\1/' || true)
  printf '| %s | %s | %s | %s | %s | %.0f |\n' "$name" "$kept" "$times" "${searches:--}" "$within" "$(awk -v a="$start" -v b="$end" 'BEGIN{print b-a}')"
}

echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), load $(cut -d' ' -f1-3 /proc/loadavg)"
echo
echo "| run | levels kept | mesh s | shader s | optimization s | total s | GP searches s | held-out within | wall s |"
echo "|---|---|---:|---:|---:|---:|---:|---|---:|"
run dragon-separate "$dragon" --shader noise_phong
run waterbottle-pbr "$assets/gltf/WaterBottle/WaterBottle.gltf" --shader pbr
run avocado-blend "$assets/gltf/Avocado/Avocado.gltf" --shader blend
run dragon-interleaved "$dragon" --shader noise_phong --optimizer interleaved
run dragon-small-walk "$dragon" --shader noise_phong --levels 5 --candidates 40
run dragon-small-brute "$dragon" --shader noise_phong --levels 5 --candidates 40 --brute-force
echo
echo "(held-out: level 0 is the original at d_near, where the bound of eq. 4 is 0: not re-checked;"
echo " shader s is what the GP searches add after the mesh stage, GP searches s their own time)"
