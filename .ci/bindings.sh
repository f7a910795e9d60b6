#!/usr/bin/env bash
# Bindings: the C API's static library, the C++17 example built with the system compiler, and its output
# compared with `pmon check --format jsonl` (parsed JSON, record by record) on a simulated recording and, when
# ../shared/data exists, on a converted KITTI extract. The header's freshness is checked by
# `cargo test -p pmon-capi --test header` (part of `cargo test --workspace`).
set -euo pipefail
cd "$(dirname "$0")/.."
start=$(date +%s)
export CARGO_TERM_COLOR=never
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
echo "== bindings: build pmon and the C API"
cargo build --workspace --locked --lib --bins --tests   # with --tests: the feature set of `cargo test`, nothing compiled twice
echo "== bindings: C++ example"
make -C examples/cpp PMON_LIB_DIR="$PWD/target/debug" --always-make
compare() { # name recording
    ./target/debug/pmon check "$2" --format jsonl >"$work/$1.rust.jsonl" || [ $? -eq 1 ]
    # A converted recording carries params.toml (the dataset's ground height and ego footprint), which
    # `pmon check` applies; the C++ example is given the same file.
    if [ -f "$2/params.toml" ]; then
        examples/cpp/pmon_replay "$2" "$2/params.toml" >"$work/$1.cpp.jsonl" || [ $? -eq 1 ]
    else
        examples/cpp/pmon_replay "$2" >"$work/$1.cpp.jsonl" || [ $? -eq 1 ]
    fi
    python3 .ci/compare_jsonl.py "$work/$1.rust.jsonl" "$work/$1.cpp.jsonl"
}
./target/debug/pmon simulate --scenario pedestrians --seed 7 --duration-s 3 --out "$work/sim"
compare simulated "$work/sim"
data="${PMON_DATA_DIR:-../shared/data}"
if [ -d "$data/kitti/object/training" ]; then
    ./target/debug/pmon convert "kitti:$data/kitti/object/training" --out "$work/kitti"
    compare kitti "$work/kitti"
else
    echo "bindings: $data/kitti/object/training not found, real-data comparison skipped"
fi
echo "== bindings: done in $(( $(date +%s) - start )) s"
