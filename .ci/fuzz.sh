#!/usr/bin/env bash
# Fuzz smoke run (docs/fuzzing.md): every cargo-fuzz target for FUZZ_SECONDS seconds (default 20), built once
# with AddressSanitizer (so oversized allocations and memory errors are caught, the Feather target above all).
# Installs cargo-fuzz if absent; uses RUSTC_BOOTSTRAP=1 so that a stable toolchain can build the targets.
set -euo pipefail
cd "$(dirname "$0")/../fuzz"
export RUSTC_BOOTSTRAP=1 CARGO_TERM_COLOR=never
secs="${FUZZ_SECONDS:-20}"
command -v cargo-fuzz >/dev/null || cargo install cargo-fuzz --locked
start=$(date +%s)
cargo fuzz build --sanitizer address
echo "fuzz: targets built in $(( $(date +%s) - start )) s"
./make_corpus.sh
# FUZZ_SKIP="t1 t2" builds but does not run the named targets (none by default: every target runs; a target with
# an open finding would be listed here and in docs/fuzzing.md, "Open findings").
skip="${FUZZ_SKIP-}"
for t in $(cargo fuzz list); do
  if [[ " $skip " == *" $t "* ]]; then
    echo "fuzz: $t SKIPPED: listed in FUZZ_SKIP"
    continue
  fi
  out=$(cargo fuzz run --sanitizer address "$t" "corpus/$t" -- -max_total_time="$secs" -max_len=65536 \
    -rss_limit_mb=2048 -malloc_limit_mb=1024 -print_final_stats=1 2>&1) || {
    # The panic or sanitizer report (above the tail), then the input itself: CI keeps no artifacts, so the
    # failing input is printed as base64 (`base64 -d > fuzz/known/TARGET-what.ext` reproduces it).
    echo "$out" | grep -m1 -B2 -A12 -E "panicked at|ERROR: (AddressSanitizer|libFuzzer)" || true
    echo "$out" | tail -40
    for a in artifacts/"$t"/*; do
      [ -f "$a" ] && [ "$(stat -c %s "$a")" -le 65536 ] && { echo "fuzz: input $a as base64:"; base64 -w 0 "$a"; echo; }
    done
    echo "fuzz: $t FAILED"; exit 1; }
  echo "fuzz: $t: $(echo "$out" | grep -o 'stat::number_of_executed_units: [0-9]*' | grep -o '[0-9]*$') executions in $secs s"
done
echo "fuzz: done in $(( $(date +%s) - start )) s"
