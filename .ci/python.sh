#!/usr/bin/env bash
# CI part for the Python package (docs/python.md): a venv under target/ with maturin, numpy, pytest and pandas
# (pinned major versions), the abi3 wheel built by maturin from python/pyproject.toml, installed into the venv,
# and the pytest suite (python/tests: bad input, the same records as `pmon check --format jsonl` on a simulated
# recording and on KITTI when ../shared/data exists; pmon.campaign in-process vs. a 2-worker Dask LocalCluster,
# byte for byte, also with a worker killed; pmon evaluate over recordings with --scheduler local vs. dask://, resumed;
# pmon reproduce --quick's simulated runs as tasks on dask:// vs. the single-process run, byte for byte;
# Ray when PMON_PY_RAY=1). Called from .ci/run.
# The wheel is built with the workspace's dev profile into the workspace's target/: the pmon crates compiled by
# the test stage are reused; only the pyo3 crates and the extension are compiled again (maturin sets
# PYO3_BUILD_EXTENSION_MODULE and the interpreter, which pyo3's build script depends on). About 30 s.
set -euo pipefail
cd "$(dirname "$0")/.."
start=$(date +%s)
export CARGO_TERM_COLOR=never
venv="${PMON_PY_VENV:-target/py-venv}"
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
fi
"$venv/bin/pip" install --quiet --disable-pip-version-check "maturin==1.*" "numpy==2.*" "pytest==9.*" "pandas==2.*" \
    "dask[distributed]==2026.*" "tqdm==4.*"   # pmon.campaign, pmon evaluate and reproduce on a LocalCluster, the progress bar (docs/campaigns.md)
# Ray is optional: its test is skipped with a message unless PMON_PY_RAY=1 installs it (docs/campaigns.md).
if [ "${PMON_PY_RAY:-0}" = 1 ]; then
    "$venv/bin/pip" install --quiet --disable-pip-version-check "ray==2.*"
fi
echo "== python: the pmon command (the oracle of the comparisons)"
cargo build --workspace --locked --lib --bins --tests   # with --tests: the feature set of `cargo test`, nothing compiled twice
echo "== python: build the wheel (maturin, dev profile) and install it"
wheels="target/py-wheels"
rm -rf "$wheels"
(cd python && "../$venv/bin/maturin" build --profile dev --locked --out "../$wheels")
"$venv/bin/pip" install --quiet --disable-pip-version-check --force-reinstall --no-deps "$wheels"/pmon-*.whl
echo "== python: pytest"
# From python/tests, not python/: there the source folder pmon/ (without the compiled module) would shadow the
# installed package.
(cd python/tests && PMON_BIN="$PWD/../../target/debug/pmon" "../../$venv/bin/python" -m pytest -q -rs -p no:cacheprovider)
echo "== python.sh took $(( $(date +%s) - start )) s"
