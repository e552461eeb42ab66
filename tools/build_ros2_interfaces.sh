#!/usr/bin/env bash
# Generate and install the Python interfaces of control_msgs and controller_manager_msgs (not on PyPI) from the
# upstream definitions in svhdesc/ros2/interfaces/ (SOURCES.md names their commits), with rosidl and ament_cmake
# from PyPI's ROS 2 Jazzy wheels, into the venv given as $1 (an ament prefix: the wheels install their share/ there).
#   bash tools/build_ros2_interfaces.sh .venv
set -euo pipefail
cd "$(dirname "$0")/.."
venv=$(cd "${1:-.venv}" && pwd)
py=$venv/bin/python
site=$("$py" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')
build=$(mktemp -d)
trap 'rm -rf "$build"' EXIT
export PATH=$venv/bin:$PATH AMENT_PREFIX_PATH=$venv CMAKE_PREFIX_PATH=$venv
# The wheels' shared libraries (site-packages/ros_*.libs) for the generators' helper programs.
LD_LIBRARY_PATH=$venv/lib:$(printf '%s:' "$site"/ros_*.libs)${LD_LIBRARY_PATH:-}
export LD_LIBRARY_PATH
for pkg in control_msgs controller_manager_msgs tf2_msgs; do  # none needs another of these three
  cmake -S "svhdesc/ros2/interfaces/$pkg" -B "$build/$pkg" -G Ninja -DCMAKE_BUILD_TYPE=Release \
    -DCMAKE_INSTALL_PREFIX="$venv" -DPython3_EXECUTABLE="$py" -DPYTHON_INSTALL_DIR="${site#"$venv"/}" \
    -DBUILD_TESTING=OFF >"$build/$pkg.log" 2>&1 || { cat "$build/$pkg.log" >&2; exit 1; }
  cmake --build "$build/$pkg" --target install >>"$build/$pkg.log" 2>&1 || { tail -50 "$build/$pkg.log" >&2; exit 1; }
done
"$py" -c 'import control_msgs.action, controller_manager_msgs.srv, tf2_msgs.msg'
