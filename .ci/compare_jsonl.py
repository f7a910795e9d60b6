#!/usr/bin/env python3
"""Compares two JSON-lines outputs record by record (parsed values, not bytes): same records, same order,
same keys, equal values. Numbers are compared as parsed floats, so `1.0` and `1` are equal but any other
difference is reported. Exit 0 when equal, 1 with the first differences otherwise."""
import json
import sys


def load(path):
    # `pmon check` ends with a totals record (`"record": "totals"`); the per-object, missed-object and outside_roi
    # records are what both sides must agree on.
    with open(path, encoding="utf-8") as f:
        records = [json.loads(line) for line in f if line.strip()]
    return [r for r in records if r.get("record") != "totals"]


def main():
    a_path, b_path = sys.argv[1], sys.argv[2]
    a, b = load(a_path), load(b_path)
    if not a:
        print(f"{a_path}: no records, nothing compared", file=sys.stderr)
        return 1
    diffs = []
    if len(a) != len(b):
        diffs.append(f"{len(a)} records in {a_path}, {len(b)} in {b_path}")
    for i, (ra, rb) in enumerate(zip(a, b)):
        if ra != rb:
            keys = sorted(set(ra) | set(rb))
            bad = [k for k in keys if ra.get(k) != rb.get(k)]
            diffs.append(f"record {i + 1}: {', '.join(f'{k}: {ra.get(k)!r} vs {rb.get(k)!r}' for k in bad)}")
    if diffs:
        print("\n".join(diffs[:20]), file=sys.stderr)
        return 1
    print(f"{len(a)} records identical ({a_path} vs {b_path})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
