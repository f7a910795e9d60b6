#!/usr/bin/env bash
# CI part for ROS 2 / MCAP interop (docs/ros2.md): a venv with the independent Python tooling (rosbags, mcap,
# mcap-ros2-support from PyPI), then pmon's bag tests against it. Called from .ci/run.
# `--workspace` keeps the feature set of the main test run, so nothing is compiled again (pmon-ros's own unit
# tests ran there).
set -euo pipefail
cd "$(dirname "$0")/.."
start=$(date +%s)
venv="${PMON_ROS_VENV:-target/ros-venv}"
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
fi
"$venv/bin/pip" install --quiet --disable-pip-version-check "rosbags==0.11.*" "mcap==1.*" "mcap-ros2-support==0.6.*"
echo "== ROS 2 bag interop (rosbags writes, pmon checks, python mcap reads back)"
PMON_ROS_PYTHON="$(pwd)/$venv/bin/python" cargo test --workspace --locked --test ros_bag_interop
echo "== ros.sh took $(( $(date +%s) - start )) s"
