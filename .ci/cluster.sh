#!/usr/bin/env bash
# CI part (docs/campaigns.md, "Several hosts"): `pmon evaluate` on a Dask cluster of three hosts, each in its own
# network namespace (its own network stack, address and host name), joined by a bridge: the scheduler on
# 10.77.0.1 and two workers on 10.77.0.2 and .3, started with Dask's own `dask scheduler` / `dask worker`
# commands, each task sent over TCP. The workers cannot see the driver's run folder, nor the dataset's tables (a
# private tmpfs is mounted over each in their mount namespaces; the table folder then holds an empty sample.json,
# which no reader could parse): each task brings its scene's slice of the tables over the network, and a worker
# reads only the sweeps. Halfway through the run one worker host is taken down (every process in its namespace
# killed). The report must equal `--scheduler local`'s byte for byte (results.json and every CSV).
#
# One kernel and one file system underneath: this tests what crosses a network (addresses, TCP, a host lost),
# not speed. Needs root and iproute2; skipped with a message where network namespaces cannot be made.
# Uses the venv and wheel of .ci/python.sh (run it first). About 1 minute.
set -euo pipefail
cd "$(dirname "$0")/.."
venv="${PMON_PY_VENV:-target/py-venv}"
py="$PWD/$venv/bin/python"
pmon="$PWD/target/debug/pmon"
start=$(date +%s)
if ! command -v ip >/dev/null || ! ip netns add pmon-ci-probe 2>/dev/null; then
    echo "== cluster: SKIPPED: cannot make network namespaces here (needs root and iproute2)"
    exit 0
fi
ip netns del pmon-ci-probe
if ! unshare --uts --mount --propagation private true 2>/dev/null || ! command -v nsenter >/dev/null; then
    echo "== cluster: SKIPPED: cannot make UTS and mount namespaces here (needs util-linux's unshare and nsenter)"
    exit 0
fi
hosts=(sched w1 w2)
down() {   # the hosts and the bridge, from this run or one that was cut short
    for h in "${hosts[@]}"; do
        for pid in $(ip netns pids "pmon-$h" 2>/dev/null); do kill -9 "$pid" 2>/dev/null || true; done
        ip netns del "pmon-$h" 2>/dev/null || true
        ip link del "veth-$h" 2>/dev/null || true   # gone with its namespace, but not always at once
    done
    ip link del pmonbr0 2>/dev/null || true
}
down
work=$(mktemp -d /tmp/pmon-cluster.XXXXXX)
trap 'down; rm -rf "$work"' EXIT

echo "== cluster: three hosts on a bridge"
ip link add pmonbr0 type bridge
ip addr add 10.77.0.254/24 dev pmonbr0
ip link set pmonbr0 up
for i in 0 1 2; do
    h=${hosts[$i]}
    ip netns add "pmon-$h"
    ip link add "veth-$h" type veth peer name eth0 netns "pmon-$h"
    ip link set "veth-$h" master pmonbr0 up
    ip netns exec "pmon-$h" ip addr add "10.77.0.$((i + 1))/24" dev eth0
    ip netns exec "pmon-$h" ip link set eth0 up
    ip netns exec "pmon-$h" ip link set lo up
done

echo "== cluster: the data (generated nuScenes v1.0 tables and sweeps: 6 scenes, 12 tasks)"
"$py" python/benchmarks/nuscenes_tables.py "$work/nus" --scenes 6 --samples 10 --annotations 20 --instances 12 \
    --points 20000
mkdir -p "$work/driver"   # the driver's folder: hidden from the workers
src="nuscenes:$work/nus"

echo "== cluster: the local run"
"$pmon" evaluate "$src" --smoke --seed 5 --out "$work/driver/local" --threads 1 -q

echo "== cluster: scheduler and workers"
# RAYON_NUM_THREADS=1: one core per worker, as docs/campaigns.md advises.
ip netns exec pmon-sched unshare --uts sh -c "hostname sched; exec '$venv/bin/dask' scheduler --host 10.77.0.1 \
    --port 8786 --no-dashboard" >"$work/sched.log" 2>&1 &
