#!/bin/sh
# Error A/B of two bench_simplify binaries (e.g. before and after a change to the quadric mode):
# each runs `BINARY --gltfpack "" --repeats 1 --orders ORDERS (default 4) --no-progressive
# [arguments]`, both at once (the error does not depend on timing), and the table of the
# Hausdorff and mean ratios to meshopt_simplify 0.18 (medians over the ORDERS + 1 input orders)
# is compared cell by cell: the cells whose medians changed, then per side the cells worse than
# meshopt (either ratio above 1.0) and the geometric means (cells with a zero ratio, printed as
# 0.00 when both errors are tiny, left out of that mean). bench/RESULTS.md, issue 3, uses it for the benchmark and survey meshes.
# Usage: bench/simplify_quality.sh BINARY_A BINARY_B [bench_simplify arguments...]
#   e.g. bench/simplify_quality.sh /tmp/old/bench_simplify build/bench/bench_simplify MESHES
set -eu
if [ $# -lt 2 ]; then
  echo "usage: $0 BINARY_A BINARY_B [bench_simplify arguments...]" >&2
  exit 2
fi
a=$1
b=$2
shift 2
for binary in "$a" "$b"; do
  [ -x "$binary" ] || { echo "simplify_quality.sh: $binary is not an executable" >&2; exit 2; }
done
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
"$a" --gltfpack "" --repeats 1 --orders "${ORDERS:-4}" --no-progressive "$@" >"$dir/a.txt" 2>&1 &
pid_a=$!
"$b" --gltfpack "" --repeats 1 --orders "${ORDERS:-4}" --no-progressive "$@" >"$dir/b.txt" 2>&1 &
pid_b=$!
wait "$pid_a" || { echo "simplify_quality.sh: $a failed:" >&2; tail -5 "$dir/a.txt" >&2; exit 1; }
wait "$pid_b" || { echo "simplify_quality.sh: $b failed:" >&2; tail -5 "$dir/b.txt" >&2; exit 1; }
# The medians table: | mesh | target | Hausdorff ratio, median | range | mean ratio, median |
medians() {
  awk -F'|' '/^\| mesh \| target \| Hausdorff ratio, median/ { on = 1; next }
    /^$/ { on = 0 }
    on && NF == 7 && $3 ~ /%/ {
      mesh = $2; target = $3; gsub(/^ +| +$/, "", mesh); gsub(/ /, "", target); gsub(/ /, "_", mesh)
      print mesh "@" target, $4 + 0, $6 + 0 }' "$1"
}
medians "$dir/a.txt" >"$dir/a.cells"
medians "$dir/b.txt" >"$dir/b.cells"
[ -s "$dir/a.cells" ] || { echo "simplify_quality.sh: no medians table from $a" >&2; exit 1; }
awk '
  FNR == NR { h[$1] = $2; m[$1] = $3; order[++cells] = $1; next }
  { hb[$1] = $2; mb[$1] = $3 }
  END {
    printf "| cell | A Hausdorff | A mean | B Hausdorff | B mean |\n|---|---:|---:|---:|---:|\n"
    for (c = 1; c <= cells; ++c) {
      k = order[c]
      if (!(k in hb)) { printf "| %s | %.2f | %.2f | missing | missing |\n", k, h[k], m[k]; continue }
      if (h[k] != hb[k] || m[k] != mb[k])
        printf "| %s | %.2f | %.2f | %.2f | %.2f |\n", k, h[k], m[k], hb[k], mb[k]
    }
    for (c = 1; c <= cells; ++c) {
      k = order[c]
      if (h[k] > 1 || m[k] > 1) { worse_a++; list_a = list_a " " k }
      if ((k in hb) && (hb[k] > 1 || mb[k] > 1)) { worse_b++; list_b = list_b " " k }
      if (h[k] > 0) { na++; lha += log(h[k]) }
      if ((k in hb) && hb[k] > 0) { nb++; lhb += log(hb[k]) }
      if (m[k] > 0) { ma++; lma += log(m[k]) }
      if ((k in hb) && mb[k] > 0) { mb_count++; lmb += log(mb[k]) }
    }
    printf "\n%d cells. Worse than meshopt (Hausdorff or mean above 1.0): A %d, B %d\n",
      cells, worse_a, worse_b
    printf "  A:%s\n  B:%s\n", list_a, list_b
    printf "geometric means: Hausdorff A %.3f, B %.3f; mean A %.3f, B %.3f\n",
      exp(lha / na), exp(lhb / nb), exp(lma / ma), exp(lmb / mb_count)
  }' "$dir/a.cells" "$dir/b.cells"
