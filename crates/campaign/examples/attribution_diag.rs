//! Counts the sensor checks' misses and false alarms by cause on the `pmon reproduce` runs (a development aid
//! for the evidence attribution, docs/attribution.md):
//!
//! `cargo run --release -p pmon-campaign --example attribution_diag -- SEED [summary|causes] [FILTER]`
//!
//! `summary` runs the quick plan's sensor runs (false alarms up to 0.3 m noise, permanent errors under paper
//! and hard conditions, towards the ego) with the same seeds as `pmon reproduce --quick --seed SEED` and prints
//! their curves; `causes` also breaks every false alarm and every verifiable miss down by cause. `FILTER`
//! keeps only the runs whose curve label contains it (for example `towards` or `paper`). With `SEEN_OVER=1` the
//! monitor runs with the params key `seen_over` on (`FACE=1`: `face_in_front`; `JUMP=1`: `jump_from_returns`; `BODY=1`: `seen_body`; `MEMGATE=1`: `memory_gate`; `FOLLOWGATE=1`: `follow_gate`; `NOBODY=1` / `NOFOLLOWGATE=1` turn those two defaults off; `SHADOWGATE=1`: `shadow_gate`; `FRONT=1`: `front_cluster`, `NOFRONT=1` turns it off; `NOSPILLFRONT=1` turns `spill_in_front` off; `NONEARSIDE=1` `spill_near_side`; `STRETCH=1`: `spill_least_stretch` on; `FIRST=1`: `jump_first_return`; `BEYOND=N`: `returns_beyond_cells = N`; the jump keys are the default since issue #10:
//! `NOJUMP=1` turns both off, `NOFIRST=1` only `jump_first_return`; `NOPRED=1` turns `jump_evidence_at_prediction` off,
//! `NOCOINC=1` `jump_coincident_boxes`, `NOJUMPED=1` `jump_jumped_boxes`; `OWNERFIT=1`: `follow_owner_fit`; `NORELEASE=1` turns `release_flagged_claims` off, the default since issue #10's round "Claims a flagged neighbour releases"; `RELCONF=1`: `release_to_confirmed`; `NORUNSON=1` turns `evidence_runs_on` off, the default since issue #10's round "Evidence in the margin that runs on"; `NOSIDE=1` turns `seen_through_near_side` off, the default since the round "The near side seen through"; `SPILLGAP=M`: `spill_gap_m = M`; `CELL=S`: every chosen run with cells of S metres). With `FULL=1` the runs are those of the full plan
//! (`pmon reproduce --seed SEED` without `--quick`: `Scale::Full` and the scenes' own lengths, the same runs,
//! scenes and injection seeds). With `CORRELATED=1` the false alarms under correlated noise up to 0.3 m are
//! counted too, and each noise model's total is printed. `DETAIL=1` lists each false alarm (with `SEEN_OVER=1`
//! also the free-space test's walk over the occluder, traced from the outside); `MISSES=1` lists each verifiable
//! miss, and `TRACE=1` with `SEEN_OVER=1` adds that trace to each. `TRANSIENT=1` adds the transient random
//! position errors (`random_position_*`: sensor recall over every injected error and the combined precision).
//! `HELD=1` adds, per row and summed per curve, the false alarms on clean object states by the length of the
//! streak of consecutive flagged frames they belong to, and how many of those streaks began with a foreign cluster
//! (a memory cascade when the streak is long). `DRIFT=1` prints how far the offset from a flagged box to the cluster it
//! took wanders from the first frame of its run of alarms, for true errors and for clean tracks whose run began with a
//! foreign cluster (world, ego and line-of-sight axes; errors of `DRIFT_MIN` metres or more, 0.8 unless told; with
//! `TRACK=ID` one line per frame of that track), when the runs began (frames since the track was last confirmed), and
//! how often the cluster continues a consistent neighbour's evidence; docs/attribution.md, "The drift of a remembered
//! offset". `IDENT=1` counts, for the same two kinds of alarm frames, whose evidence the cells of the cluster taken
//! were in the previous frame (cluster identity over frames; `IDENT_DILATE=1`: a cell nobody had takes a labelled
//! 8-neighbour's owner; `TRACK=ID` prints the track's frames); docs/attribution.md, "Cluster identity over frames".
//! `MISSRUN=1` sorts each verifiable miss (and each error found) by the track's alarms before it in the run: in the
//! previous frame, earlier only, never (docs/attribution.md, "Misses by the track's alarms before them"). `HOLDSIM=H`
//! estimates, after the fact and without changing the monitor, a hold for static vehicles: a track reported at least 3
//! m long and slower than 0.5 m/s whose alarms ran for two or more consecutive frames counts as flagged for H frames
//! after the run's last alarm; it prints the verifiable errors, those found with and without the hold, and the alarms
//! and true alarms with and without it (`HOLDFRESH=1`: only alarms from the frame's own evidence, a cluster or free
//! space, make a run; `HOLDAWAY=M`: only a run whose last alarm put the evidence in front of the box on its line of
//! sight, less than M metres from it; each held state is also counted by that alarm's features, the `HOLDFEAT` lines;
//! docs/attribution.md, "Parked cars in a row"). `HOLD=S` runs with the params key `memory_hold_s =
//! S` (docs/attribution.md, "Step 8 held over a gap"). `MAP=1` (with
//! `MISSES=1` or `DETAIL=1`) draws the cells around each listed box; `OWNERS=1` counts each verifiable miss by whose
//! the occupied cells under its true footprint went to (docs/attribution.md, "Where a displaced box's evidence goes");
//! `FAKIND=1` counts each false alarm by whether the box is confirmed by its own evidence in the faulted frame and by
//! how far its offset reaches. `BYCAUSE=1` counts every alarm, on injected errors and false, by the test that found it
//! (the verdict's `position_cause`, or a ghost; docs/cli.md), and each alarm on an injected error also by whether it
//! is reported on the object's own evidence (`metrics::reported_displacement_agrees`) and by whether the object is
//! confirmed by its own evidence in the clean twin of the frame (`clean-confirmed 1`: a verifiable error).
use std::collections::BTreeMap;

use pmon_campaign::experiments::{self, Measure, PlannedRun, Scale, SceneIds};
use pmon_campaign::{run_one, Scene};
use pmon_monitor::{Monitor, MonitorParams, SensorVerdict};
use pmon_scenario::Simulator;
use rayon::prelude::*;

/// The scenes of `pmon reproduce` (`--quick` unless `full`) that the sensor runs use, with the lengths of
/// `pmon_campaign::sim_tasks::scene_specs` (the same configuration as `crates/cli/src/reproduce.rs`), and empty
/// stand-ins for the others so that the plan's indices hold.
fn scenes(seed: u64, full: bool) -> Result<Vec<Scene>, Box<dyn std::error::Error>> {
    let mut out = Vec::new();
    for spec in pmon_campaign::sim_tasks::scene_specs(!full, seed, None)? {
        let name = spec.name.as_str();
        // The intersection is simulated for the transient errors only (`TRANSIENT=1`).
        let skip_intersection = std::env::var_os("TRANSIENT").is_none();
        if (name == "intersection" && skip_intersection) || name == "pedestrians_20hz" {
            out.push(Scene { name: name.into(), source: String::new(), frames: Vec::new() });
            continue;
        }
        let cfg = pmon_campaign::sim_tasks::scenario_config(name, spec.seed, Some(spec.duration_s))?;
        let mut sim = Simulator::new(&cfg).map_err(|e| format!("{name}: {e}"))?;
        let mut frames = Vec::new();
        while let Some(f) = sim.step() {
            frames.push(f.frame);
        }
        out.push(Scene { name: name.into(), source: String::new(), frames });
    }
    Ok(out)
}

/// The sensor runs of the plan worth watching (`correlated`: the false alarms under correlated noise too).
fn wanted(run: &PlannedRun, correlated: bool) -> bool {
    run.probes.iter().any(|p| {
        (p.figure == "false_alarms"
            && (p.curve == "sensor checks, white noise"
                || (correlated && p.curve == "sensor checks, correlated noise"))
            && p.x <= 0.3 + 1e-9)
            || ((p.figure == "permanent_position" || p.figure == "permanent_position_paper")
                && p.measure == Measure::SensorRecallVerifiable)
            || (p.figure == "position_direction" && p.curve.starts_with("towards"))
            || (std::env::var_os("TRANSIENT").is_some()
                && p.figure.starts_with("random_position_")
                && p.measure == Measure::SensorRecall)
    })
}

fn label(run: &PlannedRun) -> String {
    run.probes.iter().find(|p| p.measure != Measure::PlausibilityRecall).map_or(String::new(), |p| {
        // The full plan's noise steps are 0.05 m: two decimals there (the quick plan's output unchanged).
        let digits = if std::env::var_os("FULL").is_some() { 2 } else { 1 };
        format!("{} / {} @ {:.digits$}", p.figure, p.curve, p.x)
    })
}

/// Corners of an object's true footprint.
fn corners(o: &pmon_monitor::ObjectState) -> [[f32; 2]; 4] {
    let (s, c) = o.heading_rad.sin_cos();
    let (hl, hw) = (0.5 * o.length_m, 0.5 * o.width_m);
    [(hl, hw), (-hl, hw), (-hl, -hw), (hl, -hw)].map(|(u, v)| [o.x_m + u * c - v * s, o.y_m + u * s + v * c])
}

/// Distance from a point to a footprint (0 inside).
fn rect_distance(o: &pmon_monitor::ObjectState, p: [f32; 2]) -> f32 {
    let (s, c) = o.heading_rad.sin_cos();
    let (dx, dy) = (p[0] - o.x_m, p[1] - o.y_m);
    let (u, v) = (dx * c + dy * s, -dx * s + dy * c);
    let (eu, ev) = ((u.abs() - 0.5 * o.length_m).max(0.0), (v.abs() - 0.5 * o.width_m).max(0.0));
    eu.hypot(ev)
}

/// Footprint-to-footprint distance from object `i` to its nearest other object (true places; 0 when they
/// overlap; corner-based, exact for convex boxes that do not cross).
fn nearest_gap(objects: &[pmon_monitor::ObjectState], i: usize) -> f32 {
    let Some(a) = objects.get(i) else { return f32::INFINITY };
    let mut best = f32::INFINITY;
    for (j, b) in objects.iter().enumerate() {
        if j == i || (a.x_m - b.x_m).hypot(a.y_m - b.y_m) > 10.0 {
            continue;
        }
        let d1 = corners(a).iter().map(|&p| rect_distance(b, p)).fold(f32::INFINITY, f32::min);
        let d2 = corners(b).iter().map(|&p| rect_distance(a, p)).fold(f32::INFINITY, f32::min);
        best = best.min(d1.min(d2));
    }
    best
}

