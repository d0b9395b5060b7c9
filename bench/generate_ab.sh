#!/usr/bin/env bash
# A/B timing of `duolod generate` on the Dragon + noise_phong: two binaries, alternated A B A B
# (ROUNDS rounds), each run with a cold Mesa shader cache, so drift of a shared or virtualised
# machine falls on both alike. Prints each run's stage times and wall clock.
#
#   bench/generate_ab.sh OLD_DUOLOD NEW_DUOLOD [ROUNDS=2] [OUT=/tmp/duolod-generate-ab]
#
# Build OLD from an earlier commit in its own clone (its binary finds that clone's shaders).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
[ $# -ge 2 ] || { echo "usage: $0 OLD_DUOLOD NEW_DUOLOD [ROUNDS] [OUT]" >&2; exit 2; }
old="$1" new="$2" rounds="${3:-2}" out="${4:-/tmp/duolod-generate-ab}"
"$root/scripts/fetch-bench-data.sh" >/dev/null
dragon="${DUOLOD_DATA_DIR:-/tmp/duolod-data}/cgal/data/meshes/ChineseDragon-10kv.off"
mkdir -p "$out"
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), load $(cut -d' ' -f1-3 /proc/loadavg)"
for round in $(seq 1 "$rounds"); do
  for side in old new; do
    bin="$old"
    [ "$side" = new ] && bin="$new"
    run="$out/$side-$round"
    rm -rf "$run" "$run.cache"
    start=$(date +%s.%N)
    MESA_SHADER_CACHE_DIR="$run.cache" "$bin" generate "$dragon" --shader noise_phong --out "$run" \
      --verbose >"$run.log" 2>&1
    end=$(date +%s.%N)
    echo "$side round $round: $(grep '^time ' "$run.log" | sed 's/^time *//'), wall $(awk -v a="$start" -v b="$end" 'BEGIN{printf "%.1f", b-a}') s"
  done
done
