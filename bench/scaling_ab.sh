#!/usr/bin/env bash
# A/B scaling probes: inputs that grow in one dimension, timed on two binaries side by side.
#   - a glTF of P primitives (one material each) sharing one vertex accessor, as duolod's writer
#     lays out a level: `duolod info`, wall clock and peak memory;
#   - a fragment stage of N sequential if/else blocks updating one colour, and one of N loops
#     with constant trip counts: `duolod shader` on Spot with --generations 0 (the site
#     enumeration, the rules' slicing and two renders), its own "search" time.
# Each shader input is run once on each binary to warm the Mesa shader cache before the timed
# runs, so neither side pays llvmpipe's compiles and both pay the same renders.
#
#   bench/scaling_ab.sh OLD_DUOLOD NEW_DUOLOD [OUT=/tmp/duolod-scaling-ab]
#
# Needs python3 (writes the inputs). Build OLD from an earlier commit in its own clone.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
[ $# -ge 2 ] || { echo "usage: $0 OLD_DUOLOD NEW_DUOLOD [OUT]" >&2; exit 2; }
old="$1" new="$2" out="${3:-/tmp/duolod-scaling-ab}"
command -v python3 >/dev/null || { echo "$0: python3 is needed to write the inputs" >&2; exit 1; }
spot="$root/../shared/assets/obj/spot/spot.obj"
[ -f "$spot" ] || { echo "$0: $spot is missing" >&2; exit 1; }
mkdir -p "$out"
export MESA_SHADER_CACHE_DIR="$out/mesa-cache"

python3 - "$out" "$root/shaders/constant.frag" <<'PY'
import json, struct, sys
out, constant = sys.argv[1], sys.argv[2]
for P in (1024, 4096):
    n = 1
    while n * n < P: n += 1
    verts = [(x, y, 0.0) for y in range(n + 1) for x in range(n + 1)]
    pos = b''.join(struct.pack('<3f', *v) for v in verts)
    idx = b''
    for q in range(P):
        a = (q // n) * (n + 1) + q % n
        idx += struct.pack('<6I', a, a + 1, a + n + 2, a, a + n + 2, a + n + 1)
    doc = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
           "nodes": [{"mesh": 0}],
           "buffers": [{"byteLength": len(pos) + len(idx), "uri": "p%d.bin" % P}],
           "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": len(pos)},
                           {"buffer": 0, "byteOffset": len(pos), "byteLength": len(idx)}],
           "accessors": [{"bufferView": 0, "componentType": 5126, "count": len(verts),
                          "type": "VEC3", "min": [0, 0, 0], "max": [n, n, 0]}],
           "materials": [{"name": "m%d" % i} for i in range(P)], "meshes": [{"primitives": []}]}
    for i in range(P):
        doc["accessors"].append({"bufferView": 1, "byteOffset": i * 24, "componentType": 5125,
                                 "count": 6, "type": "SCALAR"})
        doc["meshes"][0]["primitives"].append(
            {"attributes": {"POSITION": 0}, "indices": i + 1, "material": i})
    open("%s/p%d.bin" % (out, P), "wb").write(pos + idx)
    json.dump(doc, open("%s/p%d.gltf" % (out, P), "w"))
head = open(constant).read().split("layout(location = 0) out")[0]
for kind, counts in (("ifs", (100, 200, 400)), ("loops", (64, 128))):
    for N in counts:
        body = ["layout(location = 0) out vec4 outColor;", "void main() {",
                "  vec3 c = uBaseColorFactor.rgb;", "  float a = uMaterialParams.x;"]
        for i in range(N):
            if kind == "ifs":
                body.append("  if (c.x > %.3f) c = c * %.5f + vec3(a * %.3f); else c = c.zxy * 0.99;"
                            % (0.001 * i, 1 + 0.0001 * i, 0.01 * i))
            else:
                body.append("  for (int i = 0; i < %d; ++i) c = c * (0.999 + a * 0.001) + vec3(%.4f);"
                            % (i % 5 + 2, 0.0001 * i))
        body += ["  outColor = vec4(c, 1.0);", "}"]
        open("%s/%s%d.frag" % (out, kind, N), "w").write(head + "\n".join(body) + "\n")
PY
cp "$root/shaders/constant.vert" "$out/constant.vert"

echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), load $(cut -d' ' -f1-3 /proc/loadavg)"
printf '%-34s %14s %14s\n' "input" "old" "new"
for P in 1024 4096; do
  row=""
  for bin in "$old" "$new"; do
    /usr/bin/time -f "%e %M" -o "$out/time" "$bin" info "$out/p$P.gltf" >/dev/null
    read -r seconds kb <"$out/time"
    row+=$(printf ' %14s' "${seconds} s $((kb / 1024)) MB")
  done
  printf '%-34s%s\n' "info: $P primitives, one accessor" "$row"
done
for input in ifs100 ifs200 ifs400 loops64 loops128; do
  row=""
  for bin in "$old" "$new"; do
    args=(shader "$spot" --vert "$out/constant.vert" --frag "$out/$input.frag" --pixels 200
          --generations 0 --population 2 --no-timing --out "$out/run" --force)
    "$bin" "${args[@]}" >/dev/null 2>&1  # warms the Mesa cache
    search=$("$bin" "${args[@]}" 2>&1 | grep -oE 'search [0-9.]+ s' | grep -oE '[0-9.]+')
    row+=$(printf ' %14s' "search ${search} s")
  done
  printf '%-34s%s\n' "shader: $input.frag" "$row"
done
