#!/usr/bin/env bash
# Bindings: the C API's static library, the C++17 example built with the system compiler, and its output
# compared with `pmon check --format jsonl` (parsed JSON, record by record) on a simulated recording (with the
# defaults and with `profile:recall`) and, when
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
# A parameter profile by name, through pmon_monitor_new_from_file (the simulated recording has no params.toml; it
# is clean, so this checks the load by name: python/tests/test_same_as_cli.py compares the profile's verdicts on a
# displaced recording).
test ! -f "$work/sim/params.toml"
./target/debug/pmon check "$work/sim" --format jsonl --params profile:recall >"$work/recall.rust.jsonl" || [ $? -eq 1 ]
examples/cpp/pmon_replay "$work/sim" profile:recall >"$work/recall.cpp.jsonl" || [ $? -eq 1 ]
python3 .ci/compare_jsonl.py "$work/recall.rust.jsonl" "$work/recall.cpp.jsonl"
data="${PMON_DATA_DIR:-../shared/data}"
if [ -d "$data/kitti/object/training" ]; then
    ./target/debug/pmon convert "kitti:$data/kitti/object/training" --out "$work/kitti"
    compare kitti "$work/kitti"
else
    echo "bindings: $data/kitti/object/training not found, real-data comparison skipped"
fi
echo "== bindings: done in $(( $(date +%s) - start )) s"