/// The geometry of a false alarm (`DETAIL=1`): the noise draw in the box's axes and along the ray against the
/// margins, the free-space test's 3 x 3 sample points (clearance to the nearest obstacle of their direction and
/// where that obstacle lies: in the true footprint, in the grown region), and what the sensor saw of the true
/// place and of the noisy box.
fn explain_false_alarm(
    monitor: &Monitor,
    truth: &pmon_monitor::ObjectState,
    o: &pmon_monitor::ObjectState,
    g: &pmon_monitor::Region,
    run_label: &str,
) -> String {
    use pmon_monitor::visibility::Sight;
    let mut out = String::new();
    let (s, c) = o.heading_rad.sin_cos();
    let (nx, ny) = (o.x_m - truth.x_m, o.y_m - truth.y_m);
    let (nu, nv) = (nx * c + ny * s, -nx * s + ny * c);
    let r = truth.x_m.hypot(truth.y_m).max(1e-3);
    let (rx, ry) = (truth.x_m / r, truth.y_m / r);
    let (radial, tangential) = (nx * rx + ny * ry, -nx * ry + ny * rx);
    out += &format!(
        "   run {run_label}: noise (along, across) ({nu:+.2}, {nv:+.2}) m vs margins ({:.2}, {:.2}) = ({:.2}, {:.2}) x margin; radial {radial:+.2} (+: away) tangential {tangential:+.2}\n",
        g.margin_length_m,
        g.margin_width_m,
        nu.abs() / g.margin_length_m,
        nv.abs() / g.margin_width_m
    );
    let geo = monitor.grid().geometry;
    let vis = monitor.visibility();
    let fp = &g.footprint;
    let margin = g.margin_length_m.max(g.margin_width_m);
    let mut front = f32::INFINITY;
    vis.nearest_obstacles_across(&g.grown.corners(), |r, cell, _| {
        let (cx, cy) = geo.cell_center(cell);
        if g.grown.contains(cx, cy) {
            front = front.min(r);
        }
    });
    let mut pts = Vec::new();
    for u in [-0.6f32, 0.0, 0.6] {
        for v in [-0.6f32, 0.0, 0.6] {
            let (lu, lv) = (u * fp.half_length, v * fp.half_width);
            let (x, y) = (fp.cx + lu * fp.cos - lv * fp.sin, fp.cy + lu * fp.sin + lv * fp.cos);
            let text = match vis.clearance(x, y) {
                None => format!("{:?}", vis.sight(x, y)).chars().take(8).collect(),
                Some((cl, cell)) => {
                    let (cx, cy) = geo.cell_center(cell);
                    // With `seen_body`: how far the ray ends beyond the body's reach (the box's depth along the
                    // ray past the nearest return in the grown region's directions whose cell lies in the region).
                    let (dx, dy) = (x - vis.origin()[0], y - vis.origin()[1]);
                    let rr = dx.hypot(dy);
                    let depth = 2.0
                        * (fp.half_length * ((dx * fp.cos + dy * fp.sin) / rr).abs()
                            + fp.half_width * ((dy * fp.cos - dx * fp.sin) / rr).abs());
                    let beyond = rr + cl - depth - front;
                    format!(
                        "cl {cl:.2}{} beyond-body {beyond:+.2} obst@truth {:.2} in-grown {} hits {}",
                        if cl > margin { "*" } else { "" },
                        rect_distance(truth, [cx, cy]),
                        u8::from(g.grown.contains(cx, cy)),
                        monitor.grid().hits(cell)
                    )
                }
            };
            pts.push(text);
        }
    }
    out += &format!("   free-space points (margin {margin:.2}, * = free): {}\n", pts.join(" | "));
    let sight_of = |cx: f32, cy: f32| {
        let rect = pmon_monitor::geometry::OrientedRect::new(cx, cy, o.heading_rad, 0.5 * o.length_m, 0.5 * o.width_m);
        let (mut n, mut visible, mut shadow, mut unreached) = (0, 0, 0, 0);
        if let Some(range) = geo.cell_range(rect.aabb()) {
            geo.for_each_cell_overlapping(&rect, range, |_, x, y| {
                let (px, py) = rect.nearest_point(x, y);
                n += 1;
                match vis.sight(px, py) {
                    Sight::Visible => visible += 1,
                    Sight::Shadowed(_) => shadow += 1,
                    Sight::Unreached => unreached += 1,
                }
            });
        }
        format!("{n} cells: {visible} visible {shadow} shadowed {unreached} unreached")
    };
    out += &format!(
        "   sight of the true place: {}; of the noisy box: {}\n",
        sight_of(truth.x_m, truth.y_m),
        sight_of(o.x_m, o.y_m)
    );
    out
}

/// Approximately who owns a cell (the monitor's ownership is private): among the objects whose grown region
/// holds the cell's centre, the one in whose region it lies deepest (relative to the region's size).
fn approx_owner(monitor: &Monitor, objects: &[pmon_monitor::ObjectState], cell: u32) -> Option<usize> {
    let (x, y) = monitor.grid().geometry.cell_center(cell);
    let mut best: Option<(f32, usize)> = None;
    for (j, o) in objects.iter().enumerate() {
        let Some(g) = monitor.region_of(o) else { continue };
        let r = &g.grown;
        let (dx, dy) = (x - r.cx, y - r.cy);
        let (u, v) = (dx * r.cos + dy * r.sin, -dx * r.sin + dy * r.cos);
        let depth = (u.abs() / r.half_length.max(1e-3)).max(v.abs() / r.half_width.max(1e-3));
        if depth <= 1.0 && best.is_none_or(|(d, _)| depth < d) {
            best = Some((depth, j));
        }
    }
    best.map(|(_, j)| j)
}

/// The obstacle-band returns of a cell, grouped by the clean object whose true footprint (grown by 0.15 m)
/// holds them: `id:count z lo..hi`, `none` for returns of no object (the ground, scenery, parked cars of the map).
fn returns_by_object(monitor: &Monitor, frame: &pmon_recording::RecordedFrame, cell: u32) -> String {
    let Some(cloud) = frame.cloud.as_ref() else { return String::new() };
    let geo = monitor.grid().geometry;
    let (lo, hi) = monitor.params().obstacle_band_m();
    let mut groups: BTreeMap<String, (u32, f32, f32)> = BTreeMap::new();
    for &p in &cloud.points_in_sensor {
        let q = cloud.ego_from_sensor.transform(p);
        if q[2] < lo || q[2] > hi || geo.point_to_cell(q[0], q[1]) != Some(cell) {
            continue;
        }
        let who = frame
            .objects
            .iter()
            .find(|o| rect_distance(o, [q[0], q[1]]) <= 0.15)
            .map_or("none".to_string(), |o| o.id.to_string());
        let e = groups.entry(who).or_insert((0, f32::INFINITY, f32::NEG_INFINITY));
        e.0 += 1;
        e.1 = e.1.min(q[2]);
        e.2 = e.2.max(q[2]);
    }
    groups.iter().map(|(k, (n, a, b))| format!("{k}:{n} z {a:.2}..{b:.2}")).collect::<Vec<_>>().join(", ")
}

/// With `seen_over` (`DETAIL=1 SEEN_OVER=1`): for each of the free-space test's 3 x 3 points that the 2-D map
/// calls shadowed, the walk of `Monitor::seen_over` traced again from the outside (ownership approximated by
/// [`approx_owner`]): the occluder, the first cell with returns towards and away from the sensor, its owner,
/// the clearance of its nearest return against the margin, the height of the lowest ray that reached it at the
/// point against the top of its returns less `SEEN_OVER_BELOW_TOP_M` (0.2 m), and whose returns the cell holds.
fn seen_over_trace(
    monitor: &Monitor,
    clean_monitor: &Monitor,
    frame: &pmon_recording::RecordedFrame,
    objects: &[pmon_monitor::ObjectState],
    i: usize,
    g: &pmon_monitor::Region,
) -> String {
    use pmon_monitor::visibility::Sight;
    let _ = clean_monitor;
    let mut out = String::new();
    let grid = monitor.grid();
    let geo = grid.geometry;
    let vis = monitor.visibility();
    let fp = &g.footprint;
    let margin = g.margin_length_m.max(g.margin_width_m);
    let sensor_z = frame.cloud.as_ref().map_or(0.0, |c| c.ego_from_sensor.translation_m[2]);
    let (band_lo, _) = monitor.params().obstacle_band_m();
    let id_of = |c: u32| {
        approx_owner(monitor, objects, c).map_or("-".to_string(), |j| {
            let id = objects.get(j).map_or(0, |o| o.id);
            if j == i {
                format!("SELF({id})")
            } else {
                id.to_string()
            }
        })
    };
    let near_self = |c: u32| {
        let own =
            |c: u32| grid.probability(c) > monitor.params().tau_fn && approx_owner(monitor, objects, c) == Some(i);
        own(c) || geo.neighbours4(c).any(own)
    };
    for u in [-0.6f32, 0.0, 0.6] {
        for v in [-0.6f32, 0.0, 0.6] {
            let (lu, lv) = (u * fp.half_length, v * fp.half_width);
            let (x, y) = (fp.cx + lu * fp.cos - lv * fp.sin, fp.cy + lu * fp.sin + lv * fp.cos);
            if vis.clearance(x, y).is_some() {
                continue;
            }
            let Sight::Shadowed(occ) = vis.sight(x, y) else { continue };
            let o = vis.origin();
            let (dx, dy) = (x - o[0], y - o[1]);
            let r = dx.hypot(dy);
            let (ux, uy) = (dx / r, dy / r);
            let (ox, oy) = geo.cell_center(occ);
            let occ_top = grid.returns(occ).map_or(f32::NAN, |[_, _, top]| top);
            let occ_r = grid.returns(occ).map_or(f32::NAN, |[r2, _, _]| r2.sqrt());
            out += &format!(
                "   seen_over point ({u:+.1},{v:+.1}) r {r:.2}: occluder at r {:.1} (nearest return {occ_r:.2}, top {occ_top:.2}) owner {} near-self {} returns [{}]",
                (ox - o[0]).hypot(oy - o[1]),
                id_of(occ),
                u8::from(near_self(occ)),
                returns_by_object(monitor, frame, occ)
            );
            let Some(c0) = geo.point_to_cell(x, y) else { continue };
            if grid.hits(c0) > 0 {
                out += " | own cell has returns\n";
                continue;
            }
            let step = 0.5 * geo.cell_size_m;
            let reach = 2.0 * (fp.half_length + fp.half_width + margin);
            let mut t = step;
            let mut towards = String::from("none");
            while t <= reach {
                let Some(c) = geo.point_to_cell(x - ux * t, y - uy * t) else { break };
                t += step;
                if c != c0 && grid.hits(c) > 0 && near_self(c) {
                    towards = format!("near-self cell at -{:.2} m", t - step);
                    break;
                }
            }
            let blocked = towards != "none";
            out += &format!(" | towards: {towards}");
            let mut t = step;
            while t <= reach {
                let Some(c) = geo.point_to_cell(x + ux * t, y + uy * t) else { break };
                t += step;
                if c == c0 || grid.hits(c) == 0 {
                    continue;
                }
                let (cx, cy) = geo.cell_center(c);
                out +=
                    &format!(
                    " | away: first cell with returns at +{:.2} m, owner {} near-self {} in-true-footprint-dist {:.2}",
                    t - step,
                    id_of(c),
                    u8::from(near_self(c)),
                    objects.get(i).and_then(|_| frame.objects.get(i)).map_or(f32::NAN, |tr| rect_distance(tr, [cx, cy]))
                );
                if let Some([r2min, zlow, ztop]) = grid.returns(c) {
                    let rmin = r2min.sqrt();
                    let diagonal = std::f32::consts::SQRT_2 * geo.cell_size_m;
                    let dz = zlow - sensor_z;
                    let slope = if dz < 0.0 { dz / (rmin + diagonal) } else { dz / rmin };
                    let h = sensor_z + slope * r;
                    // The occluder's shadow line (condition 5 of `Monitor::seen_over`).
                    let shadow = grid.returns(occ).map_or(f32::NAN, |[o2, _, otop]| {
                        let dz = otop - sensor_z;
                        if dz < 0.0 {
                            dz / (o2.sqrt() + diagonal)
                        } else {
                            dz / o2.sqrt()
                        }
                    });
                    let h_shadow = sensor_z + shadow * r;
                    let h_eff = h.max(h_shadow);
                    let fires = !blocked
                        && rmin - r > margin
                        && h_eff <= ztop - 0.2
                        && h_eff >= band_lo
                        && sensor_z + shadow * rmin <= ztop
                        && near_self(c);
                    // The same ray at the occluder's nearest return, lowest (through the nearest range) and highest.
                    let (h_occ_lo, h_occ_hi) =
                        (sensor_z + dz / rmin * occ_r, sensor_z + dz / (rmin + diagonal) * occ_r);
                    out += &format!(
                        " rmin {rmin:.2} clearance {:.2} (margin {margin:.2}) zlow {zlow:.2} ztop {ztop:.2} ray-h {h:.2} shadow-h {h_shadow:.2} (<= {:.2}?) ray at occluder {h_occ_lo:.2}..{h_occ_hi:.2} vs its top {occ_top:.2} => {} ; returns [{}]",
                        rmin - r,
                        ztop - 0.2,
                        if fires { "FREE" } else { "no" },
                        returns_by_object(monitor, frame, c)
                    );
                }
                break;
            }
            out.push('\n');
        }
    }
    // The true neighbours within 3 m.
    if let Some(truth) = frame.objects.get(i) {
        let near: Vec<String> = frame
            .objects
            .iter()
            .enumerate()
            .filter(|&(j, b)| j != i && (b.x_m - truth.x_m).hypot(b.y_m - truth.y_m) < 3.0)
            .map(|(_, b)| {
                format!(
                    "id {} at r {:.1} ({:+.2} m nearer) gap {:.2} size {:.1}x{:.1}",
                    b.id,
                    b.x_m.hypot(b.y_m),
                    truth.x_m.hypot(truth.y_m) - b.x_m.hypot(b.y_m),
                    nearest_gap(&[*truth, *b], 0),
                    b.length_m,
                    b.width_m
                )
            })
            .collect();
        out += &format!(
            "   true neighbours within 3 m: {}\n",
            if near.is_empty() { "none".into() } else { near.join("; ") }
        );
    }
    out
}

