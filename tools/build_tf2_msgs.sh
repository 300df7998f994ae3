#!/usr/bin/env bash
# Build the ROS 2 Jazzy interface package tf2_msgs (msg/TFMessage only, sources in
# tools/tf2_msgs/) and install it into a venv that holds the ROS 2 Jazzy PyPI wheels of
# requirements.txt, so that `from tf2_msgs.msg import TFMessage` works with rclpy (live /tf of
# markers_node). PyPI has no ROS 2 Jazzy tf2_msgs; ./rrps runs this after its pip steps.
#
# Usage:  tools/build_tf2_msgs.sh <venv-dir>
# Env:    JOBS (parallel compile jobs, default 2)
#
# Needs cmake >= 3.16, make, gcc, g++ (Debian: apt-get install cmake build-essential) and the
# interpreter's Python.h. Installs the build-time CMake/ament wheels of
# tools/tf2_msgs/requirements-build.txt into <venv>, then builds with rosidl's CMake
# (rosidl_generate_interfaces) in a temporary directory and installs into <venv> with the
# layout of the PyPI message wheels (<venv>/lib/libtf2_msgs__*.so, site-packages/tf2_msgs,
# share/tf2_msgs, share/ament_index). All output goes to <venv>/tf2_msgs-build.log; on failure
# its tail is printed and the exit status is 1.
set -euo pipefail

if [[ $# -ne 1 ]]; then
  echo "usage: $0 <venv-dir>" >&2
  exit 2
fi
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
V="$(cd "$1" && pwd)"
PY="$V/bin/python"
JOBS="${JOBS:-2}"
log="$V/tf2_msgs-build.log"
: > "$log"

fail() {
  echo "build_tf2_msgs: $* (log: $log)" >&2
  tail -n 30 "$log" >&2
  exit 1
}
[[ -x "$PY" ]] || fail "$PY not found (is $V a venv?)"
for tool in cmake make gcc g++; do
  command -v "$tool" >/dev/null || fail "'$tool' not found (apt-get install cmake build-essential)"
done
[[ -f "$V/share/geometry_msgs/cmake/geometry_msgsConfig.cmake" ]] \
  || fail "geometry_msgs is not in $V (pip install -r requirements.txt first)"

W="$(mktemp -d)"
trap 'rm -rf "$W"' EXIT

"$PY" -m pip install -q --disable-pip-version-check -r "$here/tf2_msgs/requirements-build.txt" \
  >> "$log" 2>&1 || fail "pip install of the build requirements failed"

# AMENT_PREFIX_PATH: rosidl's CMake finds the typesupports through the ament resource index.
# LD_LIBRARY_PATH: the generators run with the venv's python; _ROS_WHEELS_BOOTSTRAP_COMPLETE is
# unset so that the wheels' bootstrapper sets the library path of this venv itself.
export PATH="$V/bin:$PATH"
export AMENT_PREFIX_PATH="$V${AMENT_PREFIX_PATH:+:$AMENT_PREFIX_PATH}"
export LD_LIBRARY_PATH="$V/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
unset _ROS_WHEELS_BOOTSTRAP_COMPLETE || true
cmake -S "$here/tf2_msgs" -B "$W/build" -DCMAKE_BUILD_TYPE=Release -DBUILD_TESTING=OFF \
  -DCMAKE_PREFIX_PATH="$V" -DCMAKE_INSTALL_PREFIX="$V" -DPython3_EXECUTABLE="$PY" \
  >> "$log" 2>&1 || fail "cmake configure failed"
cmake --build "$W/build" -j "$JOBS" >> "$log" 2>&1 || fail "build failed"
cmake --install "$W/build" >> "$log" 2>&1 || fail "install failed"

# The message imports and its C typesupports load.
( cd / && "$PY" -c '
from tf2_msgs.msg import TFMessage
from geometry_msgs.msg import TransformStamped
TFMessage.__class__.__import_type_support__()
assert TFMessage._TYPE_SUPPORT is not None
TFMessage(transforms=[TransformStamped()])
' ) >> "$log" 2>&1 || fail "the installed tf2_msgs does not import"
