#!/usr/bin/env bash
# Installs the Debian 12 packages capsflow builds with, when any is missing. Sourced by tools/demo.sh and
# tools/test.sh; needs root (or sudo) only when something is missing.
capsflow_packages=(g++ cmake ninja-build pkg-config libeigen3-dev libfftw3-dev libhdf5-dev libtomlplusplus-dev
                   nlohmann-json3-dev libcli11-dev libgtest-dev libbenchmark-dev
                   python3-matplotlib python3-h5py  # capsflow figures
                   python3-yaml python3-venv        # tests: CITATION.cff read; pip install ./python into a venv
                   paraview python3-paraview xvfb xauth ffmpeg  # capsflow render: pvbatch, a display, the movie
                   dpkg-dev)                        # cpack -G DEB: dpkg-shlibdeps finds the package's dependencies

capsflow_install() {
  local missing=()
  for p in "$@"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  [ ${#missing[@]} -eq 0 ] && return 0
  echo "capsflow: installing Debian packages: ${missing[*]}"
  local sudo=""
  [ "$(id -u)" -ne 0 ] && sudo="sudo"
  $sudo apt-get update -qq && DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
}

capsflow_ensure_deps() { capsflow_install "${capsflow_packages[@]}"; }
