#!/usr/bin/env bash
# pmon beside a numpy and a PCL implementation of its grid-plus-box-max stage (issue #16), side by side in one run.
# Opt-in, NOT part of CI: installs Debian's libpcl-dev (about 1.3 GB, as root) and numpy (into target/peers/venv).
#   crates/bench/peers/run.sh [ROUNDS] [ITERATIONS]        (defaults 3 and 300; docs/performance.md)
# Set PMON_PEERS_NO_PCL=1 to leave the PCL peer out (no install).
set -euo pipefail
root="$(cd "$(dirname "$0")/../../.." && pwd)"
cd "$root"
export CARGO_INCREMENTAL=0
cargo build --release --locked -p pmon-cli
out=target/peers
pcl=()
if [ "${PMON_PEERS_NO_PCL:-0}" != 1 ]; then
    bash crates/bench/peers/build_pcl.sh "$out" >/dev/null
    pcl=(--pcl "$out/pcl_grid_box_max")
fi
[ -x "$out/venv/bin/python" ] || python3 -m venv "$out/venv"
"$out/venv/bin/pip" install --quiet --disable-pip-version-check "numpy==2.*"
"$out/venv/bin/python" crates/bench/peers/compare.py --pmon target/release/pmon "${pcl[@]}" \
    --python "$out/venv/bin/python" --rounds "${1:-3}" --iterations "${2:-300}" --export "$out/frames"
