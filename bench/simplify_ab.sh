#!/bin/sh
# Wall-clock A/B of two bench_simplify binaries (e.g. before and after a change to the quadric
# mode), alternating them so that both see the same machine drift (bench/RESULTS.md, issue 3).
# Each run prints, per mesh and ratio, duolod's time over meshopt_simplify 0.18's in the same
# process (their runs alternate; the ratio is the median of the per-pair ratios); the table gives
# the median of those ratios over the runs, and the median of duolod's ms.
# Usage: bench/simplify_ab.sh RUNS BINARY_A BINARY_B [bench_simplify arguments...]
#   e.g. bench/simplify_ab.sh 7 /tmp/old/bench_simplify build/bench/bench_simplify
# Each run is `BINARY --gltfpack "" --repeats $REPEATS (default 9) --samples 0 --no-progressive
# --rows $ROWS (default positions) [arguments]`: the positions-only rows, no distances
# (ROWS=default: the attribute-aware rows of files with attributes, i.e. the general engine).
set -eu
if [ $# -lt 3 ]; then
  echo "usage: $0 RUNS BINARY_A BINARY_B [bench_simplify arguments...]" >&2
  exit 2
fi
runs=$1
a=$2
b=$3
shift 3
for binary in "$a" "$b"; do
  [ -x "$binary" ] || { echo "simplify_ab.sh: $binary is not an executable" >&2; exit 2; }
done
out=$(mktemp)
trap 'rm -f "$out"' EXIT
i=0
while [ "$i" -lt "$runs" ]; do
  for side in A B; do
    binary=$a
    [ "$side" = B ] && binary=$b
    # The main table's rows (NF >= 15: not the narrower tables after it): | mesh | tris in |
    # target | ours | meshopt | ms ours | ms meshopt | ratio | ...
    "$binary" --gltfpack "" --repeats "${REPEATS:-9}" --samples 0 --no-progressive \
      --rows "${ROWS:-positions}" "$@" 2>/dev/null |
      awk -F'|' -v side="$side" 'NF >= 15 && /^\| / && !/^\| mesh/ {
        mesh = $2; target = $4; gsub(/^ +| +$/, "", mesh); gsub(/ /, "", target)
        gsub(/ /, "_", mesh)
        print side, mesh "@" target, $7 + 0, $9 + 0 }' >>"$out"
  done
  i=$((i + 1))
done
# Medians per cell and side, cells in first-seen order.
awk '
  function median(list,    n, v, i, j, t) {
    n = split(list, v, " ")
    for (i = 2; i <= n; ++i) for (j = i; j > 1 && v[j - 1] + 0 > v[j] + 0; --j) {
      t = v[j]; v[j] = v[j - 1]; v[j - 1] = t }
    return n % 2 ? v[(n + 1) / 2] : (v[n / 2] + v[n / 2 + 1]) / 2
  }
  { key = $2; if (!(key in seen)) { seen[key] = 1; order[++cells] = key }
    ms[$1, key] = ms[$1, key] " " $3; ratio[$1, key] = ratio[$1, key] " " $4 }
  END {
    printf "| cell | A ms | A ratio | B ms | B ratio | B/A time |\n|---|---:|---:|---:|---:|---:|\n"
    for (c = 1; c <= cells; ++c) {
      k = order[c]; am = median(ms["A", k]); bm = median(ms["B", k])
      ar = median(ratio["A", k]); br = median(ratio["B", k])
      printf "| %s | %.2f | %.2f | %.2f | %.2f | %.3f |\n", k, am, ar, bm, br, bm / am
      la += log(ar); lb += log(br)
    }
    printf "\ngeometric mean of the ratio (ours / meshopt): A %.3f, B %.3f\n",
      exp(la / cells), exp(lb / cells)
  }' "$out"