/// `HELD=1`: the false alarms on clean object states grouped by the length of the streak of consecutive frames
/// in which that track was flagged while clean (1, 2-5, 6-20, > 20 frames), and, per group, those whose streak
/// began with a foreign cluster (a cluster not at the object's true place): `[alarms, began foreign]` per group.
/// A long streak that began with a foreign cluster is a memory cascade (docs/attribution.md). Last: verifiable
/// errors found, and of them those whose reported offset exceeds `conflict_association_m` + 1 m.
fn held(scene: &Scene, run: &PlannedRun) -> Result<[[u64; 2]; 5], String> {
    let spec = &run.spec;
    let mut out = [[0u64; 2]; 5];
    // Track id -> (streak length so far, began with a foreign cluster, seen in this frame, confirmed by its own
    // evidence in the streak's first frame).
    let mut streaks: BTreeMap<u64, (u64, bool, bool, bool)> = BTreeMap::new();
    let close = |out: &mut [[u64; 2]; 5], (n, foreign): (u64, bool)| {
        let b = match n {
            0 => return,
            1 => 0,
            2..=5 => 1,
            6..=20 => 2,
            _ => 3,
        };
        if let Some(x) = out.get_mut(b) {
            x[0] += n;
            x[1] += if foreign { n } else { 0 };
        }
    };
    pmon_campaign::paired_frames(scene, spec, |f| {
        for v in streaks.values_mut() {
            v.2 = false;
        }
        for (i, r) in f.reports.iter().enumerate() {
            let (injected, alarm) = injected_and_alarm(f, i, r);
            let (Some(truth), Some(o)) = (f.clean.objects.get(i), f.objects.get(i)) else { continue };
            if injected && alarm && f.confirmed.get(i).copied().unwrap_or(false) {
                // A verifiable error found with an offset beyond the gate (plus a metre for the box and the cluster's
                // extent): found, but credited with evidence that is not its own.
                let far = r.sensor.offset_m[0].hypot(r.sensor.offset_m[1]) > spec.params.conflict_association_m + 1.0;
                out[4][0] += 1;
                out[4][1] += u64::from(far);
            }
            if injected || !alarm {
                continue;
            }
            if std::env::var("TRACK").ok().and_then(|t| t.parse::<u64>().ok()) == Some(o.id) {
                track_line(f, i);
            }
            let e = streaks.entry(o.id).or_insert((0, false, false, false));
            if e.0 == 0 {
                e.1 = foreign_cluster(f, truth, r.sensor.cluster.and_then(|c| f.clusters.get(usize::from(c))));
                e.3 = r.sensor.eta_own >= spec.params.tau_tp;
            }
            e.0 += 1;
            e.2 = true;
        }
        for (id, v) in &mut streaks {
            if !v.2 {
                if v.0 > 5 && std::env::var_os("STREAKS").is_some() {
                    eprintln!(
                        "STREAK [{}] id {id} frames {}..{} foreign {} confirmed-at-start {}",
                        label(run),
                        f.k as u64 - v.0,
                        f.k - 1,
                        v.1,
                        v.3
                    );
                }
                close(&mut out, (v.0, v.1));
                *v = (0, false, false, false);
            }
        }
        Ok(())
    })?;
    for v in streaks.values() {
        close(&mut out, (v.0, v.1));
    }
    Ok(out)
}

/// `DRIFT=1`: how far the offset from a flagged box to the cluster it took wanders from the offset of the first
/// frame of its run of consecutive alarms (the anchor), for true errors (injected, verifiable) and for clean tracks
/// whose run began with a foreign cluster. The offset is compared in three frames: world axes, the ego frame, and
/// the box's line of sight (along the ray from the ego to the box, and across it). Per curve and lag (frames since
/// the anchor): the distance's percentiles, and per frame kind the share beyond step 9's allowance along or across
/// the box (`2 (margin - delta_safe) + delta_safe + cell size`). Returned: (key, samples [world, ego, los, min] as
/// (distance, beyond)) per run.
type DriftSamples = BTreeMap<(String, u64), Vec<[(f32, bool); 4]>>;

