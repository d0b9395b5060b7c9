#!/usr/bin/env bash
# The main job on a real sample asset, from a fresh Debian 12 machine: installs, builds, and runs
# duolod on the Khronos WaterBottle (glTF PBR, 4,510 triangles) with Mesa llvmpipe through EGL —
# no display or GPU needed. Results go to out/example/.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
asset="${1:-$root/../shared/assets/gltf/WaterBottle/WaterBottle.gltf}"
out="$root/out/example"

bash "$root/scripts/setup.sh"
bash "$root/scripts/build.sh" "$root/build"
duolod="$root/build/tools/duolod"
mkdir -p "$out"

echo "== duolod info =="
"$duolod" info "$asset"
echo "== duolod render: all 20 views of the paper's domain at 1 m, and one 4x4 supersampled =="
"$duolod" render "$asset" --distance 1 --out "$out/views.png" --force
"$duolod" render "$asset" --distance 1 --view 2 --supersample 4 --out "$out/reference_view2.png" --force
echo "== duolod error: the plain render against the 4x4 supersampled reference, near and far =="
"$duolod" error "$asset" "$asset" --distance 1
"$duolod" error "$asset" "$asset" --distance 4
echo "== duolod simplify: quadric to 25%, measured in geometry and in the image at 128 px =="
"$duolod" simplify "$asset" "$out/simplified_25.glb" --ratio 0.25 --pixels 128 --force
echo "== duolod simplify: the paper's image-driven mode at 48 px, to 50% =="
"$duolod" simplify "$asset" "$out/image_driven_50.glb" --mode image --ratio 0.5 --pixels 48 --force
echo "== duolod generate: the joint mesh + shader LOD of Spot with the noise/Phong shader (fast settings) =="
"$duolod" generate "$root/../shared/assets/obj/spot/spot.obj" --shader noise_phong --mesh-mode quadric \
  --levels 4 --shader-levels 1 --population 6 --generations 2 --candidates 50 \
  --out "$out/spot_lod" --force
echo "Results written to $out"