disown   # no job-control notice when the hosts are taken down
for i in 1 2; do
    ip netns exec "pmon-w$i" unshare --uts --mount --propagation private sh -c "hostname worker-$i; \
        mount -t tmpfs tmpfs '$work/driver'; \
        mount -t tmpfs tmpfs '$work/nus/v1.0-synthetic'; : > '$work/nus/v1.0-synthetic/sample.json'; \
        RAYON_NUM_THREADS=1 exec '$venv/bin/dask' worker tcp://10.77.0.1:8786 --host 10.77.0.$((i + 1)) \
        --nthreads 1 --nworkers 1 --no-nanny --no-dashboard" >"$work/w$i.log" 2>&1 &
    disown
done
"$py" - <<'EOF' || { tail -20 "$work"/sched.log "$work"/w1.log "$work"/w2.log; exit 1; }
import sys, time
from dask.distributed import Client
t0 = time.time()
with Client("tcp://10.77.0.1:8786", timeout=60) as c:
    c.wait_for_workers(2, timeout=60)
    print("   workers:", sorted(c.run(lambda: __import__("socket").gethostname()).values()), file=sys.stderr)
EOF

for i in 1 2; do   # the driver's folder (with the local run in it) is empty for the workers
    pid=$(ip netns pids "pmon-w$i" | head -1)
    [ -z "$(nsenter -t "$pid" -m -- ls -A "$work/driver")" ] || { echo "worker-$i sees the driver's folder"; exit 1; }
done
echo "   the workers see an empty $work/driver (the driver's: $(ls "$work/driver" | tr '\n' ' '))"
echo "== cluster: pmon evaluate --scheduler dask://10.77.0.1:8786, worker-2's host taken down mid-task"
# After 3 results, as soon as worker-2 is running a task: every process of its namespace killed.
RESULTS="$work/driver/cl.run/results" "$py" - <<'EOF' &
import os, subprocess, sys, time
from dask.distributed import Client
results = os.environ["RESULTS"]
with Client("tcp://10.77.0.1:8786", timeout=60) as c:
    while True:
        done = len([f for f in os.listdir(results) if f.endswith(".json")]) if os.path.isdir(results) else 0
        busy = [t for w, t in c.processing().items() if w.startswith("tcp://10.77.0.3:") and t]
        if done >= 3 and busy:
            break
        time.sleep(0.05)
    for pid in subprocess.run(["ip", "netns", "pids", "pmon-w2"], capture_output=True, text=True).stdout.split():
        subprocess.run(["kill", "-9", pid])
    print(f"   worker-2's host taken down after {done} results, with {len(busy[0])} task(s) assigned to it", file=sys.stderr)
EOF
killer=$!
"$pmon" evaluate "$src" --smoke --seed 5 --out "$work/driver/cl" --python "$py" \
    --scheduler dask://10.77.0.1:8786 2>"$work/cl.log" || { cat "$work/cl.log"; exit 1; }
wait "$killer"
grep -oE '^\[[0-9]+/[0-9]+\] [^ ]+ on [a-z0-9-]+' "$work/cl.log" | awk '{print $NF}' | sort | uniq -c \
    | awk '{printf "   %s tasks finished on %s\n", $1, $2}'
grep -iE "remove worker|lost" "$work/sched.log" | sed 's/^/   scheduler: /' | head -3
grep -q "on worker-1:" "$work/cl.log" || { echo "no task ran on worker-1"; exit 1; }
grep -q "on worker-2:" "$work/cl.log" || { echo "no task ran on worker-2"; exit 1; }
n=0
for f in "$work/driver/local/results.json" "$work/driver/local"/*.csv; do
    cmp "$f" "$work/driver/cl/$(basename "$f")"
    n=$((n + 1))
done
echo "== cluster: $n report files byte-identical to the local run ($(( $(date +%s) - start )) s)"
