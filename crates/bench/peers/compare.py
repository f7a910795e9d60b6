#!/usr/bin/env python3
"""pmon beside its peers, side by side in one run (issue #16): alternates `pmon bench`, the PCL peer and the numpy
peer on the same frames, round after round, and prints the medians and their ratios.

Per round and case it runs, one process after the other: `pmon bench --json --only CASE` (pmon's sensor checks,
its matching stages rasterize + regions, and the native floor), the PCL peer and the numpy peer (each times its
grid-plus-box-max pipeline on the frames exported by `pmon bench --export-peers` and checks its per-box maxima
against pmon's). Standard library only; the numpy peer runs under --python.

    compare.py --pmon target/release/pmon --pcl target/peers/pcl_grid_box_max --python target/peers/venv/bin/python
               [--rounds 3] [--iterations 300] [--export target/peers/frames] [--case kitti/0.5m ...]
               [--pmon-arg=--kitti-whole-grid ...]

Exit status 1 when a peer's per-box maxima differ from pmon's. `run.sh` beside this file builds everything.
"""

import argparse
import json
import statistics
import subprocess
import sys
from pathlib import Path

DEFAULT_CASES = ["synthetic-64/0.5m", "kitti/0.5m", "av2/0.5m", "nuscenes/0.5m", "synthetic-32/0.5m"]


def peer(cmd):
    out = subprocess.run(cmd, capture_output=True, text=True)
    line = out.stdout.strip().splitlines()[-1] if out.stdout.strip() else ""
    fields = dict(kv.split("=", 1) for kv in line.split() if "=" in kv)
    if "median_us" not in fields:
        sys.exit(f"{' '.join(map(str, cmd))} failed ({out.returncode}):\n{out.stdout}{out.stderr}")
    a, b = fields["agree"].split("/")
    return float(fields["median_us"]), float(fields["p99_us"]), int(a) == int(b), fields["agree"]


def pmon(binary, case, iterations, extra=()):
    out = subprocess.run(
        [binary, "bench", "--json", "--only", case, "--iterations", str(iterations), "--max-seconds-per-case", "10"]
        + list(extra),
        capture_output=True,
        text=True,
        check=True,
    )
    report = json.loads(out.stdout)
    c = next(c for c in report["cases"] if c["name"] == case)
    stage = {s["stage"]: s["timing"]["median_us"] for s in c["stages"]}
    return {
        "sensor": c["sensor_checks"]["median_us"],
        "p99": c["sensor_checks"].get("p99_us", 0.0),
        "matching": stage["rasterize"] + stage["regions"],
        "native": (c.get("native_floor") or {}).get("median_us", float("nan")),
        "load": report["machine"].get("load_average_1min"),
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--pmon", required=True)
    ap.add_argument("--pcl", help="the PCL peer binary (build_pcl.sh); left out when not given")
    ap.add_argument("--python", help="a Python with numpy for the numpy peer; left out when not given")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--iterations", type=int, default=300)
    ap.add_argument("--export", default="target/peers/frames")
    ap.add_argument("--case", action="append", help="a case of pmon bench (repeatable); default: all 0.5 m sweeps")
    ap.add_argument(
        "--pmon-arg",
        action="append",
        default=[],
        help="a further argument of the timed `pmon bench` runs (repeatable), e.g. --pmon-arg=--kitti-whole-grid",
    )
    args = ap.parse_args()
    here = Path(__file__).resolve().parent
    export = Path(args.export)
    only = args.case or DEFAULT_CASES
    cmd = [args.pmon, "bench", "--export-peers", str(export)] + [x for c in only for x in ("--only", c)]
    listing = subprocess.run(cmd, capture_output=True, text=True, check=True).stdout
    cases = [line.split("\t")[0] for line in listing.splitlines() if line.strip()]
    print(f"frames exported to {export}: {', '.join(cases)}")
    rows = {c: [] for c in cases}
    ok = True
    for r in range(1, args.rounds + 1):
        for case in cases:
            d = export / case.replace("/", "_")
            row = pmon(args.pmon, case, args.iterations, args.pmon_arg)
            if args.pcl:
                row["pcl"], row["pcl_p99"], agree, row["pcl_agree"] = peer([args.pcl, str(d), str(args.iterations)])
                ok &= agree
            if args.python:
                script = str(here / "numpy_grid_box_max.py")
                row["numpy"], _, agree, row["numpy_agree"] = peer([args.python, script, str(d), str(args.iterations)])
                ok &= agree
            rows[case].append(row)
            print(f"round {r} {case}: " + ", ".join(f"{k}={v:.1f}" if isinstance(v, float) else f"{k}={v}"
                                                    for k, v in row.items()), flush=True)

    def ratio(a, b):
        return f"{a / b:.2f}" if b and b == b else "-"

    print("\nMedians per round (us) and ratios; sensor = pmon's full sensor checks, matching = its rasterize +"
          " regions stages, native = the native floor; pcl/numpy = the peers' grid + box-max pipeline")
    head = ["case", "round", "sensor", "p99", "matching", "native", "pcl", "numpy",
            "sensor/pcl", "matching/pcl", "numpy/sensor", "sensor/native"]
    print(" | ".join(head))
    for case, rs in rows.items():
        for k, x in enumerate(rs, 1):
            pcl, npy = x.get("pcl", float("nan")), x.get("numpy", float("nan"))
            print(" | ".join([case, str(k), f"{x['sensor']:.1f}", f"{x['p99']:.1f}", f"{x['matching']:.1f}",
                              f"{x['native']:.2f}", f"{pcl:.1f}", f"{npy:.1f}", ratio(x["sensor"], pcl),
                              ratio(x["matching"], pcl), ratio(npy, x["sensor"]), ratio(x["sensor"], x["native"])]))
    print("\nMedian over rounds of each round's ratio")
    for case, rs in rows.items():
        def med(f):
            vals = [v for v in (f(x) for x in rs) if v == v]
            return f"{statistics.median(vals):.2f}" if vals else "-"
        nan = float("nan")
        print(f"{case}: sensor/pcl {med(lambda x: x['sensor'] / x.get('pcl', nan))}, "
              f"matching/pcl {med(lambda x: x['matching'] / x.get('pcl', nan))}, "
              f"numpy/sensor {med(lambda x: x.get('numpy', nan) / x['sensor'])}, "
              f"sensor/native {med(lambda x: x['sensor'] / x['native'])}; agreement: "
              + ", ".join(sorted({x.get('pcl_agree', '-') + ' (pcl) ' + x.get('numpy_agree', '-') + ' (numpy)'
                                  for x in rs})))
    if not ok:
        print("A PEER DISAGREES WITH PMON'S PER-BOX MAXIMA", file=sys.stderr)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
