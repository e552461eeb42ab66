#!/usr/bin/env bash
# Install svhdesc into ./.venv on a fresh Debian 12 machine (run as root for the system packages).
#   bash tools/install.sh          # the compiler (build extra)
#   bash tools/install.sh test     # everything the test suite and `svhdesc validate` use
set -euo pipefail
cd "$(dirname "$0")/.."
extra=build
packages=(python3 python3-venv python3-dev git)
if [ "${1:-}" = test ]; then
  extra=test
  # urdfdom's check_urdf, Gazebo's sdformat (ign sdf), offscreen GL for `svhdesc render`.
  packages+=(liburdfdom-tools ignition-tools libsdformat-dev libegl1 libgl1-mesa-dri libosmesa6)
fi
missing=()
for p in "${packages[@]}"; do dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p"); done
if [ ${#missing[@]} -gt 0 ]; then
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi
[ -x .venv/bin/python ] || python3 -m venv .venv
.venv/bin/python -m pip install -q --upgrade pip
.venv/bin/python -m pip install -q -c constraints.txt -e ".[$extra]"
