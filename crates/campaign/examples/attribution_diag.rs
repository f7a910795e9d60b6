//! Counts the sensor checks' misses and false alarms by cause on the `pmon reproduce --quick` runs (a
//! development aid for the evidence attribution, docs/attribution.md):
//!
//! `cargo run --release -p pmon-campaign --example attribution_diag -- SEED [summary|causes] [FILTER]`
//!
//! `summary` runs the quick plan's sensor runs (false alarms up to 0.3 m noise, permanent errors under paper
//! and hard conditions, towards the ego) with the same seeds as `pmon reproduce --quick --seed SEED` and prints
//! their curves; `causes` also breaks every false alarm and every verifiable miss down by cause. `FILTER`
//! keeps only the runs whose curve label contains it (for example `towards` or `paper`). With `SEEN_OVER=1` the
//! monitor runs with the params key `seen_over` on.
use std::collections::BTreeMap;

use pmon_campaign::experiments::{self, Measure, PlannedRun, Scale, SceneIds};
use pmon_campaign::{run_one, Injector, Scene};
use pmon_monitor::{Monitor, MonitorParams, NotMonitoredReason, SensorVerdict};
use pmon_scenario::Simulator;
use rayon::prelude::*;

/// The scenes of `pmon reproduce --quick` that the sensor runs use (the same configuration as
/// `crates/cli/src/reproduce.rs`), with empty stand-ins for the others so that the plan's indices hold.
fn scenes(seed: u64) -> Result<Vec<Scene>, Box<dyn std::error::Error>> {
    let mut out = Vec::new();
    for name in ["pedestrians", "intersection", "pedestrians_20hz", "pedestrians_paper"] {
        if name == "intersection" || name == "pedestrians_20hz" {
            out.push(Scene { name: name.into(), source: String::new(), frames: Vec::new() });
            continue;
        }
        let mut cfg = pmon_campaign::sim_tasks::scenario_config(name, seed, None)?;
        cfg.duration_s = cfg.duration_s.min(15.0);
        let mut sim = Simulator::new(&cfg).map_err(|e| format!("{name}: {e}"))?;
        let mut frames = Vec::new();
        while let Some(f) = sim.step() {
            frames.push(f.frame);
        }
        out.push(Scene { name: name.into(), source: String::new(), frames });
    }
    Ok(out)
}

/// The sensor runs of the quick plan worth watching.
fn wanted(run: &PlannedRun) -> bool {
    run.probes.iter().any(|p| {
        (p.figure == "false_alarms" && p.curve == "sensor checks, white noise" && p.x <= 0.3 + 1e-9)
            || ((p.figure == "permanent_position" || p.figure == "permanent_position_paper")
                && p.measure == Measure::SensorRecallVerifiable)
            || (p.figure == "position_direction" && p.curve.starts_with("towards"))
    })
}

