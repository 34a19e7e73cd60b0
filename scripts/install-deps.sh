#!/usr/bin/env bash
# Installs every Debian 12 package mr needs to build, test and run.
# Non-interactive and idempotent: when everything is present it only checks
# (about a second) and touches nothing.  Run as root or with sudo available.
set -euo pipefail

packages=(
  # toolchain
  build-essential cmake ninja-build ccache pkg-config git clang-format
  clang libclang-rt-14-dev            # libFuzzer targets and sanitizer runtimes
  # core: images, maths, threading, JSON, logging, command lines
  libopenimageio-dev openimageio-tools libopenexr-dev libeigen3-dev libtbb-dev
  nlohmann-json3-dev libspdlog-dev libfmt-dev libcli11-dev zlib1g-dev
  # cameras and calibration (OpenCV's aruco module is in contrib)
  libmrcal-dev python3-mrcal python3-numpy libmrgingham-dev libsuitesparse-dev libopencv-dev libopencv-contrib-dev
  libceres-dev                        # the mirror sphere's robust fit
  # geometry and ray tracing
  libopenmesh-dev libembree-dev
  libtinygltf-dev                     # glTF 2.0 assets
  libopencolorio-dev                  # plates in log encodings and ACES
  # tests and benchmarks
  libgtest-dev libgmock-dev libbenchmark-dev
  blender python3-opencv              # the Cycles cross-check and bench/cycles_compare.py
  # the end-to-end pipeline: video registration, batch rendering, man pages
  colmap parallel help2man dpkg-dev
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi

echo "install-deps: installing ${#missing[@]} packages: ${missing[*]}"
sudo=""
if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
