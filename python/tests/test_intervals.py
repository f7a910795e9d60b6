"""The intervals clustered by track of `pmon reproduce` (docs/evaluation.md, "Scoring"), recomputed independently
with numpy from the per-track counts it writes beside each figure (`<figure>_tracks.csv`): the Wilson interval with
the effective sample size n / deff (Kish's design effect over tracks), equal to 1e-6 at every point, and never
narrower than the interval over object states."""

import csv
import math
from collections import defaultdict
from statistics import NormalDist

import numpy as np

Z = NormalDist().inv_cdf(0.975)


def read(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def effective_n_wilson(k, n):
    """From the formula: p = sum k / sum n over the m clusters with n_i > 0; V = m/(m-1) sum (k_i - p n_i)^2 / n^2;
    V_srs = p (1-p) / (n-1); deff = max(1, V / V_srs), 1 when p is 0 or 1 or m < 2; Wilson at n_eff = n / deff,
    successes p n_eff. Returns (m, deff, lo, hi)."""
    k, n = np.asarray(k, dtype=float), np.asarray(n, dtype=float)
    k, n = k[n > 0], n[n > 0]
    m, total = len(n), n.sum()
    if total == 0:
        return m, 1.0, math.nan, math.nan
    p = k.sum() / total
    deff = 1.0
    if m >= 2 and 0 < p < 1:
        v = m / (m - 1) * np.sum((k - p * n) ** 2) / total**2
        deff = max(1.0, v / (p * (1 - p) / (total - 1)))
    ne = total / deff
    # Wilson's bounds as the roots of (p - t)^2 = Z^2 t (1 - t) / ne.
    a = 1 + Z**2 / ne
    b = -(2 * p + Z**2 / ne)
    roots = np.roots([a, b, p * p]).real
    return m, deff, max(0.0, roots.min()), min(1.0, roots.max())


def test_the_intervals_by_track_are_the_effective_n_wilson_intervals(reproduce_local):
    figures = sorted(p.name[: -len("_tracks.csv")] for p in reproduce_local.glob("*_tracks.csv"))
    for must in (
        "permanent_position",
        "permanent_position_one",
        "permanent_position_paper",
        "position_direction",
        "position_offset",
    ):
        assert must in figures, figures
    wider = 0
    for fig in figures:
        points = read(reproduce_local / f"{fig}.csv")
        clusters = defaultdict(list)
        for r in read(reproduce_local / f"{fig}_tracks.csv"):
            clusters[(r["curve"], r["x"])].append((int(r["k"]), int(r["n"]), (r["run"], r["track"])))
        keyed = [(p["curve"], p["x"]) for p in points if p["tracks"] != ""]
        assert set(clusters) <= set(keyed), fig  # no clusters without their point
        for p in points:
            clustered = "(verifiable" in p["curve"] or "precision" in p["curve"]
            if fig.startswith("permanent_position"):
                # The recall over verifiable errors and the precision carry it; the recall over all errors not.
                assert (p["tracks"] != "") == clustered, (fig, p)
            if p["tracks"] == "":
                assert p["ci95_tracks_lo"] == p["ci95_tracks_hi"] == "", (fig, p)
                continue
            cl = clusters[(p["curve"], p["x"])]
            ks, ns = [c[0] for c in cl], [c[1] for c in cl]
            assert len({c[2] for c in cl}) == len(cl), (fig, p)  # one row per (run, track)
            assert (sum(ks), sum(ns)) == (int(p["k"]), int(p["n"])), (fig, p)
            m, deff, lo, hi = effective_n_wilson(ks, ns)
            assert m == int(p["tracks"]), (fig, p)
            t_lo, t_hi = float(p["ci95_tracks_lo"]), float(p["ci95_tracks_hi"])
            if int(p["n"]) == 0:
                assert math.isnan(t_lo) and math.isnan(t_hi), (fig, p)
                continue
            assert abs(t_lo - lo) <= 1e-6 and abs(t_hi - hi) <= 1e-6, (fig, p, lo, hi, deff)
            s_lo, s_hi = float(p["ci95_lo"]), float(p["ci95_hi"])
            assert t_lo <= s_lo + 1e-6 and t_hi >= s_hi - 1e-6, (fig, p)
            wider += (t_hi - t_lo) > (s_hi - s_lo) + 0.01
    # Tracks are missed or detected as a whole more often than not: somewhere the clustered interval is wider.
    assert wider > 0
