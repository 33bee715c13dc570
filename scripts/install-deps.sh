#!/usr/bin/env bash
# Installs the Debian packages shadowsg builds and runs with, or the packages
# named as arguments (scripts/install-workflow-deps.sh). Idempotent: does
# nothing when everything is already installed.
set -euo pipefail
PKGS=(cmake ninja-build g++ pkg-config ccache
      libeigen3-dev libopencv-dev libembree-dev libopenexr-dev libimath-dev
      nlohmann-json3-dev libcli11-dev libtinyobjloader-dev libraw-dev libapriltag-dev
      libgtest-dev libgmock-dev libbenchmark-dev gnuplot-nox colmap
      opencv-doc
      clang libclang-rt-14-dev  # libFuzzer (scripts/fuzz.sh)
      chromium)                 # bench --check-html: index.html in headless Chromium
[ $# -gt 0 ] && PKGS=("$@")
name=${INSTALL_DEPS_NAME:-install-deps}
missing=()
for p in "${PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "$name: all ${#PKGS[@]} packages present"
  exit 0
fi
echo "$name: installing ${missing[*]}"
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -q
$SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
