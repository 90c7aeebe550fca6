#!/usr/bin/env bash
# Installs every Debian package the project needs; installs nothing when all are present.
# Idempotent; uses sudo when not root.
set -euo pipefail

PACKAGES=(
  build-essential cmake ninja-build pkg-config git
  libeigen3-dev
  libsuitesparse-dev libopenblas-dev
  cyclonedds-dev cyclonedds-tools
  openssl libssl-dev  # DDS Security: scripts/make_credentials.sh, the checks of --secure
  libopencv-dev
  libyaml-cpp-dev nlohmann-json3-dev libcli11-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  gmsh python3-gmsh
  python3-matplotlib
  iproute2 nftables procps jq parallel
  libfastrtps-dev fastddsgen  # only for tests/interop (Fast DDS against the ROS 2 mirror)
)

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#PACKAGES[@]} packages present"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "setup: need root or sudo to install: ${missing[*]}" >&2; exit 1; }
  SUDO="sudo"
fi
echo "setup: installing ${missing[*]}"
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
echo "setup: done"
