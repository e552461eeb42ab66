#!/usr/bin/env bash
# Install svhdesc into ./.venv on a fresh Debian 12 machine (run as root for the system packages).
#   bash tools/install.sh          # the compiler: the `build` extra (svhdesc build, info)
#   bash tools/install.sh ros      # + Debian's ROS 1 for `svhdesc sim --ros` and the roslaunch files
#   bash tools/install.sh test     # everything the test suite and `svhdesc validate` use
set -euo pipefail
cd "$(dirname "$0")/.."
extra=build
packages=(python3 python3-venv git)
ros=(ros-core python3-rospy python3-actionlib python3-genpy python3-genmsg python3-std-msgs python3-sensor-msgs
  python3-geometry-msgs python3-trajectory-msgs python3-actionlib-msgs python3-rosgraph-msgs
  python3-tf2-msgs ros-robot-state-publisher)
case "${1:-}" in
  "") ;;
  ros) extra=build,sim; packages+=("${ros[@]}") ;;
  test)
    extra=test
    # urdfdom's check_urdf, Gazebo's sdformat (ign sdf), offscreen GL for `svhdesc render`, ROS 1 with RViz under
    # Xvfb (xwd and netpbm take its screenshot; iproute2 brings up loopback in the tests' private network namespace);
    # ODE (python3-pyode, Gazebo Classic's engine) for `svhdesc compare`'s ode engine.
    packages+=(liburdfdom-tools ignition-tools libsdformat-dev libegl1 libgl1-mesa-dri libosmesa6 "${ros[@]}"
      rviz xvfb x11-apps netpbm iproute2 python3-pyode)
    ;;
  *) echo "usage: bash tools/install.sh [ros|test]" >&2; exit 2 ;;
esac
missing=()
for p in "${packages[@]}"; do dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p"); done
if [ ${#missing[@]} -gt 0 ]; then
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi
# Debian's own interpreter, whatever `python3` is first on PATH: its ROS 1 Python packages are built for it.
[ -x .venv/bin/python ] || /usr/bin/python3 -m venv .venv
.venv/bin/python -m pip install -q --upgrade pip
.venv/bin/python -m pip install -q -c constraints.txt -e ".[$extra]"
