#!/usr/bin/env bash
# Installs everything weft needs from Debian 12 packages (plus bookworm-backports for
# CMake >= 3.28 and Mesa 25's lavapipe). Idempotent and quick when all is present.
set -euo pipefail

packages=(
  clang-19 clang-tools-19 libclang-rt-19-dev lld-19 ninja-build cmake
  libvulkan-dev vulkan-validationlayers mesa-vulkan-drivers
  glslang-dev glslang-tools spirv-tools
  libglm-dev libopenmesh-dev libtinygltf-dev libspdlog-dev libfmt-dev doctest-dev
  libeigen3-dev libembree-dev libstb-dev nlohmann-json3-dev libcli11-dev libtinyexr-dev libjpeg62-turbo-dev
  libtbb-dev git
  # the viewer (window, UI, headless X for its tests) and the fuzzers
  libglfw3-dev libimgui-dev xvfb xauth libfuzzer-19-dev
  # the Python module (import weft), its tests and docs/python.md's plot
  pybind11-dev python3-dev python3-numpy python3-pytest python3-matplotlib
  # the farm's Slurm runner and its test's one-node cluster (docs/farm.md)
  slurm-wlm munge
)
# Packages whose Debian 12 version is too old: take them from bookworm-backports.
backported=(cmake mesa-vulkan-drivers libgl1-mesa-dri libglx-mesa0 libegl-mesa0 libgbm1 libglapi-mesa libdrm2 libdrm-amdgpu1)

sudo_cmd=""
if [ "$(id -u)" -ne 0 ]; then sudo_cmd="sudo"; fi

have_all() {
  command -v clang++-19 >/dev/null || return 1
  command -v clang-scan-deps-19 >/dev/null || return 1
  local v; v=$(cmake --version 2>/dev/null | sed -n 's/cmake version \([0-9]*\)\.\([0-9]*\).*/\1 \2/p')
  set -- $v; [ "${1:-0}" -gt 3 ] || { [ "${1:-0}" -eq 3 ] && [ "${2:-0}" -ge 28 ]; } || return 1
  local status
  status=$(dpkg-query -W -f='${Status}\n' "${packages[@]}" 2>/dev/null | grep -c "install ok installed" || true)
  [ "$status" -eq "${#packages[@]}" ] || return 1
  # Mesa 25 (lavapipe with Vulkan 1.4) comes from backports.
  dpkg-query -W -f='${Version}' mesa-vulkan-drivers 2>/dev/null | grep -q '^2[5-9]\.' || return 1
}

if have_all; then
  exit 0
fi

echo "[bootstrap] installing weft's dependencies from Debian packages..."
if ! grep -rqs 'bookworm-backports' /etc/apt/sources.list /etc/apt/sources.list.d/; then
  echo 'deb http://deb.debian.org/debian bookworm-backports main' | $sudo_cmd tee /etc/apt/sources.list.d/weft-backports.list >/dev/null
fi
export DEBIAN_FRONTEND=noninteractive
$sudo_cmd apt-get update -qq
$sudo_cmd apt-get install -y -qq --no-install-recommends "${packages[@]}" >/dev/null
# Installed only where present (names of Mesa's split packages change across releases).
to_backport=()
for p in "${backported[@]}"; do
  if dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || [ "$p" = cmake ] || [ "$p" = mesa-vulkan-drivers ]; then
    to_backport+=("$p/bookworm-backports")
  fi
done
$sudo_cmd apt-get install -y -qq --no-install-recommends "${to_backport[@]}" >/dev/null
if ! have_all; then
  echo "[bootstrap] error: dependencies still missing after install" >&2
  exit 1
fi
echo "[bootstrap] done: $(cmake --version | head -1), $(clang++-19 --version | head -1)"
