#!/usr/bin/env bash
# Installs, with apt-get, only the Debian packages liloc needs that are missing.
# Idempotent: a second run checks with dpkg and returns in well under a second.
set -euo pipefail

PACKAGES=(
  build-essential cmake pkg-config ccache git
  liblcm-dev liblcm-bin liblcm-java libglib2.0-dev
  libeigen3-dev libpcl-dev libceres-dev libopencv-dev
  libspdlog-dev libgtest-dev libyaml-cpp-dev
  default-jdk-headless libjchart2d-java
)

missing=()
for pkg in "${PACKAGES[@]}"; do
  # dpkg-query prints "install ok installed" only for a fully installed package.
  if [[ "$(dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null)" != "install ok installed" ]]; then
    missing+=("$pkg")
  fi
done

if [[ ${#missing[@]} -eq 0 ]]; then
  exit 0
fi

echo "liloc setup: installing ${missing[*]}"
SUDO=""
if [[ $(id -u) -ne 0 ]]; then
  SUDO="sudo"
fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "liloc setup: done"
