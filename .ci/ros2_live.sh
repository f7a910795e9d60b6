#!/usr/bin/env bash
# CI part for the live ROS 2 node (docs/ros2.md, "The live node"): `pmon ros2` against an independent DDS peer,
# Cyclone DDS from PyPI (`cyclonedds`), over loopback in a network namespace of its own (DDS discovers its peers
# by multicast, which plain loopback does not carry). Called from .ci/run; skips with a message where network
# namespaces are not permitted. PMON_ROS2_LOAD=1 adds the load measurement (KITTI sweeps at 10 Hz, ~20 s).
set -euo pipefail
cd "$(dirname "$0")/.."
start=$(date +%s)
venv="${PMON_ROS_VENV:-target/ros-venv}"
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
fi
"$venv/bin/pip" install --quiet --disable-pip-version-check "cyclonedds==11.*" "rosbags==0.11.*" "mcap==1.*" \
    "mcap-ros2-support==0.6.*"
if ! command -v unshare >/dev/null || ! command -v ip >/dev/null; then
    if command -v apt-get >/dev/null; then
        (apt-get update -qq && apt-get install -y -qq iproute2 util-linux >/dev/null) || true
    fi
fi
if ! unshare --net true 2>/dev/null || ! command -v ip >/dev/null; then
    echo "== ros2_live.sh: SKIPPED: no network namespace can be made here (unshare --net or iproute2 missing);"
    echo "   the live node test needs one for multicast DDS discovery on loopback (docs/ros2.md)"
    exit 0
fi
# Built outside the namespace (the same feature set as the main test run: nothing is compiled again).
cargo test --workspace --locked --test ros2_live --no-run
echo "== live ROS 2 node vs Cyclone DDS (network namespace, loopback with multicast)"
python="$(cd "$venv" && pwd)/bin/python"
unshare --net -- bash -c '
    set -euo pipefail
    ip link set lo up
    ip link set lo multicast on
    ip route add 224.0.0.0/4 dev lo
    PMON_ROS2_LIVE=1 PMON_ROS_PYTHON="$1" cargo test --offline --workspace --locked --test ros2_live -- \
        --nocapture --test-threads 1 $2
' _ "$python" "$([ "${PMON_ROS2_LOAD:-0}" = 1 ] && echo --include-ignored)"
echo "== ros2_live.sh took $(( $(date +%s) - start )) s"
