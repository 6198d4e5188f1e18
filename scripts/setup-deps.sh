#!/usr/bin/env bash
# Installs every Debian package Afterimage needs to build, test and run its demo.
# Idempotent: apt-get skips packages that are already installed.
set -euo pipefail
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
pkgs=(
  cmake g++ ninja-build git clang-format
  ccache                   # a second build (--portable, the vendored package) reuses objects
  libembree-dev            # ray tracing (render/)
  libopenimageio-dev openimageio-tools  # EXR/PNG I/O (io/), oiiotool for users
  libtbb-dev               # threads
  libhwy-dev               # SIMD (core/simd.h)
  libfftw3-dev             # FFT reference bloom (post/)
  libopencv-photo-dev      # peer denoiser: OpenCV multi-frame non-local means (peers/)
  python3-opencv           # the same peer through OpenCV's Python binding (tools/opencv_nlm.py)
  libcli11-dev libfmt-dev libspdlog-dev nlohmann-json3-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  python3 python3-numpy python3-skimage   # SSIM cross-check data generation
  ffmpeg                   # demo side-by-side MP4
  chromium                 # headless check that the HTML report renders
)
missing=()
for p in "${pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  $SUDO apt-get update
  $SUDO apt-get install -y --no-install-recommends "${missing[@]}"
fi
