"""Which plausibility alarms on a CommonRoad (NGSIM) file sit on the data's own glitches (docs/plausibility.md).

For every state judged by `pmon check FILE --format jsonl`, the recorded speed is compared with the speed of the
recorded positions (mean of the one-step differences before and after it). A state counts as *glitched* when any
of its last six states (the calibrated rule's 0.5 s baseline at 10 Hz) has a recorded speed more than THRESHOLD
m/s off its positions' speed. Prints the alarms on glitched and on self-consistent states. Standard library only.
Reads CommonRoad 2018b (`obstacle` with a `role`) and 2020a (`dynamicObstacle`) files. The same rule is in Rust
(`pmon_datasets::motion::speed_label_glitches`), which `pmon reproduce` uses to judge the clean-track claim.

    pmon check commonroad:USA_Lanker-1_1_T-1.xml --format jsonl [--params cal.toml] > out.jsonl
    python3 ngsim_speed_glitches.py USA_Lanker-1_1_T-1.xml out.jsonl [THRESHOLD, default 2.0]
"""

import json
import math
import sys
import xml.etree.ElementTree as ET


def tracks_of(xml_path):
    root = ET.parse(xml_path).getroot()
    step = float(root.get("timeStepSize", "0.1"))
    tracks = {}
    # 2018b files: <obstacle> with a <role>; 2020a files: <dynamicObstacle>.
    for ob in list(root.iter("obstacle")) + list(root.iter("dynamicObstacle")):
        role = ob.find("role")
        if role is not None and role.text != "dynamic":
            continue
        traj = ob.find("trajectory")
        states = {}
        for st in [ob.find("initialState")] + (list(traj) if traj is not None else []):
            t = int(st.find("time/exact").text)
            states[t] = (
                float(st.find("position/point/x").text),
                float(st.find("position/point/y").text),
                float(st.find("velocity/exact").text),
            )
        tracks[int(ob.get("id"))] = states
    return tracks, step


def speed_gap(states, t, step):
    """|recorded speed - speed of the recorded positions| at step t, or None."""
    if t not in states:
        return None
    w = [
        math.hypot(states[b][0] - states[a][0], states[b][1] - states[a][1]) / step
        for a, b in ((t - 1, t), (t, t + 1))
        if a in states and b in states
    ]
    return abs(states[t][2] - sum(w) / len(w)) if w else None


def main():
    tracks, step = tracks_of(sys.argv[1])
    threshold = float(sys.argv[3]) if len(sys.argv) > 3 else 2.0
    counts = {"glitched": [0, 0], "consistent": [0, 0]}
    for line in open(sys.argv[2]):
        d = json.loads(line)
        if "motion" not in d or d["motion"].startswith("not_monitored"):
            continue
        states = tracks.get(d["id"], {})
        t = int(round(d["timestamp_s"] / step))
        gaps = [speed_gap(states, u, step) for u in range(t - 5, t + 1)]
        glitched = max((g for g in gaps if g is not None), default=0.0) > threshold
        alarm = d["motion"].startswith("implausible")
        c = counts["glitched" if glitched else "consistent"]
        c[0] += 1
        c[1] += int(alarm)
        if alarm and not glitched:
            print("alarm on a self-consistent state:", d["id"], t, d.get("kind"), d.get("error_size"))
    for name, (n, a) in counts.items():
        print(f"{name}: {n} judged states, {a} alarms ({1000.0 * a / max(n, 1):.2f} per mille)")


if __name__ == "__main__":
    main()
