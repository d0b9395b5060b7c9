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
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if ((${#missing[@]})); then
  echo "duolod setup: installing ${missing[*]}"
  SUDO=""
  if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
else
  echo "duolod setup: all packages present"
fi
