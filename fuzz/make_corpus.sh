#!/usr/bin/env bash
# Builds fuzz/corpus/<target>/ at run time: the small synthetic seeds committed in fuzz/seeds/, plus files from
# the real data extracts when they are present (PMON_DATA_DIR, default ../shared/data beside the repository).
# The real data is never copied into the repository: fuzz/corpus is ignored by git.
set -euo pipefail
cd "$(dirname "$0")"
data="${PMON_DATA_DIR:-../../shared/data}"
rm -rf corpus
for t in recording kitti nuscenes nuscenes_v1 av2_feather commonroad params monitor; do
  mkdir -p "corpus/$t"
  cp seeds/"$t"/* "corpus/$t/" 2>/dev/null || true
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
