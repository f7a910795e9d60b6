#!/usr/bin/env bash
# Opt-in (issue #16; NOT part of CI): installs Debian's libpcl-dev (about 1.3 GB with --no-install-recommends,
# 400+ packages, as root) when it is missing, and builds the PCL peer of `pmon bench` into OUT
# (default: <workspace>/target/peers/pcl_grid_box_max).
#
# -march=native with -DEIGEN_MAX_ALIGN_BYTES=16 -DEIGEN_MALLOC_ALREADY_ALIGNED=1: Debian's PCL is built for the
# baseline; code built with wider vectors must keep Eigen's alignment of that build, or it crashes freeing clouds
# allocated by the library. -ffp-contract=off: no fused multiply-adds, so the cell and box tests compute pmon's
# bits and the per-box maxima can be compared exactly.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
out="${1:-$here/../../../target/peers}"
if ! dpkg -s libpcl-dev >/dev/null 2>&1; then
    echo "== installing libpcl-dev (about 1.3 GB)"
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends libpcl-dev g++ >/dev/null
fi
inc=$(ls -d /usr/include/pcl-1.* | sort -V | tail -1)
mkdir -p "$out"
g++ -std=c++17 -O3 -march=native -ffp-contract=off -DEIGEN_MAX_ALIGN_BYTES=16 -DEIGEN_MALLOC_ALREADY_ALIGNED=1 \
    -I"$inc" -I/usr/include/eigen3 "$here/pcl_grid_box_max.cpp" -o "$out/pcl_grid_box_max" \
    -lpcl_common -lpcl_filters
echo "$out/pcl_grid_box_max"
