"""The sensor alarms of `pmon reproduce` by the test that raised them (`<figure>_causes.csv`, docs/evaluation.md),
read back independently against the figures' own counts (`<figure>.csv`): per point, the errors found by each test
add up to the detections of the curve's recall over verifiable errors, the false alarms by test to the false alarms
of its precision curve (the same runs) or to those of the false-alarm curve."""

import csv
from collections import defaultdict

CAUSES = {
    "ghost",
    "displaced_evidence",
    "evidence_followed",
    "jumped_from_evidence",
    "seen_through",
    "face_in_front",
    "returns_beyond",
    "evidence_released",
    "evidence_runs_on",
    "held_while_parked",
    "position_error (no cause)",
}


def read(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def test_alarms_by_test_add_up_to_each_figures_counts(reproduce_local):
    figures = sorted(p.name[: -len("_causes.csv")] for p in reproduce_local.glob("*_causes.csv"))
    # The noise runs' figure appears only when they raised a false alarm (a short run may raise none).
    for must in ("permanent_position", "permanent_position_paper", "position_direction"):
        assert must in figures, figures
    checked_found = checked_false = 0
    for fig in figures:
        points = {(p["curve"], p["x"]): p for p in read(reproduce_local / f"{fig}.csv")}
        found, false = defaultdict(int), defaultdict(int)
        for r in read(reproduce_local / f"{fig}_causes.csv"):
            assert r["cause"] in CAUSES, (fig, r)
            assert int(r["found"]) + int(r["false_alarms"]) > 0, (fig, r)  # only causes that raised an alarm
            key = (r["curve"], r["x"])
            assert key in points, (fig, r)  # a point of the figure
            found[key] += int(r["found"])
            false[key] += int(r["false_alarms"])
        carrying = {curve for curve, _ in found}
        if fig != "false_alarms":
            # The recall over verifiable errors carries its runs' alarms, once per figure.
            assert carrying and all("verifiable" in c for c in carrying), (fig, carrying)
        for (curve, x), p in points.items():
            key = (curve, x)
            if curve not in carrying:
                # A curve that should carry its alarms does, whenever it has some.
                if fig == "false_alarms":
                    should = curve.startswith("sensor checks")
                else:
                    should = "verifiable" in curve and "share" not in curve
                assert not (should and int(p["k"]) > 0), (fig, p)
                continue
            if fig == "false_alarms":
                assert false[key] == int(p["k"]) and found[key] == 0, (fig, p)
                checked_false += int(p["k"])
                continue
            assert found[key] == int(p["k"]), (fig, p)
            checked_found += found[key]
            precision = points.get((curve.replace("sensor recall (verifiable)", "sensor precision"), x))
            if precision is not None and precision["curve"] != curve:
                assert false[key] == int(precision["n"]) - int(precision["k"]), (fig, p, precision)
                checked_false += false[key]
    # The check is about something: errors were found and false alarms raised.
    assert checked_found > 0 and checked_false > 0, (checked_found, checked_false)
