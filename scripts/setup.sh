#!/usr/bin/env bash
# Installs the Debian 12 packages duolod needs (idempotent). Runs `apt-get update` at most once per
# machine boot-session: only when a package is missing.
set -euo pipefail

packages=(
  build-essential cmake pkg-config git
  libegl-dev libegl-mesa0 libgl1-mesa-dri libepoxy-dev
  glslang-dev glslang-tools spirv-tools libspirv-cross-c-shared-dev spirv-cross
  libtinygltf-dev nlohmann-json3-dev libstb-dev libeigen3-dev libcli11-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libmeshoptimizer-dev gltfpack
  assimp-testmodels  # real (and deliberately broken) OBJ/PLY/glTF files for the robustness tests
  chromium    # headless screenshot test of report.html
  locales     # a comma-decimal locale (localedef) for the runtime's locale-independence test
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
# Node.js and npm fetch the glTF-Validator and the third-party shaders from the npm registry.
# Debian's nodejs + npm when the machine has no node of its own (a node installed from elsewhere
# conflicts with Debian's npm package, so an existing one is used as it is).
if ! command -v node >/dev/null || ! command -v npm >/dev/null; then
  missing+=(nodejs npm)
fi

if ((${#missing[@]})); then
  echo "duolod setup: installing ${missing[*]}"
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
else
  echo "duolod setup: all packages present"
fi

# The Khronos glTF-Validator (npm `gltf-validator`, a JS library) for scripts/validate-gltf.js, in
# the gitignored .tools/ folder of the checkout. Tests that need it skip loudly without it.
tools_dir="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)/.tools"
if ! command -v npm >/dev/null; then
  echo "duolod setup: WARNING: no node/npm (Node.js >= 18 from nodejs.org or Debian's nodejs+npm):" \
       "the glTF validation tests will skip"
elif [ ! -f "$tools_dir/node_modules/gltf-validator/package.json" ]; then
  echo "duolod setup: fetching gltf-validator from npm into $tools_dir"
  mkdir -p "$tools_dir"
  npm install --prefix "$tools_dir" --no-audit --no-fund --silent gltf-validator@2.0.0-dev.3.10
else
  echo "duolod setup: gltf-validator present"
fi

# Third-party shaders for the shader round-trip test (issue 4): three.js MeshPhysicalMaterial and
# the glTF Sample Viewer PBR shader, fetched from npm into build-deps/npm (gitignored) and turned
# into GLSL 450 files by scripts/thirdparty_shaders.mjs. Optional: the test skips loudly without them.
npm_cache="$(cd "$(dirname "$0")/.." && pwd)/build-deps/npm"
three_version=0.187.0
gltf_viewer_version=1.1.0
if command -v npm >/dev/null && command -v node >/dev/null; then
  mkdir -p "$npm_cache"
  if [ ! -f "$npm_cache/three-$three_version.tgz" ] ||
     [ ! -f "$npm_cache/khronosgroup-gltf-viewer-$gltf_viewer_version.tgz" ]; then
    echo "duolod setup: fetching three@$three_version and @khronosgroup/gltf-viewer@$gltf_viewer_version"
    (cd "$npm_cache" && npm pack --silent "three@$three_version" "@khronosgroup/gltf-viewer@$gltf_viewer_version" >/dev/null)
    rm -rf "$npm_cache/three" "$npm_cache/gltf-viewer"
  fi
  if [ ! -d "$npm_cache/three/package" ] || [ ! -d "$npm_cache/gltf-viewer/package" ]; then
    mkdir -p "$npm_cache/three" "$npm_cache/gltf-viewer"
    tar xzf "$npm_cache/three-$three_version.tgz" -C "$npm_cache/three"
    tar xzf "$npm_cache/khronosgroup-gltf-viewer-$gltf_viewer_version.tgz" -C "$npm_cache/gltf-viewer"
  fi
  # Cheap (about a second), so always re-run: the extracted files follow the script.
  node "$(dirname "$0")/thirdparty_shaders.mjs" "$npm_cache" >/dev/null
else
  echo "duolod setup: WARNING: no node/npm: the third-party shader round-trip tests will skip"
fi