fn label(run: &PlannedRun) -> String {
    run.probes
        .iter()
        .find(|p| p.measure != Measure::PlausibilityRecall)
        .map_or(String::new(), |p| format!("{} / {} @ {:.1}", p.figure, p.curve, p.x))
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
) {
    use pmon_monitor::visibility::Sight;
    let (s, c) = o.heading_rad.sin_cos();
    let (nx, ny) = (o.x_m - truth.x_m, o.y_m - truth.y_m);
    let (nu, nv) = (nx * c + ny * s, -nx * s + ny * c);
    let r = truth.x_m.hypot(truth.y_m).max(1e-3);
    let (rx, ry) = (truth.x_m / r, truth.y_m / r);
    let (radial, tangential) = (nx * rx + ny * ry, -nx * ry + ny * rx);
    eprintln!(
        "   run {run_label}: noise (along, across) ({nu:+.2}, {nv:+.2}) m vs margins ({:.2}, {:.2}) = ({:.2}, {:.2}) x margin; radial {radial:+.2} (+: away) tangential {tangential:+.2}",
        g.margin_length_m,
        g.margin_width_m,
        nu.abs() / g.margin_length_m,
        nv.abs() / g.margin_width_m
    );
    let geo = monitor.grid().geometry;
    let vis = monitor.visibility();
    let fp = &g.footprint;
    let margin = g.margin_length_m.max(g.margin_width_m);
    let mut pts = Vec::new();
    for u in [-0.6f32, 0.0, 0.6] {
        for v in [-0.6f32, 0.0, 0.6] {
            let (lu, lv) = (u * fp.half_length, v * fp.half_width);
            let (x, y) = (fp.cx + lu * fp.cos - lv * fp.sin, fp.cy + lu * fp.sin + lv * fp.cos);
            let text = match vis.clearance(x, y) {
                None => format!("{:?}", vis.sight(x, y)).chars().take(8).collect(),
                Some((cl, cell)) => {
                    let (cx, cy) = geo.cell_center(cell);
                    format!(
                        "cl {cl:.2}{} obst@truth {:.2} in-grown {} hits {}",
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
    eprintln!("   free-space points (margin {margin:.2}, * = free): {}", pts.join(" | "));
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
    eprintln!(
        "   sight of the true place: {}; of the noisy box: {}",
        sight_of(truth.x_m, truth.y_m),
        sight_of(o.x_m, o.y_m)
    );
}

/// Why a clean object state raised an alarm, or why an injected, verifiable one did not.
fn causes(scene: &Scene, run: &PlannedRun) -> Result<BTreeMap<String, u64>, String> {
    let run_label = label(run);
    let spec = &run.spec;
    let mut monitor = Monitor::new(spec.params).map_err(|e| e.to_string())?;
    let mut clean_monitor = Monitor::new(spec.params).map_err(|e| e.to_string())?;
    let mut injector = Injector::new(spec.injection);
    let mut out = BTreeMap::new();
    let tau = spec.params.tau_tp;
    for (k, clean) in scene.frames.iter().enumerate() {
        let mut objects = clean.objects.clone();
        let injections = injector.apply_at(k as u64, clean.timestamp_s, &mut objects);
        let mut roi = Vec::new();
        let mut view = clean.as_frame(&mut roi);
        let confirmed: Vec<bool> = clean_monitor
            .check(&view)
            .map_err(|e| e.to_string())?
            .objects
            .iter()
            .map(|r| !matches!(r.sensor.verdict, SensorVerdict::NotMonitored(_)) && r.sensor.eta_own >= tau)
            .collect();
        view.objects = &objects;
        let (objects_out, clusters_out) = {
            let report = monitor.check(&view).map_err(|e| e.to_string())?;
            (report.objects.to_vec(), report.clusters.to_vec())
        };
        for (i, r) in objects_out.iter().enumerate() {
            if matches!(
                r.sensor.verdict,
                SensorVerdict::NotMonitored(NotMonitoredReason::OutsideGrid | NotMonitoredReason::InvalidState)
            ) {
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
            if !injected && alarm {
                let how = match (r.sensor.verdict, r.sensor.cluster) {
                    (SensorVerdict::Ghost, _) => "ghost".to_string(),
                    (_, None) => "seen_through".to_string(),
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
                    eprintln!(
                        "FA frame {k} id {} range {:.1} d {d:.2} {how} eta {:.2} own {:.2} vis {:.2} hit-cells {cells} hits {hits} size {:.1}x{:.1}",
                        o.id,
                        o.x_m.hypot(o.y_m),
                        r.sensor.eta,
                        r.sensor.eta_own,
                        r.sensor.visible_fraction,
                        o.length_m,
                        o.width_m
                    );
                    if let Some(g) = region {
                        explain_false_alarm(&monitor, truth, o, &g, &run_label);
                    }
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
                    eprintln!(
                        "MISS frame {k} id {} range {:.1} {:?} eta {:.2} own {:.2} vis {:.2} size {:.1}x{:.1} {}",
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
                }
            }
        }
    }
    Ok(out)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let seed: u64 = args.get(1).map_or(Ok(7), |s| s.parse())?;
    let mode = args.get(2).map_or("summary", String::as_str);
    let filter = args.get(3).cloned().unwrap_or_default();
    let scenes = scenes(seed)?;
    let ids = SceneIds { pedestrians: 0, intersection: 1, pedestrians_20hz: Some(2), pedestrians_paper: Some(3) };
    let planned = experiments::plan(Scale::Quick, ids, &MonitorParams::default(), seed);
    // `SEEN_OVER=1`: the same runs and injection seeds, with the params key `seen_over` on.
    let seen_over = std::env::var_os("SEEN_OVER").is_some();
    let chosen: Vec<PlannedRun> = planned
        .iter()
        .filter(|r| wanted(r) && label(r).contains(&filter))
        .map(|r| {
            let mut r = r.clone();
            r.spec.params.seen_over |= seen_over;
            r.spec.params.face_in_front |= std::env::var_os("FACE").is_some();
            r
        })
        .collect();
    let results: Vec<_> = chosen
        .par_iter()
        .map(|r| {
            let scene = scenes.get(r.spec.scene).ok_or("no scene")?;
            let res = run_one(scene, &r.spec)?;
            let c = if mode == "causes" { causes(scene, r)? } else { BTreeMap::new() };
            Ok::<_, String>((res, c))
        })
        .collect::<Result<_, _>>()?;
    let mut fa_total = (0u64, 0u64);
    let mut all_causes: BTreeMap<String, BTreeMap<String, u64>> = BTreeMap::new();
    for (r, (res, c)) in chosen.iter().zip(&results) {
        let m = &res.metrics;
        let l = label(r);
        if l.starts_with("false_alarms") {
            fa_total.0 += m.sensor.false_alarms();
            fa_total.1 += m.clean_states_in_scope;
            println!("{l:<70} FA {} / {}", m.sensor.false_alarms(), m.clean_states_in_scope);
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
