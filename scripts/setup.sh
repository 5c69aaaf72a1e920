#!/usr/bin/env bash
# Installs hedgefit's build and run dependencies from Debian 12 packages.
# Idempotent: does nothing (not even apt-get update) when everything is present.
set -euo pipefail

PACKAGES=(
  build-essential cmake pkg-config git
  libpcl-dev libopencv-dev libopencv-contrib-dev libeigen3-dev libflann-dev libvtk9-dev
  libceres-dev libgtest-dev libgmock-dev libbenchmark-dev libpng-dev libjpeg-dev
  libcli11-dev nlohmann-json3-dev libfmt-dev libtbb-dev libnanoflann-dev
  xvfb xauth
  clang libclang-rt-14-dev
  pybind11-dev python3-dev python3-numpy
  povray
)

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#PACKAGES[@]} packages already installed"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  if command -v sudo >/dev/null 2>&1; then
    SUDO="sudo"
  else
    echo "setup: need root (or sudo) to install: ${missing[*]}" >&2
    exit 1
  fi
fi

echo "setup: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -q
$SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
