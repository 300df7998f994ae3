#!/usr/bin/env bash
# Build the ROS 2 Jazzy interface packages of tools/ (tf2_msgs: msg/TFMessage only, for live /tf
# of markers_node; rrps_msgs: the climbing step's action) and install them into a venv that holds
# the ROS 2 Jazzy PyPI wheels of requirements.txt, so that `from tf2_msgs.msg import TFMessage`
# and `from rrps_msgs.action import ClimbStep` work with rclpy. PyPI has no wheel of either;
# ./rrps runs this after its pip steps.
#
# Usage:  tools/build_interfaces.sh <venv-dir> [PACKAGE ...]   (default: every package of tools/)
# Env:    JOBS (parallel compile jobs, default 2)
#
# Needs cmake >= 3.16, make, gcc, g++ (Debian: apt-get install cmake build-essential) and the
# interpreter's Python.h. Installs the build-time CMake/ament wheels of
# tools/tf2_msgs/requirements-build.txt into <venv>, then builds each package with rosidl's CMake
# (rosidl_generate_interfaces) in a temporary directory and installs it into <venv> with the
# layout of the PyPI message wheels (<venv>/lib/lib<pkg>__*.so, site-packages/<pkg>,
# share/<pkg>, share/ament_index). All output goes to <venv>/interfaces-build.log; on failure its
# tail is printed and the exit status is 1.
set -euo pipefail

if [[ $# -lt 1 ]]; then
  echo "usage: $0 <venv-dir> [PACKAGE ...]" >&2
  exit 2
fi
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
V="$(cd "$1" && pwd)"
shift
packages=("$@")
if [[ ${#packages[@]} -eq 0 ]]; then
  for cmakelists in "$here"/*/CMakeLists.txt; do packages+=("$(basename "$(dirname "$cmakelists")")"); done
fi
PY="$V/bin/python"
JOBS="${JOBS:-2}"
log="$V/interfaces-build.log"
: > "$log"

fail() {
  echo "build_interfaces: $* (log: $log)" >&2
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
for package in "${packages[@]}"; do
  [[ -f "$here/$package/CMakeLists.txt" ]] || fail "no interface package $package in $here"
  cmake -S "$here/$package" -B "$W/$package" -DCMAKE_BUILD_TYPE=Release -DBUILD_TESTING=OFF \
    -DCMAKE_PREFIX_PATH="$V" -DCMAKE_INSTALL_PREFIX="$V" -DPython3_EXECUTABLE="$PY" \
    >> "$log" 2>&1 || fail "$package: cmake configure failed"
  cmake --build "$W/$package" -j "$JOBS" >> "$log" 2>&1 || fail "$package: build failed"
  cmake --install "$W/$package" >> "$log" 2>&1 || fail "$package: install failed"
  # Every interface of the package imports and its C typesupport loads.
  ( cd / && "$PY" - "$here/$package" "$package" <<'PYTHON' ) >> "$log" 2>&1 || fail "the installed $package does not import"
import importlib
import pathlib
import sys

source, package = pathlib.Path(sys.argv[1]), sys.argv[2]
for kind in ('msg', 'srv', 'action'):
    for path in sorted((source / kind).glob(f'*.{kind}')):
        cls = getattr(importlib.import_module(f'{package}.{kind}'), path.stem)
        cls.__class__.__import_type_support__()
        assert cls._TYPE_SUPPORT is not None, path
        print('imported', f'{package}/{kind}/{path.stem}')
PYTHON
done
