#!/usr/bin/env bash
# Builds fuzz/corpus/<target>/ at run time: the small synthetic seeds committed in fuzz/seeds/, plus files from
# the real data extracts when they are present (PMON_DATA_DIR, default ../shared/data beside the repository).
# The real data is never copied into the repository: fuzz/corpus is ignored by git.
set -euo pipefail
cd "$(dirname "$0")"
data="${PMON_DATA_DIR:-../../shared/data}"
rm -rf corpus
for t in recording kitti nuscenes nuscenes_v1 nuscenes_slice av2_feather commonroad params monitor mcap_bag; do
  mkdir -p "corpus/$t"
  cp seeds/"$t"/* "corpus/$t/" 2>/dev/null || true
done
# Inputs that once crashed a target (fuzz/known/TARGET-what.ext, each with a regression test, docs/fuzzing.md) are
# seeds too, so that every run replays them first.
for f in known/*; do
  t=$(basename "$f"); t=${t%%-*}
  [ -d "corpus/$t" ] && cp "$f" "corpus/$t/"
done
if [ -d "$data" ]; then
  k="$data/kitti/object/training"
  for f in $(ls "$k/label_2" 2>/dev/null | head -5); do cp "$k/label_2/$f" "corpus/kitti/label_$f"; done
  for f in $(ls "$k/calib" 2>/dev/null | head -2); do cp "$k/calib/$f" "corpus/kitti/calib_$f"; done
  [ -f "$data/nuscenes/sample_annotations.json" ] && cp "$data/nuscenes/sample_annotations.json" corpus/nuscenes/real.json
  for log in "$data"/av2/sensor/val/*/; do
    for f in "$log"*.feather "$log"calibration/*.feather; do
      [ -f "$f" ] && cp "$f" "corpus/av2_feather/$(basename "$log")_$(basename "$f")"
    done
  done
  for f in "$data"/commonroad/*.xml; do [ -f "$f" ] && cp "$f" corpus/commonroad/; done
  echo "fuzz corpus: seeds + real extracts from $data"
else
  echo "fuzz corpus: committed seeds only (no real data at $data)"
fi
# An MCAP seed written by pmon itself, when pmon is built: two frames of one car with a 64-point cloud on it,
# converted to a bag (object lists, PointCloud2, tf), small enough for -max_len.
pmon=""
for p in ../target/debug/pmon ../target/release/pmon; do [ -x "$p" ] && pmon="$p" && break; done
if [ -n "$pmon" ]; then
  tmp=$(mktemp -d)
  mkdir -p "$tmp/rec/clouds"
  python3 - "$tmp/rec" <<'PY'
import json, struct, sys
d = sys.argv[1]
pts = [(10.0 + 0.1 * (i % 8) + f, -0.8 + 0.2 * (i // 8), 0.8) for f in (0.0,) for i in range(64)]
with open(d + "/frames.jsonl", "w") as out:
    for f in range(2):
        with open(f"{d}/clouds/{f:06d}.bin", "wb") as c:
            for p in pts:
                c.write(struct.pack("<3f", p[0] + f, p[1], p[2]))
        obj = {"id": 1, "class": "car", "x_m": 11 + f, "y_m": 0, "heading_rad": 0, "speed_mps": 10, "length_m": 4, "width_m": 2}
        cloud = {"file": f"clouds/{f:06d}.bin", "points": len(pts),
                 "ego_from_sensor": {"rotation": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "translation_m": [0, 0, 1.7]}}
        out.write(json.dumps({"frame": f, "timestamp_s": 0.1 * f, "objects": [obj], "cloud": cloud}) + "\n")
PY
  if "$pmon" convert "$tmp/rec/frames.jsonl" --format mcap --out corpus/mcap_bag/two_frames.mcap >/dev/null; then
    echo "fuzz corpus: mcap_bag seeded with a bag written by $pmon"
  else
    echo "fuzz corpus: no MCAP seed (pmon convert failed)"
  fi
  rm -rf "$tmp"
else
  echo "fuzz corpus: no MCAP seed (pmon is not built)"
fi