/// One track's run in [`drift`]: anchor offsets (world, ego, line of sight), anchor frame, category, seen this frame.
type DriftRun = (Option<[[f32; 2]; 3]>, usize, &'static str, bool);

fn drift(scene: &Scene, run: &PlannedRun) -> Result<DriftSamples, String> {
    let spec = &run.spec;
    let mut out: DriftSamples = BTreeMap::new();
    // Only the errors of `DRIFT_MIN` metres or more (0.8 unless told).
    let min: f64 = std::env::var("DRIFT_MIN").ok().and_then(|t| t.parse().ok()).unwrap_or(0.8);
    if spec.injection.fault.magnitude() < min - 1e-6 {
        return Ok(out);
    }
    // Track id -> (anchor offsets [world, ego, los], anchor frame, category, seen this frame).
    let mut runs: BTreeMap<u64, DriftRun> = BTreeMap::new();
    let track: Option<u64> = std::env::var("TRACK").ok().and_then(|t| t.parse().ok());
    let mut anchors_own: BTreeMap<u64, bool> = BTreeMap::new();
    let mut last_own: BTreeMap<u64, usize> = BTreeMap::new();
    pmon_campaign::paired_frames(scene, spec, |f| {
        for v in runs.values_mut() {
            v.3 = false;
        }
        // The last frame each track was confirmed by its own evidence (consistent, `eta_own >= tau_tp`).
        for (i, r) in f.reports.iter().enumerate() {
            if r.sensor.verdict == SensorVerdict::Consistent && r.sensor.eta_own >= spec.params.tau_tp {
                if let Some(o) = f.objects.get(i) {
                    last_own.insert(o.id, f.k);
                }
            }
        }
        let yaw = f.clean.world_from_ego.yaw_rad as f32;
        for (i, r) in f.reports.iter().enumerate() {
            let (injected, alarm) = injected_and_alarm(f, i, r);
            let (Some(truth), Some(o)) = (f.clean.objects.get(i), f.objects.get(i)) else { continue };
            if !alarm || (injected && !f.confirmed.get(i).copied().unwrap_or(false)) {
                continue;
            }
            let c = r.sensor.cluster.and_then(|c| f.clusters.get(usize::from(c)));
            let e = runs.entry(o.id).or_insert((None, f.k, "", false));
            if e.2.is_empty() {
                e.1 = f.k;
                e.2 = run_kind(injected, foreign_cluster(f, truth, c));
                // Frames since the track was last confirmed by its own evidence when its run began.
                let gap = last_own.get(&o.id).map_or(u64::MAX, |&k| (f.k - k) as u64);
                let bucket = match gap {
                    1 => 0,
                    2..=5 => 1,
                    6..=20 => 2,
                    u64::MAX => 4,
                    _ => 3,
                };
                let key = (format!("start-{}", e.2), bucket);
                out.entry(key).or_default().push([(0.0, false); 4]);
            }
            e.3 = true;
            let Some(c) = c else { continue };
            let d = [c.centroid_m[0] - o.x_m, c.centroid_m[1] - o.y_m];
            let rot = |v: [f32; 2], a: f32| {
                let (s, cs) = a.sin_cos();
                [cs * v[0] - s * v[1], s * v[0] + cs * v[1]]
            };
            let bearing = o.y_m.atan2(o.x_m);
            let now = [rot(d, yaw), d, rot(d, -bearing)];
            let truth_region = f.clean_monitor.region_of(truth);
            let own_now = truth_region.is_some_and(|g| g.grown.distance(c.centroid_m[0], c.centroid_m[1]) < 0.5);
            let Some(anchor) = e.0 else {
                e.0 = Some(now);
                e.1 = f.k;
                anchors_own.insert(o.id, own_now);
                continue;
            };
            let kind = format!(
                "{}:{}>{}",
                e.2,
                if anchors_own.get(&o.id).copied().unwrap_or(false) { "own" } else { "for" },
                if own_now { "own" } else { "for" }
            );
            let lag = (f.k - e.1) as u64;
            let Some(g) = f.monitor.region_of(o) else { continue };
            let delta = spec.params.safety_margin_m;
            let cell = spec.params.cell_size_m;
            let allow =
                [2.0 * (g.margin_length_m - delta) + delta + cell, 2.0 * (g.margin_width_m - delta) + delta + cell];
            // Each difference back in the current ego frame's axes, then in the box's.
            let back = [yaw, 0.0, -bearing];
            let mut s = [(0.0f32, false); 4];
            for v in 0..3 {
                let dd = [now[v][0] - anchor[v][0], now[v][1] - anchor[v][1]];
                let de = rot(dd, -back[v]);
                let (sn, cs) = o.heading_rad.sin_cos();
                let (u, w) = (de[0] * cs + de[1] * sn, -de[0] * sn + de[1] * cs);
                s[v] = (dd[0].hypot(dd[1]), u.abs() > allow[0] || w.abs() > allow[1]);
            }
            let m = (0..3).min_by(|&a, &b| s[a].0.total_cmp(&s[b].0)).unwrap_or(0);
            s[3] = (s[m].0, s[0].1 && s[1].1 && s[2].1);
            if track == Some(o.id) {
                eprintln!(
                    "DRIFTTRACK [{}] frame {} id {} {} lag {lag} box ({:.2},{:.2}) truth ({:.2},{:.2}) c ({:.2},{:.2}) {} cells world off ({:.2},{:.2}) drift w/e/l {:.2}/{:.2}/{:.2} beyond {}/{}/{} vis {:.2}",
                    label(run), f.k, o.id, kind, o.x_m, o.y_m, truth.x_m, truth.y_m, c.centroid_m[0], c.centroid_m[1], c.cells,
                    now[0][0], now[0][1], s[0].0, s[1].0, s[2].0, u8::from(s[0].1), u8::from(s[1].1), u8::from(s[2].1),
                    r.sensor.visible_fraction
                );
            }
            // Does the cluster continue (8-adjacent occupied cells) evidence inside the grown region of another
            // object the sensor calls consistent? (Approximate: the cluster's cells are the occupied cells within its
            // bounds.)
            let geo = f.monitor.grid().geometry;
            let tau = spec.params.tau_fn;
            let occupied = |idx: u32| f.monitor.grid().hits(idx) > 0 && f.monitor.grid().probability(idx) > tau;
            let mut touches = false;
            if let Some((x0, y0)) = geo.point_to_cell(c.bounds_m[0], c.bounds_m[1]).map(|i| geo.cell_center(i)) {
                let step = geo.cell_size_m;
                let mut y = y0;
                while y <= c.bounds_m[3] + 1e-3 && !touches {
                    let mut x = x0;
                    while x <= c.bounds_m[2] + 1e-3 && !touches {
                        if let Some(idx) = geo.point_to_cell(x, y).filter(|&i| occupied(i)) {
                            touches = geo.block3x3(idx).any(|n| {
                                let (nx, ny) = geo.cell_center(n);
                                occupied(n)
                                    && f.reports.iter().enumerate().any(|(m, rm)| {
                                        m != i
                                            && rm.sensor.verdict == SensorVerdict::Consistent
                                            && f.objects
                                                .get(m)
                                                .and_then(|om| f.monitor.region_of(om))
                                                .is_some_and(|g| g.grown.contains(nx, ny))
                                    })
                            });
                        }
                        x += step;
                    }
                    y += step;
                }
            }
            out.entry((format!("touch-{kind}"), u64::from(touches))).or_default().push(s);
            out.entry((kind, lag)).or_default().push(s);
        }
        runs.retain(|_, v| v.3);
        Ok(())
    })?;
    Ok(out)
}

/// Prints [`drift`]'s samples of one curve: per category the distance's percentiles at lags 1, 3, 5, 10, 20 and,
/// over every lag, the share beyond the allowance (world, ego, line of sight, all three).
/// `IDENT=1`: cluster identity over frames (docs/attribution.md, "Cluster identity over frames"). For every alarm
/// frame of a true error (injected, verifiable) and of a clean track (its run of consecutive alarms classed by its
/// first frame as in [`drift`]: `clean-foreign` when that frame's cluster was not at the object's true place), the
/// cells of the cluster it took are looked up in the previous frame (through the ego poses: world, then the previous
/// ego frame): to which track that frame's attribution gave each cell (the object that took the conflict cluster
/// holding it, else the object owning it; `Monitor::cell_attributed_to`). Signals:
/// - `other`: most of the cluster's cells were another track's;
/// - `other-unconf`: `other`, and that track is not confirmed by its own evidence now (`eta_own < tau_tp`);
/// - `carried`: per track, set by an `other` frame, kept over the following alarm frames of its run whose cluster
///   was mostly its own last frame (or nobody's) or that have no cluster (step 8), cleared by a frame whose cluster
///   was mostly nobody's or its own at the run's start; what a memory bit per track would carry.
///
/// Counted per category: alarm frames, those with a cluster, and per signal the frames carrying it; runs, and runs
/// whose first frame with a cluster carries `other`. Errors of `DRIFT_MIN` metres or more (0.8 unless told).
/// One track's run in [`ident`]: category, carried, first cluster frame seen, seen this frame, first cluster frame
/// was `other`, alarm frames so far.
type IdentRun = (&'static str, bool, bool, bool, bool, u64);

fn ident(scene: &Scene, run: &PlannedRun) -> Result<BTreeMap<String, u64>, String> {
    let spec = &run.spec;
    let mut out: BTreeMap<String, u64> = BTreeMap::new();
    let min: f64 = std::env::var("DRIFT_MIN").ok().and_then(|t| t.parse().ok()).unwrap_or(0.8);
    if spec.injection.fault.magnitude() < min - 1e-6 {
        return Ok(out);
    }
    // Track id -> (category, carried, first cluster frame seen, seen this frame, first cluster frame was `other`,
    // alarm frames so far).
    let mut runs: BTreeMap<u64, IdentRun> = BTreeMap::new();
    // The previous frame's attribution per cell (track id, `u64::MAX`: nobody) and its ego pose.
    let mut prev: Vec<u64> = Vec::new();
    // Occupied (and not known scenery) in the previous frame.
    let mut prev_occ: Vec<bool> = Vec::new();
    // The previous frame's attribution was through a conflict cluster (not ownership).
    let mut prev_by_cluster: Vec<bool> = Vec::new();
    let dilate = std::env::var_os("IDENT_DILATE").is_some();
    let mut prev_pose: Option<pmon_monitor::Pose2> = None;
    let track: Option<u64> = std::env::var("TRACK").ok().and_then(|t| t.parse().ok());
    let bump = |out: &mut BTreeMap<String, u64>, k: String| *out.entry(k).or_default() += 1;
    pmon_campaign::paired_frames(scene, spec, |f| {
        for v in runs.values_mut() {
            v.3 = false;
        }
        let geo = f.monitor.grid().geometry;
        let pose = f.clean.world_from_ego;
        for (i, r) in f.reports.iter().enumerate() {
            let (injected, alarm) = injected_and_alarm(f, i, r);
            let (Some(truth), Some(o)) = (f.clean.objects.get(i), f.objects.get(i)) else { continue };
            if !alarm || (injected && !f.confirmed.get(i).copied().unwrap_or(false)) {
                continue;
            }
            let ci = r.sensor.cluster.map(usize::from);
            let c = ci.and_then(|c| f.clusters.get(c));
            let e = runs.entry(o.id).or_insert(("", false, false, false, false, 0));
            if e.0.is_empty() {
                e.0 = run_kind(injected, foreign_cluster(f, truth, c));
                bump(&mut out, format!("{} runs", e.0));
            }
            e.3 = true;
            e.5 += 1;
            let cat = e.0;
            bump(&mut out, format!("{cat} frames"));
            // The cluster's cells in the previous frame: whose were they?
            let (mut own, mut other, mut none, mut none_free, mut other_by_cluster) = (0u32, 0u32, 0u32, 0u32, 0u32);
            let mut others: BTreeMap<u64, u32> = BTreeMap::new();
            if let (Some(ci), Some(pp)) = (ci, prev_pose) {
                let (ps, pc) = (pp.yaw_rad.sin(), pp.yaw_rad.cos());
                for &cell in f.monitor.last_cluster_cells(ci) {
                    let (x, y) = geo.cell_center(cell);
                    let (wx, wy) = pose.transform_point(f64::from(x), f64::from(y));
                    let (dx, dy) = (wx - pp.x_m, wy - pp.y_m);
                    let (px, py) = ((pc * dx + ps * dy) as f32, (-ps * dx + pc * dy) as f32);
                    let pcell = geo.point_to_cell(px, py);
                    let mut who = pcell.and_then(|p| prev.get(p as usize)).copied().unwrap_or(u64::MAX);
                    if who == u64::MAX && dilate {
                        // `IDENT_DILATE=1`: a cell nobody had last frame takes the label of an 8-neighbour that had one
                        // (the lowest id among the most frequent; evidence moves by up to a cell per frame).
                        let mut near: BTreeMap<u64, u32> = BTreeMap::new();
                        for n in pcell.map(|p| geo.block3x3(p)).into_iter().flatten() {
                            if let Some(&w) = prev.get(n as usize).filter(|&&w| w != u64::MAX) {
                                *near.entry(w).or_default() += 1;
                            }
                        }
                        if let Some((&w, _)) = near.iter().max_by_key(|&(id, n)| (*n, std::cmp::Reverse(*id))) {
                            who = w;
                        }
                    }
                    if who == u64::MAX {
                        let occupied_then = pcell.and_then(|p| prev_occ.get(p as usize)).copied().unwrap_or(false);
                        if occupied_then {
                            none_free += 1;
                        }
                        none += 1;
                    } else if who == o.id {
                        own += 1;
                    } else {
                        other += 1;
                        other_by_cluster +=
                            u32::from(pcell.and_then(|p| prev_by_cluster.get(p as usize)).copied().unwrap_or(false));
                        *others.entry(who).or_default() += 1;
                    }
                }
            }
            let cells = own + other + none;
            if cells == 0 {
                // No cluster (held by step 8, a ghost) or no previous frame: the carried bit stays.
                if e.1 {
                    bump(&mut out, format!("{cat} frames carried"));
                }
                continue;
            }
            bump(&mut out, format!("{cat} frames with a cluster"));
            let first = !e.2;
            e.2 = true;
            let is_other = 2 * other > cells;
            // The track most of those cells were: is it confirmed by its own evidence now?
            let j = others.iter().max_by_key(|&(id, n)| (*n, std::cmp::Reverse(*id))).map(|(&id, _)| id);
            let unconf = j.is_some_and(|j| {
                f.objects
                    .iter()
                    .position(|x| x.id == j)
                    .and_then(|m| f.reports.get(m))
                    .is_none_or(|rm| rm.sensor.eta_own < spec.params.tau_tp)
            });
            if is_other {
                e.1 = true;
            } else if 2 * own <= cells && 2 * none > cells {
                // Mostly nobody's last frame: the identity is lost.
                e.1 = false;
            }
            let carried = e.1;
            if is_other {
                bump(&mut out, format!("{cat} frames other"));
                if unconf {
                    bump(&mut out, format!("{cat} frames other-unconf"));
                }
                if 2 * other_by_cluster > other {
                    bump(&mut out, format!("{cat} frames other, mostly through that track's cluster"));
                }
                // Is that track itself displaced (injected now)? Not known to the monitor: for the explanation.
                let j_injected = j.is_some_and(|j| {
                    f.injections.iter().any(|x| f.objects.get(x.index as usize).is_some_and(|oj| oj.id == j))
                });
                if j_injected {
                    bump(&mut out, format!("{cat} frames other, that track displaced"));
                }
                if first {
                    e.4 = true;
                    bump(&mut out, format!("{cat} runs first-other"));
                }
            }
            if first && 2 * own > cells {
                bump(&mut out, format!("{cat} runs first-own-majority"));
            }
            if first && 2 * none > cells {
                bump(&mut out, format!("{cat} runs first-none-majority"));
                if 2 * none_free > none {
                    bump(&mut out, format!("{cat} runs first-none-majority, mostly occupied and free then"));
                }
            }
            if other > 0 {
                bump(&mut out, format!("{cat} frames any-other"));
            }
            if 2 * own > cells {
                bump(&mut out, format!("{cat} frames own-majority"));
            }
            if 2 * none > cells {
                bump(&mut out, format!("{cat} frames none-majority"));
                if 2 * none_free > none {
                    bump(&mut out, format!("{cat} frames none-majority, mostly occupied and free then"));
                }
            }
            if carried {
                bump(&mut out, format!("{cat} frames carried"));
            }
            if track == Some(o.id) {
                eprintln!(
                    "IDENTTRACK [{}] frame {} id {} {cat} cells {cells} own {own} other {other} ({others:?}) none {none} other-unconf {} carried {}",
                    label(run), f.k, o.id, u8::from(unconf), u8::from(carried)
                );
            }
        }
        for v in runs.values() {
            if !v.3 && v.4 {
                *out.entry(format!("{} frames in first-other runs", v.0)).or_default() += v.5;
            }
        }
        runs.retain(|_, v| v.3);
        // This frame's attribution, for the next.
        prev.clear();
        prev.resize((geo.cells_per_side as usize).pow(2), u64::MAX);
        prev_by_cluster.clear();
        prev_by_cluster.resize((geo.cells_per_side as usize).pow(2), false);
        prev_occ.clear();
        prev_occ.resize((geo.cells_per_side as usize).pow(2), false);
        let tau = spec.params.tau_fn;
        for &cell in f.monitor.grid().touched() {
            if let Some(slot) = prev_occ.get_mut(cell as usize) {
                *slot = f.monitor.grid().probability(cell) > tau
                    && f.monitor.grid().flags(cell) & pmon_monitor::grid::FLAG_STATIC == 0;
            }
        }
        for &cell in f.monitor.grid().touched() {
            if let (Some(m), Some(slot)) = (f.monitor.cell_attributed_to(cell), prev.get_mut(cell as usize)) {
                *slot = f.objects.get(m as usize).map_or(u64::MAX, |x| x.id);
                if let Some(v) = prev_by_cluster.get_mut(cell as usize) {
                    *v = f.monitor.grid().flags(cell) & pmon_monitor::grid::FLAG_EXPLAINED == 0;
                }
            }
        }
        prev_pose = Some(pose);
        Ok(())
    })?;
    for v in runs.values() {
        if v.4 {
            *out.entry(format!("{} frames in first-other runs", v.0)).or_default() += v.5;
        }
    }
    Ok(out)
}

fn print_drift(group: &str, samples: &DriftSamples) {
    // The categories whose names start with `prefix` (or, with `None`, those of neither counting prefix), and the
    // number of samples of one category under one key.
    let categories = |prefix: Option<&str>| -> std::collections::BTreeSet<&String> {
        samples
            .keys()
            .map(|(c, _)| c)
            .filter(|c| match prefix {
                Some(p) => c.starts_with(p),
                None => !c.starts_with("start-") && !c.starts_with("touch-"),
            })
            .collect()
    };
    let count = |cat: &String, b: u64| samples.get(&(cat.clone(), b)).map_or(0, Vec::len);
    // Runs by frames since the track was last confirmed when they began: 1, 2-5, 6-20, more, never.
    for cat in categories(Some("start-")) {
        let n = |b: u64| count(cat, b);
        println!(
            "DRIFT {group} {cat}: runs begun 1 frame after the track was last confirmed {} | 2-5 {} | 6-20 {} | more {} | never {}",
            n(0),
            n(1),
            n(2),
            n(3),
            n(4)
        );
    }
    for cat in categories(Some("touch-")) {
        let n = |b: u64| count(cat, b);
        println!(
            "DRIFT {group} {cat}: cluster continues a consistent neighbour's evidence {} of {}",
            n(1),
            n(0) + n(1)
        );
    }
    for cat in categories(None) {
        for lag in [1u64, 3, 5, 10, 20] {
            let Some(v) = samples.get(&(cat.clone(), lag)) else { continue };
            let pct = |k: usize| {
                let mut d: Vec<f32> = v.iter().map(|s| s[k].0).collect();
                d.sort_by(f32::total_cmp);
                let at = |q: f64| d.get(((d.len() as f64 - 1.0) * q).round() as usize).copied().unwrap_or(f32::NAN);
                format!("{:.2}/{:.2}/{:.2}/{:.2}", at(0.5), at(0.9), at(0.99), at(1.0))
            };
            println!(
                "DRIFT {group} {cat:<22} lag {lag:>2}: n {:>6} p50/p90/p99/max world {} ego {} los {} min {}",
                v.len(),
                pct(0),
                pct(1),
                pct(2),
                pct(3)
            );
        }
        let all: Vec<&[(f32, bool); 4]> = samples.iter().filter(|((c, _), _)| c == cat).flat_map(|(_, v)| v).collect();
        let share = |k: usize| all.iter().filter(|s| s[k].1).count();
        println!(
            "DRIFT {group} {cat:<22} every lag: n {} beyond allowance world {} ego {} los {} all three {}",
            all.len(),
            share(0),
            share(1),
            share(2),
            share(3)
        );
    }
}

/// `MISSRUN=1`: each verifiable miss (an injected error on an object confirmed when clean, no alarm) by the track's
/// alarms before it in the run: flagged in the previous frame, flagged earlier only, or never flagged so far; and
/// the same for the verifiable errors found. Multi-frame rules can only reach the first two kinds.
fn miss_runs(scene: &Scene, run: &PlannedRun) -> Result<BTreeMap<String, u64>, String> {
    let spec = &run.spec;
    let mut out: BTreeMap<String, u64> = BTreeMap::new();
    // Track id -> (last frame flagged).
    let mut last: BTreeMap<u64, usize> = BTreeMap::new();
    pmon_campaign::paired_frames(scene, spec, |f| {
        for (i, r) in f.reports.iter().enumerate() {
            let (injected, alarm) = injected_and_alarm(f, i, r);
            let Some(o) = f.objects.get(i) else { continue };
            if injected && f.confirmed.get(i).copied().unwrap_or(false) {
                let before = match last.get(&o.id) {
                    Some(&k) if k + 1 == f.k => "flagged in the previous frame",
                    Some(_) => "flagged earlier only",
                    None => "never flagged before",
                };
                let what = if alarm { "found" } else { "MISS" };
                *out.entry(format!("{what:<5} {before}")).or_default() += 1;
                if !alarm {
                    *out.entry(format!(
                        "  {what:<5} {before}: {:?} own {}",
                        r.sensor.verdict,
                        u8::from(r.sensor.eta_own >= spec.params.tau_tp)
                    ))
                    .or_default() += 1;
                }
            }
            if alarm {
                last.insert(o.id, f.k);
            }
        }
        Ok(())
    })?;
    Ok(out)
}

/// `HOLDSIM=H` (a post-hoc estimate, no monitor change): a static vehicle (reported length >= 3 m, speed < 0.5 m/s)
/// whose alarms ran for two or more consecutive frames counts as flagged for H frames after the run's last alarm.
fn hold_sim(scene: &Scene, run: &PlannedRun, hold: usize) -> Result<BTreeMap<String, u64>, String> {
    let spec = &run.spec;
    let mut out: BTreeMap<String, u64> = BTreeMap::new();
    // Track id -> (last frame flagged, length of the run ending there).
    let mut runs: BTreeMap<u64, (usize, usize)> = BTreeMap::new();
    // Track id -> last frame of a run of two or more.
    let mut held: BTreeMap<u64, usize> = BTreeMap::new();
    // Track id -> the features of its last alarm (`HOLDFEAT` lines: what the monitor could tell held runs by).
    let mut feats: BTreeMap<u64, String> = BTreeMap::new();
    pmon_campaign::paired_frames(scene, spec, |f| {
        for (i, r) in f.reports.iter().enumerate() {
            if !pmon_campaign::in_scope(r.sensor.verdict) {
                continue;
            }
            let (injected, alarm) = injected_and_alarm(f, i, r);
            let Some(o) = f.objects.get(i) else { continue };
            let vehicle = o.length_m >= 3.0 && o.speed_mps.abs() < 0.5;
            let sim = alarm || (vehicle && held.get(&o.id).is_some_and(|&k| f.k <= k + hold));
            if sim && !alarm {
                if let Some(feat) = feats.get(&o.id) {
                    *out.entry(format!("HOLDFEAT inj {} {feat}", u8::from(injected))).or_default() += 1;
                }
            }
            let verifiable = injected && f.confirmed.get(i).copied().unwrap_or(false);
            let mut add = |k: &str, v: bool| *out.entry(format!("HOLDSIM {k}")).or_default() += u64::from(v);
            add("verifiable", verifiable);
            add("detected", verifiable && alarm);
            add("detected_sim", verifiable && sim);
            add("alarms", alarm);
            add("true_alarms", alarm && injected);
            add("alarms_sim", sim);
            add("true_alarms_sim", sim && injected);
            // `HOLDFRESH=1`: only alarms from this frame's evidence (a cluster, or free space) make a run.
            let fresh = std::env::var_os("HOLDFRESH").is_none()
                || matches!(
                    r.sensor.position_cause,
                    Some(pmon_monitor::PositionCause::DisplacedEvidence | pmon_monitor::PositionCause::SeenThrough)
                );
            if alarm && !fresh {
                runs.remove(&o.id);
            }
            if alarm && fresh {
                let n = match runs.get(&o.id) {
                    Some(&(k, n)) if k + 1 == f.k => n + 1,
                    _ => 1,
                };
                runs.insert(o.id, (f.k, n));
                let [dx, dy] = r.sensor.offset_m;
                let range = o.x_m.hypot(o.y_m).max(1e-3);
                let radial = (dx * o.x_m + dy * o.y_m) / range;
                let mag = dx.hypot(dy);
                feats.insert(
                    o.id,
                    format!(
                        "radial {} conf {} mag {} cause {:?} n {}",
                        if radial > 0.3 * mag {
                            "away"
                        } else if radial < -0.3 * mag {
                            "towards"
                        } else {
                            "side"
                        },
                        u8::from(r.sensor.eta_own >= spec.params.tau_tp),
                        if mag < 1.0 {
                            "<1"
                        } else if mag < 2.0 {
                            "1-2"
                        } else {
                            ">2"
                        },
                        r.sensor.position_cause,
                        n.min(5)
                    ),
                );
                // `HOLDAWAY=M`: only a run whose last alarm puts the evidence in front of the box on its line of
                // sight (the offset's radial part above 0.3 of it) and less than M metres from it is held.
                let [dx, dy] = r.sensor.offset_m;
                let away = (dx * o.x_m + dy * o.y_m) / o.x_m.hypot(o.y_m).max(1e-3) > 0.3 * dx.hypot(dy);
                let holdable = std::env::var("HOLDAWAY")
                    .ok()
                    .and_then(|v| v.parse::<f32>().ok())
                    .is_none_or(|m| away && dx.hypot(dy) < m);
                if n >= 2 && holdable {
                    held.insert(o.id, f.k);
                } else if !holdable {
                    held.remove(&o.id);
                }
            }
        }
        Ok(())
    })?;
    Ok(out)
}

/// Whether object `i` of the frame carries an injected error, and whether its sensor verdict (`r`) is an alarm in
/// scope (a ghost or a position error).
fn injected_and_alarm(f: &pmon_campaign::PairedFrame<'_>, i: usize, r: &pmon_monitor::ObjectReport) -> (bool, bool) {
    let injected = f.injections.iter().any(|x| x.index as usize == i);
    let alarm = pmon_campaign::in_scope(r.sensor.verdict)
        && matches!(r.sensor.verdict, SensorVerdict::Ghost | SensorVerdict::PositionError);
    (injected, alarm)
}

/// Whether the cluster a flagged box took is foreign: its centroid 0.5 m or more from the grown region of the
/// object's true place (or the true place has no region).
fn foreign_cluster(
    f: &pmon_campaign::PairedFrame<'_>,
    truth: &pmon_monitor::ObjectState,
    c: Option<&pmon_monitor::ClusterReport>,
) -> bool {
    let truth_region = f.clean_monitor.region_of(truth);
    c.is_some_and(|c| !truth_region.is_some_and(|g| g.grown.distance(c.centroid_m[0], c.centroid_m[1]) < 0.5))
}

/// The kind of a run of alarms, from its first frame: an injected error, or a clean track whose first cluster was
/// foreign, or another clean track.
fn run_kind(injected: bool, foreign: bool) -> &'static str {
    if injected {
        "true"
    } else if foreign {
        "clean-foreign"
    } else {
        "clean-other"
    }
}

fn track_line(f: &pmon_campaign::PairedFrame<'_>, i: usize) {
    let (Some(r), Some(o), Some(t)) = (f.reports.get(i), f.objects.get(i), f.clean.objects.get(i)) else { return };
    let c = r.sensor.cluster.and_then(|c| f.clusters.get(usize::from(c)));
    let whose = c.map_or(String::from("-"), |c| {
        let owners: Vec<String> = f
            .clean
            .objects
            .iter()
            .enumerate()
            .filter(|(m, tm)| {
                *m != i
                    && f.clean_monitor
                        .region_of(tm)
                        .is_some_and(|g| g.grown.distance(c.centroid_m[0], c.centroid_m[1]) < 0.5)
            })
            .map(|(m, tm)| {
                let om = f.objects.get(m).copied().unwrap_or(*tm);
                let rm = f.reports.get(m);
                format!(
                    "id {} inj {} box ({:.1},{:.1}) truth ({:.1},{:.1}) verdict {:?} cluster {:?} eta_own {:.2}",
                    tm.id,
                    u8::from(f.injections.iter().any(|x| x.index as usize == m)),
                    om.x_m,
                    om.y_m,
                    tm.x_m,
                    tm.y_m,
                    rm.map(|r| r.sensor.verdict),
                    rm.and_then(|r| r.sensor.cluster),
                    rm.map_or(0.0, |r| r.sensor.eta_own)
                )
            })
            .collect();
        format!(
            "c ({:.2},{:.2}) {} cells, true place of: [{}]",
            c.centroid_m[0],
            c.centroid_m[1],
            c.cells,
            owners.join("; ")
        )
    });
    eprintln!(
        "TRACK frame {} id {} box ({:.2},{:.2}) truth ({:.2},{:.2}) v {:.1} hdg {:.2} {:?} offset ({:.2},{:.2}) vis {:.2} {whose}",
        f.k,
        o.id,
        o.x_m,
        o.y_m,
        t.x_m,
        t.y_m,
        o.speed_mps,
        o.heading_rad,
        r.sensor.verdict,
        r.sensor.offset_m[0],
        r.sensor.offset_m[1],
        r.sensor.visible_fraction
    );
}

/// Why a clean object state raised an alarm, or why an injected, verifiable one did not.
fn causes(scene: &Scene, run: &PlannedRun) -> Result<BTreeMap<String, u64>, String> {
    let run_label = label(run);
    let spec = &run.spec;
    let mut out = BTreeMap::new();
    let tau = spec.params.tau_tp;
    pmon_campaign::paired_frames(scene, spec, |f| {
        let (k, clean, objects, injections, confirmed) = (f.k, f.clean, f.objects, f.injections, f.confirmed);
        let (objects_out, clusters_out, monitor, clean_monitor) = (f.reports, f.clusters, f.monitor, f.clean_monitor);
        for (i, r) in objects_out.iter().enumerate() {
            if !pmon_campaign::in_scope(r.sensor.verdict) {
                continue;
            }
            let injected = injections.iter().any(|x| x.index as usize == i);
            let alarm = matches!(r.sensor.verdict, SensorVerdict::Ghost | SensorVerdict::PositionError);
            let (Some(truth), Some(o)) = (clean.objects.get(i), objects.get(i)) else { continue };
            let d = (o.x_m - truth.x_m).hypot(o.y_m - truth.y_m);
            let region = clean_monitor.region_of(o);
            let margin = region.map_or(0.0, |g| g.margin_length_m.min(g.margin_width_m));
            // The cluster's relation to the object's true place and to other objects.
            let truth_region = clean_monitor.region_of(truth);
            let cluster_at_truth = |c: &pmon_monitor::ClusterReport| {
                truth_region.is_some_and(|g| g.grown.distance(c.centroid_m[0], c.centroid_m[1]) < 0.5)
            };
            // Range and whether the displacement points away from the sensor.
            let away = (o.x_m.hypot(o.y_m) - truth.x_m.hypot(truth.y_m)) / d.max(1e-6);
            let dir = if away > 0.5 {
                "away"
            } else if away < -0.5 {
                "towards"
            } else {
                "across"
            };
            if !injected && confirmed.get(i).copied().unwrap_or(false) {
                // How often a clean, confirmed box's noise draw exceeds its margin along one of its axes (the
                // grown region then no longer covers its whole true footprint), against the alarms.
                if let Some(g) = region {
                    let (s, c) = o.heading_rad.sin_cos();
                    let (nx, ny) = (o.x_m - truth.x_m, o.y_m - truth.y_m);
                    let (nu, nv) = (nx * c + ny * s, -nx * s + ny * c);
                    let beyond = (nu.abs() / g.margin_length_m).max(nv.abs() / g.margin_width_m);
                    let key = if beyond > 1.0 {
                        format!("NOISE beyond margin, alarm {}", u8::from(alarm))
                    } else {
                        format!("NOISE within margin, alarm {}", u8::from(alarm))
                    };
                    *out.entry(key).or_default() += 1;
                }
            }
            // `BYCAUSE=1`: every alarm by the test that found it (`PositionCause`, or a ghost), on injected objects
            // (found errors) and on clean ones (false alarms).
            if alarm && std::env::var_os("BYCAUSE").is_some() {
                let cause = match r.sensor.verdict {
                    SensorVerdict::Ghost => "ghost",
                    _ => r.sensor.position_cause.map_or("none", |c| c.name()),
                };
                let kind = if injected { "alarm on an injected error" } else { "false alarm" };
                *out.entry(format!("BYCAUSE {kind:<26} {cause}")).or_default() += 1;
                if injected {
                    let agrees = pmon_campaign::metrics::reported_displacement_agrees(
                        &r.sensor,
                        clusters_out,
                        truth,
                        [o.x_m - truth.x_m, o.y_m - truth.y_m],
                    );
                    let how = if agrees { "on its own evidence" } else { "wrong evidence" };
                    *out.entry(format!("BYCAUSE {kind:<26} {cause} {how}")).or_default() += 1;
                    let verifiable = u8::from(confirmed.get(i).copied().unwrap_or(false));
                    *out.entry(format!("BYCAUSE {kind:<26} {cause} clean-confirmed {verifiable}")).or_default() += 1;
                }
            }
            if !injected && alarm {
                let how = match (r.sensor.verdict, r.sensor.cluster) {
                    (SensorVerdict::Ghost, _) => "ghost".to_string(),
                    // Without a cluster: the test that found it (before the verdicts carried it, every such alarm
                    // was labelled `seen_through`, though step 8, step 9 and the opt-in rules give them too).
                    (_, None) => r.sensor.position_cause.map_or("none", |c| c.name()).to_string(),
                    (_, Some(c)) => {
                        let c = clusters_out.get(usize::from(c));
                        format!("cluster {}", if c.is_some_and(cluster_at_truth) { "own(at truth)" } else { "foreign" })
                    }
                };
                let key = format!(
                    "FA {how:<20} noise/margin {:.1} {dir:<7} clean-confirmed {}",
                    (d / margin.max(1e-3) * 2.0).round() / 2.0,
                    u8::from(confirmed.get(i).copied().unwrap_or(false)),
                );
                *out.entry(key).or_default() += 1;
                // `FAKIND=1`: each false alarm by whether the box is confirmed by its own evidence in the faulted
                // frame (its cluster then came by spill-over, `front_cluster` or the memory), and by how far its
                // offset reaches.
                if std::env::var_os("FAKIND").is_some() {
                    let now = if r.sensor.eta_own >= tau { "confirmed now" } else { "unconfirmed now" };
                    let reach = r.sensor.offset_m[0].hypot(r.sensor.offset_m[1]);
                    let reach = if reach < 1.0 {
                        "<1 m"
                    } else if reach < 2.0 {
                        "1-2 m"
                    } else {
                        ">=2 m"
                    };
                    let key = format!(
                        "FAKIND {how:<20} clean-confirmed {} {now:<15} offset {reach}",
                        u8::from(confirmed.get(i).copied().unwrap_or(false))
                    );
                    *out.entry(key).or_default() += 1;
                }
                if std::env::var("DETAIL").is_ok() {
                    // Hits in the object's region (any count, occupied or not).
                    let (mut cells, mut hits) = (0u32, 0u32);
                    if let Some(g) = region {
                        let geo = monitor.grid().geometry;
                        if let Some(range) = geo.cell_range(g.grown.aabb()) {
                            geo.for_each_cell_overlapping(&g.grown, range, |idx, _, _| {
                                let h = u32::from(monitor.grid().hits(idx));
                                cells += u32::from(h > 0);
                                hits += h;
                            });
                        }
                    }
                    let mut text = format!(
                        "FA [{run_label}] frame {k} id {} range {:.1} d {d:.2} {how} eta {:.2} own {:.2} vis {:.2} hit-cells {cells} hits {hits} size {:.1}x{:.1}\n",
                        o.id,
                        o.x_m.hypot(o.y_m),
                        r.sensor.eta,
                        r.sensor.eta_own,
                        r.sensor.visible_fraction,
                        o.length_m,
                        o.width_m
                    );
                    if std::env::var_os("MAP").is_some() {
                        if let Some(g) = region {
                            text += &miss_map(monitor, truth, o, &g, i, spec.params.tau_fn);
                        }
                    }
                    if let Some(g) = region {
                        text += &explain_false_alarm(monitor, truth, o, &g, &run_label);
                        if spec.params.seen_over {
                            text += &seen_over_trace(monitor, clean_monitor, clean, objects, i, &g);
                        }
                    }
                    eprint!("{text}");
                }
            }
            if injected && confirmed.get(i).copied().unwrap_or(false) {
                let gap = nearest_gap(&clean.objects, i);
                let near = if gap <= 0.0 {
                    "overlap"
                } else if gap < 0.3 {
                    "<0.3"
                } else {
                    ">=0.3"
                };
                *out.entry(format!("VERIFIABLE neighbour {near}")).or_default() += 1;
            }
            if injected && confirmed.get(i).copied().unwrap_or(false) && !alarm {
                // Where did the evidence at its true place go?
                let mut at_truth: Vec<String> = clusters_out
                    .iter()
                    .filter(|c| cluster_at_truth(c))
                    .map(|c| match c.object {
                        None => "free".to_string(),
                        Some(m) if m as usize == i => "self".to_string(),
                        Some(m) => {
                            let other_inj = injections.iter().any(|x| x.index == m);
                            format!("other-{}", if other_inj { "displaced" } else { "clean" })
                        }
                    })
                    .collect();
                at_truth.sort();
                at_truth.dedup();
                let own = if r.sensor.eta_own >= tau { "own-in-region" } else { "no-own" };
                let gap = nearest_gap(&clean.objects, i);
                let near = if gap <= 0.0 {
                    "overlap"
                } else if gap < 0.3 {
                    "<0.3"
                } else if gap < 0.6 {
                    "<0.6"
                } else if gap < 1.2 {
                    "<1.2"
                } else {
                    ">=1.2"
                };
                let key = format!(
                    "MISS {:<24} {own:<13} neighbour {near:<7} cluster-at-truth [{}]",
                    format!("{:?}", r.sensor.verdict),
                    at_truth.join(",")
                );
                *out.entry(key).or_default() += 1;
                // `OWNERS=1`: whose the occupied cells under the true footprint went to, by majority.
                if std::env::var_os("OWNERS").is_some() {
                    let geo = monitor.grid().geometry;
                    let (mut me, mut clean_o, mut disp_o, mut free) = (0u32, 0u32, 0u32, 0u32);
                    // Of the displaced owners' cells, those held by a grown region (step 1) rather than a cluster taken.
                    let mut disp_region = 0u32;
                    // Per displaced owner, its cells (the largest one's verdict is printed).
                    let mut disp_by: BTreeMap<u32, u32> = BTreeMap::new();
                    if let Some(tg) = truth_region {
                        if let Some(range) = geo.cell_range(tg.grown.aabb()) {
                            geo.for_each_cell_overlapping(&tg.grown, range, |idx, x, y| {
                                if rect_distance(truth, [x, y]) > 0.25
                                    || monitor.grid().probability(idx) <= spec.params.tau_fn
                                {
                                    return;
                                }
                                match monitor.cell_attributed_to(idx) {
                                    Some(m) if m as usize == i => me += 1,
                                    Some(m) if injections.iter().any(|x| x.index == m) => {
                                        disp_o += 1;
                                        if monitor.grid().flags(idx) & pmon_monitor::grid::FLAG_EXPLAINED != 0 {
                                            disp_region += 1;
                                        }
                                        *disp_by.entry(m).or_default() += 1;
                                    }
                                    Some(_) => clean_o += 1,
                                    None => free += 1,
                                }
                            });
                        }
                    }
                    let total = me + clean_o + disp_o + free;
                    let what = if total == 0 {
                        "none"
                    } else if 2 * me > total {
                        "self"
                    } else if 2 * clean_o > total {
                        "other-clean"
                    } else if 2 * disp_o > total {
                        "other-displaced"
                    } else if 2 * free > total {
                        "free"
                    } else {
                        "mixed"
                    };
                    let size = if o.length_m > 3.0 {
                        "car"
                    } else if o.length_m > 1.2 {
                        "cyclist"
                    } else {
                        "pedestrian"
                    };
                    // The displaced owner's own verdict (a flagged owner's claim on these cells is in doubt).
                    let owner = if what == "other-displaced" {
                        disp_by
                            .iter()
                            .max_by_key(|(m, n)| (**n, std::cmp::Reverse(**m)))
                            .and_then(|(m, _)| objects_out.get(*m as usize))
                            .map_or(String::new(), |or| {
                                // `region` / `cluster` / `both`: the displaced owners held these cells by their grown
                                // regions, by clusters they took, or some of each.
                                let how = match disp_region {
                                    0 => "cluster",
                                    r if r == disp_o => "region",
                                    _ => "both",
                                };
                                // The cluster the owner took: does it touch (8-adjacent) the cells this box owns, and
                                // does it fit this box together with them (spill-over's tests)?
                                let taken = or.sensor.cluster.map(|k| monitor.last_cluster_cells(usize::from(k)));
                                let rel = match (taken, region) {
                                    (Some(cells), Some(g)) if !cells.is_empty() => {
                                        let owned = |c: u32| monitor.cell_attributed_to(c) == Some(i as u32);
                                        let touches =
                                            cells.iter().any(|&c| geo.block3x3(c).any(|n| n != c && owned(n)));
                                        let fp = &g.footprint;
                                        let mut span =
                                            [f32::INFINITY, f32::NEG_INFINITY, f32::INFINITY, f32::NEG_INFINITY];
                                        let mut add = |x: f32, y: f32| {
                                            let (u, v) = fp.local(x, y);
                                            span = [span[0].min(u), span[1].max(u), span[2].min(v), span[3].max(v)];
                                        };
                                        for &c in cells {
                                            let (x, y) = geo.cell_center(c);
                                            add(x, y);
                                        }
                                        if let Some(range) = geo.cell_range(g.grown.aabb()) {
                                            geo.for_each_cell_overlapping(&g.grown, range, |idx, x, y| {
                                                if monitor.grid().probability(idx) > spec.params.tau_fn && owned(idx) {
                                                    add(x, y);
                                                }
                                            });
                                        }
                                        let slack = std::f32::consts::SQRT_2 * geo.cell_size_m
                                            + 2.0 * spec.params.safety_margin_m;
                                        let fits = span[1] - span[0] <= 2.0 * fp.half_length + slack
                                            && span[3] - span[2] <= 2.0 * fp.half_width + slack;
                                        format!(
                                            " cluster {} {}",
                                            if touches { "touches-it" } else { "apart" },
                                            if fits { "fits-with-own" } else { "too-big" }
                                        )
                                    }
                                    _ => String::new(),
                                };
                                format!(" owner {:?} {:?} by {how}{rel}", or.sensor.verdict, or.sensor.position_cause)
                            })
                    } else {
                        String::new()
                    };
                    let key = format!(
                        "OWNERS {:<24} {size:<10} {dir:<7} truth evidence {what}{owner}",
                        format!("{:?}", r.sensor.verdict)
                    );
                    *out.entry(key).or_default() += 1;
                }
                if std::env::var("MISSES").is_ok() {
                    // Each cluster at the true place: cells, who took it, whether that object's own true place is
                    // also under it (merged evidence) and how far its box is from it.
                    let detail: Vec<String> = clusters_out
                        .iter()
                        .enumerate()
                        .filter(|(_, c)| cluster_at_truth(c))
                        .map(|(ci, c)| {
                            let who = c.object.map_or("free".to_string(), |m| {
                                let m = m as usize;
                                let (mt, mo) = (clean.objects.get(m), objects.get(m));
                                let merged = mt
                                    .and_then(|t| clean_monitor.region_of(t))
                                    .is_some_and(|g| g.grown.distance(c.centroid_m[0], c.centroid_m[1]) < 0.5);
                                let md = match (mt, mo) {
                                    (Some(t), Some(o)) => (o.x_m - t.x_m).hypot(o.y_m - t.y_m),
                                    _ => 0.0,
                                };
                                let gap = mt.map_or(0.0, |t| (t.x_m - truth.x_m).hypot(t.y_m - truth.y_m));
                                format!(
                                    "id {} disp {md:.1} truth-gap {gap:.2} merged {} its-own-cluster {}",
                                    mo.map_or(0, |o| o.id),
                                    u8::from(merged),
                                    objects_out.get(m).and_then(|r| r.sensor.cluster).map_or(-1, i32::from)
                                )
                            });
                            format!("[c{ci} {} cells -> {who}]", c.cells)
                        })
                        .collect();
                    let mut text = format!(
                        "MISS [{run_label}] frame {k} id {} range {:.1} {:?} eta {:.2} own {:.2} vis {:.2} size {:.1}x{:.1} {}\n",
                        o.id,
                        truth.x_m.hypot(truth.y_m),
                        r.sensor.verdict,
                        r.sensor.eta,
                        r.sensor.eta_own,
                        r.sensor.visible_fraction,
                        o.length_m,
                        o.width_m,
                        detail.join(" ")
                    );
                    // `POINTS=1`: the free-space test's points of the missed box too.
                    if std::env::var_os("POINTS").is_some() {
                        if let Some(g) = region {
                            text += &explain_false_alarm(monitor, truth, o, &g, &run_label);
                        }
                    }
                    // `MAP=1`: the cells around the missed box (rows north to south): `S`/`s` its own evidence
                    // inside / outside the reported box's grown region, `N`/`n` another object's, `F`/`f` nobody's,
                    // `:` returns too sparse to be occupied, `+` an empty cell of the grown region, `T` an empty cell
                    // of the true footprint.
                    if std::env::var_os("MAP").is_some() {
                        if let Some(g) = region {
                            text += &miss_map(monitor, truth, o, &g, i, spec.params.tau_fn);
                        }
                    }
                    // `TRACE=1` (with `SEEN_OVER=1`): the seen-over walk of the missed box too.
                    if spec.params.seen_over && std::env::var_os("TRACE").is_some() {
                        if let Some(g) = region {
                            text += &seen_over_trace(monitor, clean_monitor, clean, objects, i, &g);
                        }
                    }
                    eprint!("{text}");
                }
            }
        }
        Ok(())
    })?;
    Ok(out)
}

/// `MAP=1`: an ASCII picture of the cells around a missed box (see the call).
fn miss_map(
    monitor: &Monitor,
    truth: &pmon_monitor::ObjectState,
    o: &pmon_monitor::ObjectState,
    g: &pmon_monitor::Region,
    i: usize,
    tau_fn: f32,
) -> String {
    let geo = monitor.grid().geometry;
    let cs = geo.cell_size_m;
    let reach = 0.5 * truth.length_m.max(truth.width_m) + (o.x_m - truth.x_m).hypot(o.y_m - truth.y_m) + 2.0;
    let (cx, cy) = (0.5 * (o.x_m + truth.x_m), 0.5 * (o.y_m + truth.y_m));
    let steps = (reach / cs).ceil() as i32;
    let mut text = format!(
        "   map (cell {cs} m; truth ({:.1}, {:.1}), box ({:.1}, {:.1}), heading {:.0} deg; sensor at the origin)\n",
        truth.x_m,
        truth.y_m,
        o.x_m,
        o.y_m,
        o.heading_rad.to_degrees()
    );
    for r in (-steps..=steps).rev() {
        let mut line = String::from("   ");
        for c in -steps..=steps {
            let (x, y) = (cx + c as f32 * cs, cy + r as f32 * cs);
            let Some(idx) = geo.point_to_cell(x, y) else {
                line.push(' ');
                continue;
            };
            let (px, py) = geo.cell_center(idx);
            let inside = g.grown.contains(px, py);
            let hits = monitor.grid().hits(idx);
            let ch = if monitor.grid().probability(idx) > tau_fn {
                let who = monitor.cell_attributed_to(idx);
                match (who, inside) {
                    (Some(m), true) if m as usize == i => 'S',
                    (Some(m), false) if m as usize == i => 's',
                    (Some(_), true) => 'N',
                    (Some(_), false) => 'n',
                    (None, true) => 'F',
                    (None, false) => 'f',
                }
            } else if hits > 0 {
                ':'
            } else if inside {
                '+'
            } else if rect_distance(truth, [px, py]) == 0.0 {
                'T'
            } else {
                '.'
            };
            line.push(ch);
        }
        text += &line;
        text.push('\n');
    }
    text
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let seed: u64 = args.get(1).map_or(Ok(7), |s| s.parse())?;
    let mode = args.get(2).map_or("summary", String::as_str);
    let filter = args.get(3).cloned().unwrap_or_default();
    // `FULL=1`: the full plan (`pmon reproduce --seed SEED` without `--quick`): its scale and scene lengths.
    let full = std::env::var_os("FULL").is_some();
    // `CORRELATED=1`: the false alarms under correlated noise as well.
    let correlated = std::env::var_os("CORRELATED").is_some();
    let scenes = scenes(seed, full)?;
    let ids = SceneIds { pedestrians: 0, intersection: 1, pedestrians_20hz: Some(2), pedestrians_paper: Some(3) };
    let scale = if full { Scale::Full } else { Scale::Quick };
    let planned = experiments::plan(scale, ids, &MonitorParams::default(), seed);
    // `SEEN_OVER=1`: the same runs and injection seeds, with the params key `seen_over` on.
    let seen_over = std::env::var_os("SEEN_OVER").is_some();
    let chosen: Vec<PlannedRun> = planned
        .iter()
        .filter(|r| wanted(r, correlated) && label(r).contains(&filter))
        .map(|r| {
            let mut r = r.clone();
            r.spec.params.seen_over |= seen_over;
            r.spec.params.face_in_front |= std::env::var_os("FACE").is_some();
            if let Some(k) = std::env::var("BEYOND").ok().and_then(|v| v.parse().ok()) {
                r.spec.params.returns_beyond_cells = k;
            }
            // `JUMP=1`: step 9 from the returns (the params key `jump_from_returns`, the default since issue #10;
            // `NOJUMP=1` turns it off, and with it `jump_first_return`).
            r.spec.params.jump_from_returns |= std::env::var_os("JUMP").is_some();
            // `BODY=1`: the free-space test counts only rays that end on the body (the params key `seen_body`).
            r.spec.params.seen_body |= std::env::var_os("BODY").is_some();
            // `MEMGATE=1`: evidence beyond the gate is never a box's (the params key `memory_gate`).
            r.spec.params.memory_gate |= std::env::var_os("MEMGATE").is_some();
            // `FOLLOWGATE=1`: step 8 counts only cells within the gate (the params key `follow_gate`).
            r.spec.params.follow_gate |= std::env::var_os("FOLLOWGATE").is_some();
            // `seen_body` and `follow_gate` are the default since issue #10's round "Rays on the body with step 8
            // gated": `NOBODY=1` and `NOFOLLOWGATE=1` turn them off.
            if std::env::var_os("NOBODY").is_some() {
                r.spec.params.seen_body = false;
            }
            if std::env::var_os("NOFOLLOWGATE").is_some() {
                r.spec.params.follow_gate = false;
            }
            // `SHADOWGATE=1`: only unexplained evidence within the gate contradicts a box it shadows (`shadow_gate`).
            r.spec.params.shadow_gate |= std::env::var_os("SHADOWGATE").is_some();
            // `FRONT=1`: a free cluster in front of a confirmed box confirmed by scenery (`front_cluster`).
            r.spec.params.front_cluster |= std::env::var_os("FRONT").is_some();
            // `NOFRONT=1`: `front_cluster` off (the default since issue #10's round "Two rules together";
            // `HOLD=0` turns the other key of that round off).
            r.spec.params.front_cluster &= std::env::var_os("NOFRONT").is_none();
            // `NOSPILLFRONT=1`: `spill_in_front` off (the default since issue #10's round "Spill-over in front of
            // the box"): spill-over gives a confirmed box only clusters that touch its own evidence.
            r.spec.params.spill_in_front &= std::env::var_os("NOSPILLFRONT").is_none();
            // `NONEARSIDE=1`: `spill_near_side` off (the default since issue #10's round "The near side of the box"):
            // spill-over in front of a box counts all its own evidence, its far side too.
            r.spec.params.spill_near_side &= std::env::var_os("NONEARSIDE").is_none();
            // `STRETCH=1`: `spill_least_stretch` on (off by default; issue #10's round "The box a cluster stretches
            // least").
            r.spec.params.spill_least_stretch |= std::env::var_os("STRETCH").is_some();
            // `HOLD=S`: a track flagged as displaced keeps its offset S seconds after its last alarm for step 8
            // (the params key `memory_hold_s`).
            if let Some(s) = std::env::var("HOLD").ok().and_then(|v| v.parse().ok()) {
                r.spec.params.memory_hold_s = s;
            }
            // `FIRST=1`: step 9's returns' mean from each cell's first return (the params key `jump_first_return`,
            // the default since issue #10; `NOFIRST=1`: the sums of all the returns).
            r.spec.params.jump_first_return |= std::env::var_os("FIRST").is_some();
            if std::env::var_os("NOFIRST").is_some() {
                r.spec.params.jump_first_return = false;
            }
            if std::env::var_os("NOJUMP").is_some() {
                r.spec.params.jump_from_returns = false;
                r.spec.params.jump_first_return = false;
            }
            // `NOPRED=1`: the diagonal test also from where the returns put the box (`jump_evidence_at_prediction`
            // off); `NOCOINC=1`: step 9 leaves out cells in a box reported in the predicted place too
            // (`jump_coincident_boxes` off). Both are the default since issue #10.
            r.spec.params.jump_evidence_at_prediction &= std::env::var_os("NOPRED").is_none();
            r.spec.params.jump_coincident_boxes &= std::env::var_os("NOCOINC").is_none();
            r.spec.params.jump_jumped_boxes &= std::env::var_os("NOJUMPED").is_none();
            r.spec.params.follow_owner_fit |= std::env::var_os("OWNERFIT").is_some();
            r.spec.params.release_flagged_claims &= std::env::var_os("NORELEASE").is_none();
            // `RELCONF=1`: the params key `release_to_confirmed`.
            r.spec.params.release_to_confirmed |= std::env::var_os("RELCONF").is_some();
            // `NOSIDE=1` turns the params key `seen_through_near_side` off.
            if std::env::var_os("NOSIDE").is_some() {
                r.spec.params.seen_through_near_side = false;
            }
            // `NORUNSON=1` turns the params key `evidence_runs_on` off.
            if std::env::var_os("NORUNSON").is_some() {
                r.spec.params.evidence_runs_on = false;
            }
            // `SPILLGAP=M`: the params key `spill_gap_m = M` (spill-over across a gap of empty cells; 0.4 by default,
            // `SPILLGAP=0` gives the verdicts before it).
            if let Some(m) = std::env::var("SPILLGAP").ok().and_then(|v| v.parse().ok()) {
                r.spec.params.spill_gap_m = m;
            }
            // `PARKED=S`: the params key `parked_hold_s = S` (docs/attribution.md, "Parked cars in a row").
            if let Some(s) = std::env::var("PARKED").ok().and_then(|v| v.parse().ok()) {
                r.spec.params.parked_hold_s = s;
            }
            // `CELL=S`: every chosen run with cells of S metres (e.g. the false alarms, 0.5 m cells in the plan, at
            // 0.2 m: `CELL=0.2 ... summary false_alarms`).
            if let Some(c) = std::env::var("CELL").ok().and_then(|v| v.parse().ok()) {
                r.spec.params.cell_size_m = c;
            }
            r
        })
        .collect();
    let results: Vec<_> = chosen
        .par_iter()
        .map(|r| {
            let scene = scenes.get(r.spec.scene).ok_or("no scene")?;
            let res = run_one(scene, &r.spec)?;
            let mut c = if mode == "causes" { causes(scene, r)? } else { BTreeMap::new() };
            if std::env::var_os("MISSRUN").is_some() {
                c.extend(miss_runs(scene, r)?);
            }
            if let Some(h) = std::env::var("HOLDSIM").ok().and_then(|v| v.parse().ok()) {
                c.extend(hold_sim(scene, r, h)?);
            }
            let h = if std::env::var_os("HELD").is_some() { Some(held(scene, r)?) } else { None };
            let d = if std::env::var_os("DRIFT").is_some() { Some(drift(scene, r)?) } else { None };
            let id = if std::env::var_os("IDENT").is_some() { Some(ident(scene, r)?) } else { None };
            Ok::<_, String>((res, c, h, d, id))
        })
        .collect::<Result<_, _>>()?;
    let mut fa_total = (0u64, 0u64);
    let mut fa_by_curve: BTreeMap<String, (u64, u64)> = BTreeMap::new();
    let mut all_causes: BTreeMap<String, BTreeMap<String, u64>> = BTreeMap::new();
    // `HELD=1`: per row group (false alarms, paper, hard, towards, transient), the streak buckets summed.
    let mut held_by_group: BTreeMap<String, [[u64; 2]; 5]> = BTreeMap::new();
    let mut drift_by_group: BTreeMap<String, DriftSamples> = BTreeMap::new();
    let mut ident_by_group: BTreeMap<String, BTreeMap<String, u64>> = BTreeMap::new();
    for (r, (res, c, h, d, id)) in chosen.iter().zip(&results) {
        if let Some(id) = id {
            let g = ident_by_group.entry(label(r).split(" @ ").next().unwrap_or_default().to_string()).or_default();
            for (k, v) in id {
                *g.entry(k.clone()).or_default() += v;
            }
        }
        let m = &res.metrics;
        let l = label(r);
        if l.starts_with("false_alarms") {
            fa_total.0 += m.sensor.false_alarms();
            fa_total.1 += m.clean_states_in_scope;
            let curve = l.split(" @ ").next().unwrap_or_default().to_string();
            let e = fa_by_curve.entry(curve).or_default();
            e.0 += m.sensor.false_alarms();
            e.1 += m.clean_states_in_scope;
            println!("{l:<70} FA {} / {}", m.sensor.false_alarms(), m.clean_states_in_scope);
        } else if l.starts_with("random_position_") {
            // Transient errors (`TRANSIENT=1`): the figure's sensor recall (all injected) and the combined precision.
            println!(
                "{l:<70} recall {:5.1} % ({}/{})  verifiable {:5.1} %  combined precision {:5.1} % ({}/{})",
                100.0 * m.sensor.recall().value,
                m.sensor.detected,
                m.sensor.injected,
                100.0 * m.sensor_verifiable.recall().value,
                100.0 * m.combined.precision().value,
                m.combined.true_alarms,
                m.combined.alarms
            );
        } else {
            println!(
                "{l:<70} recall(verifiable) {:5.1} % ({}/{})  precision {:5.1} % ({}/{})",
                100.0 * m.sensor_verifiable.recall().value,
                m.sensor_verifiable.detected,
                m.sensor_verifiable.injected,
                100.0 * m.sensor.precision().value,
                m.sensor.true_alarms,
                m.sensor.alarms
            );
        }
        if let Some(h) = h {
            let row = |h: &[[u64; 2]; 5]| {
                format!(
                    "FA by streak 1: {} ({}) | 2-5: {} ({}) | 6-20: {} ({}) | >20: {} ({}) | verifiable found {}, offset beyond gate + 1 m {}",
                    h[0][0], h[0][1], h[1][0], h[1][1], h[2][0], h[2][1], h[3][0], h[3][1], h[4][0], h[4][1]
                )
            };
            println!("    HELD {}  [(n): began with a foreign cluster]", row(h));
            let g = held_by_group.entry(l.split(" @ ").next().unwrap_or_default().to_string()).or_default();
            for (a, b) in g.iter_mut().zip(h) {
                a[0] += b[0];
                a[1] += b[1];
            }
        }
        if let Some(d) = d {
            let g = drift_by_group.entry(l.split(" @ ").next().unwrap_or_default().to_string()).or_default();
            for (k, v) in d {
                g.entry(k.clone()).or_default().extend_from_slice(v);
            }
        }
        let group = if std::env::var("BYMAG").is_ok() {
            l.clone()
        } else {
            l.split(" @ ").next().unwrap_or_default().to_string()
        };
        let g = all_causes.entry(group).or_default();
        for (k, v) in c {
            *g.entry(k.clone()).or_default() += v;
        }
    }
    println!("sensor false alarms up to 0.3 m noise: {} in {}", fa_total.0, fa_total.1);
    for (group, h) in &held_by_group {
        let total: u64 = h.iter().take(4).map(|x| x[0]).sum();
        let cascade = h[2][1] + h[3][1];
        println!(
            "HELD total {group}: {total} FA; streak 1: {} | 2-5: {} | 6-20: {} ({} began foreign) | >20: {} ({} began foreign); cascades (streak > 5, began foreign): {cascade}; verifiable found {}, offset beyond gate + 1 m {}",
            h[0][0], h[1][0], h[2][0], h[2][1], h[3][0], h[3][1], h[4][0], h[4][1]
        );
    }
    for (group, d) in &drift_by_group {
        print_drift(group, d);
    }
    for (group, d) in &ident_by_group {
        for (k, v) in d {
            println!("IDENT {group} {k}: {v}");
        }
    }
    if correlated {
        for (curve, (k, n)) in &fa_by_curve {
            println!("  {curve}: {k} in {n}");
        }
    }
    for (group, c) in &all_causes {
        if c.is_empty() {
            continue;
        }
        println!("== {group}");
        let mut v: Vec<_> = c.iter().collect();
        v.sort_by(|a, b| b.1.cmp(a.1).then(a.0.cmp(b.0)));
        for (k, n) in v {
            println!("{n:>6}  {k}");
        }
    }
    Ok(())
}
