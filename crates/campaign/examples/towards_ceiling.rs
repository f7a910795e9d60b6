//! How many displacements towards the ego could *any* free-space rule prove, given the sweep? An upper bound
//! (a ceiling) for issue #10's goal "towards the ego >= 90 % from 1 m", measured on the `pmon reproduce` runs
//! (docs/attribution.md, "The ceiling the rays allow"):
//!
//! `cargo run --release -p pmon-campaign --example towards_ceiling -- SEED [FILTER]`
//!
//! For every verifiable error of the quick plan's runs *towards the ego* (the object confirmed by its own evidence
//! when clean, as `pmon reproduce` scores it; `FILTER` keeps the runs whose label contains it, default `towards`),
//! the reported box is **provable by the rays** when no placement of the object within the monitor's own allowance
//! survives the sweep: for every shift of the reported box on a 0.1 m lattice within its grown region's margins
//! (along and across the box), some LiDAR ray crosses the shifted box's volume (between the obstacle band's floor
//! and 0.2 m below the object's true top, a height the monitor is not even told) and ends at least
//! `delta_safe` (0.1 m) beyond it. A rule that knows only the sweep and the stated uncertainty cannot prove more,
//! so the share of provable errors bounds the recall any such rule can reach; the clean confirmed boxes of the
//! same frames are counted the same way as a check of the bound's soundness (a clean box must not be provable).
//! `MIN_RAYS=k` asks k rays per shift instead of one. `SVG=path` also draws the curves (PNG when `path` ends in `.png`) (recall today, the share
//! provable by the rays, the ceiling, the goal) as an SVG figure, with its data beside it as CSV (`path.csv`).
use pmon_campaign::experiments::{self, Measure, PlannedRun, Scale, SceneIds};
use pmon_campaign::{run_one, Scene};
use pmon_monitor::{MonitorParams, ObjectState, SensorVerdict};
use pmon_scenario::Simulator;
use rayon::prelude::*;
use std::collections::BTreeMap;

/// The quick plan's scenes with the true heights of each frame's objects (by id).
struct HeightScene {
    scene: Scene,
    heights: Vec<BTreeMap<u64, f32>>,
}

fn scenes(seed: u64) -> Result<Vec<HeightScene>, Box<dyn std::error::Error>> {
    let mut out = Vec::new();
    for spec in pmon_campaign::sim_tasks::scene_specs(true, seed, None)? {
        let name = spec.name.as_str();
        if name != "pedestrians" {
            // Only the hard-conditions street carries the towards-the-ego runs; stand-ins keep the indices.
            out.push(HeightScene {
                scene: Scene { name: name.into(), source: String::new(), frames: Vec::new() },
                heights: Vec::new(),
            });
            continue;
        }
        let cfg = pmon_campaign::sim_tasks::scenario_config(name, spec.seed, Some(spec.duration_s))?;
        let mut sim = Simulator::new(&cfg).map_err(|e| format!("{name}: {e}"))?;
        let (mut frames, mut heights) = (Vec::new(), Vec::new());
        while let Some(f) = sim.step() {
            heights.push(f.truth.iter().map(|t| (t.id, t.height_m as f32)).collect());
            frames.push(f.frame);
        }
        out.push(HeightScene { scene: Scene { name: name.into(), source: String::new(), frames }, heights });
    }
    Ok(out)
}

fn label(run: &PlannedRun) -> String {
    run.probes
        .iter()
        .find(|p| p.measure != Measure::PlausibilityRecall)
        .map_or(String::new(), |p| format!("{} / {} @ {:.1}", p.figure, p.curve, p.x))
}

/// Rays of one sweep in the ego frame, bucketed by azimuth (0.5 degree bins) for the window queries.
struct Rays {
    origin: [f32; 3],
    /// The obstacle band, ego frame.
    band: (f32, f32),
    points: Vec<[f32; 3]>,
    /// `start[b]..start[b + 1]` indexes `order` for bin `b`.
    start: Vec<u32>,
    order: Vec<u32>,
}

const BINS: usize = 720;

/// The definitions' knobs (environment): `THREE_SIGMA=1` grants 3 sigma instead of the grown region's margins
/// (which add `safety_margin_m`), `BELOW_TOP=m` (0.2) keeps the volume that far below the true top,
/// `TOLERANCE=m` (0.1) is how far outside a placement its own returns may lie and still be explained by it;
/// `NEIGHBOURS=1` also counts as explained the returns inside a clean neighbour's grown region (a placement that
/// leaves only such returns outside is then indistinguishable: any rule that grants every correct box its grown
/// region must grant that neighbour those returns).
#[derive(Clone, Copy)]
struct Knobs {
    three_sigma: bool,
    below_top_m: f32,
    tolerance_m: f32,
    neighbours: bool,
}

/// What the sweep allows about one reported box.
struct Judgement {
    /// Every placement within the margins is crossed by rays: any sound free-space rule may flag it.
    provable: bool,
    /// Some placement within the margins is crossed by no ray and holds all of the object's own returns: no
    /// rule that grants the stated uncertainty can tell the box from a correct one.
    indistinguishable: bool,
}

fn bin_of(x: f32, y: f32, origin: [f32; 3]) -> usize {
    let a = (y - origin[1]).atan2(x - origin[0]); // -pi..pi
    (((a + core::f32::consts::PI) / core::f32::consts::TAU * BINS as f32) as usize).min(BINS - 1)
}

impl Rays {
    fn of(frame: &pmon_recording::RecordedFrame, band: (f32, f32)) -> Option<Self> {
        let cloud = frame.cloud.as_ref()?;
        let t = cloud.ego_from_sensor;
        let origin = t.translation_m;
        let points: Vec<[f32; 3]> = cloud.points_in_sensor.iter().map(|p| t.transform(*p)).collect();
        let bins: Vec<usize> = points.iter().map(|q| bin_of(q[0], q[1], origin)).collect();
        let mut start = vec![0u32; BINS + 1];
        for &b in &bins {
            start[b + 1] += 1;
        }
        for b in 0..BINS {
            start[b + 1] += start[b];
        }
        let mut fill = start.clone();
        let mut order = vec![0u32; points.len()];
        for (i, &b) in bins.iter().enumerate() {
            order[fill[b] as usize] = i as u32;
            fill[b] += 1;
        }
        Some(Self { origin, band, points, start, order })
    }

    /// Is the box `o` (height `top_m` over the ground) provable by the rays: every shift within the margins
    /// crossed by at least `min_rays` rays that end `beyond_m` past it?
    fn judge(
        &self,
        o: &ObjectState,
        truth: &ObjectState,
        margins: (f32, f32),
        z: (f32, f32),
        (min_rays, tolerance_m): (u32, f32),
        absorbed: &dyn Fn(f32, f32) -> bool,
    ) -> Judgement {
        let (s, c) = o.heading_rad.sin_cos();
        let (hl, hw) = (0.5 * o.length_m + margins.0, 0.5 * o.width_m + margins.1);
        // The azimuth window of the box grown by its margins (its four corners; a box around the sensor is
        // not asked).
        let mut angles = [0.0f32; 4];
        let centre = (o.y_m - self.origin[1]).atan2(o.x_m - self.origin[0]);
        for (k, (u, v)) in [(hl, hw), (-hl, hw), (-hl, -hw), (hl, -hw)].into_iter().enumerate() {
            let (x, y) = (o.x_m + u * c - v * s, o.y_m + u * s + v * c);
            let a = (y - self.origin[1]).atan2(x - self.origin[0]) - centre;
            angles[k] = (a + core::f32::consts::PI).rem_euclid(core::f32::consts::TAU) - core::f32::consts::PI;
        }
        let (lo, hi) = angles.iter().fold((f32::MAX, f32::MIN), |(l, h), &a| (l.min(a), h.max(a)));
        if hi - lo > 1.5 {
            return Judgement { provable: false, indistinguishable: true };
        }
        let per_bin = core::f32::consts::TAU / BINS as f32;
        let first = ((centre + lo + core::f32::consts::PI) / per_bin).floor() as i64 - 1;
        let last = ((centre + hi + core::f32::consts::PI) / per_bin).floor() as i64 + 1;
        // The rays of the window in the box's axes: origin and end relative to the reported centre.
        let (ou, ov) = {
            let (dx, dy) = (self.origin[0] - o.x_m, self.origin[1] - o.y_m);
            (dx * c + dy * s, -dx * s + dy * c)
        };
        let mut rays: Vec<[f32; 3]> = Vec::new();
        // The object's own returns (in its true footprint, 5 cm tolerance, in the obstacle band), in the
        // reported box's axes.
        let mut own: Vec<[f32; 2]> = Vec::new();
        let (ts, tc) = truth.heading_rad.sin_cos();
        for b in first..=last {
            let b = b.rem_euclid(BINS as i64) as usize;
            for &i in &self.order[self.start[b] as usize..self.start[b + 1] as usize] {
                let q = self.points[i as usize];
                let (dx, dy) = (q[0] - o.x_m, q[1] - o.y_m);
                let r = [dx * c + dy * s, -dx * s + dy * c, q[2]];
                rays.push(r);
                let (ex, ey) = (q[0] - truth.x_m, q[1] - truth.y_m);
                let (tu, tv) = (ex * tc + ey * ts, -ex * ts + ey * tc);
                if tu.abs() <= 0.5 * truth.length_m + 0.05
                    && tv.abs() <= 0.5 * truth.width_m + 0.05
                    && q[2] >= self.band.0
                    && q[2] <= self.band.1
                    && !absorbed(q[0], q[1])
                {
                    own.push([r[0], r[1]]);
                }
            }
        }
        let o3 = [ou, ov, self.origin[2]];
        let step = 0.1f32;
        let (nu, nv) = ((margins.0 / step).floor() as i32, (margins.1 / step).floor() as i32);
        let (l2, w2) = (0.5 * o.length_m, 0.5 * o.width_m);
        let mut judgement = Judgement { provable: true, indistinguishable: false };
        for iu in -nu..=nu {
            for iv in -nv..=nv {
                let (su, sv) = (iu as f32 * step, iv as f32 * step);
                let lo3 = [su - l2, sv - w2, z.0];
                let hi3 = [su + l2, sv + w2, z.1];
                let mut found = 0u32;
                for q in &rays {
                    let d = [q[0] - o3[0], q[1] - o3[1], q[2] - o3[2]];
                    let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                    let (mut t0, mut t1) = (0.0f32, 1.0f32);
                    let mut ok = true;
                    for a in 0..3 {
                        if d[a].abs() < 1e-9 {
                            if o3[a] < lo3[a] || o3[a] > hi3[a] {
                                ok = false;
                                break;
                            }
                        } else {
                            let (ta, tb) = ((lo3[a] - o3[a]) / d[a], (hi3[a] - o3[a]) / d[a]);
                            t0 = t0.max(ta.min(tb));
                            t1 = t1.min(ta.max(tb));
                        }
                    }
                    // Crosses the volume and ends at least 0.1 m beyond where it leaves it.
                    if ok && t0 < t1 && (1.0 - t1) * len >= 0.1 {
                        found += 1;
                        if found >= min_rays {
                            break;
                        }
                    }
                }
                if found < min_rays {
                    judgement.provable = false;
                    // A placement the rays allow: does it also hold all the object's own returns (within
                    // `delta_safe`)? Then the sweep is what a correct box there would give.
                    if own
                        .iter()
                        .all(|p| (p[0] - su).abs() <= l2 + tolerance_m && (p[1] - sv).abs() <= w2 + tolerance_m)
                    {
                        judgement.indistinguishable = true;
                        return judgement;
                    }
                }
            }
        }
        judgement
    }
}

#[derive(Default)]
struct Count {
    verifiable: u64,
    detected: u64,
    provable: u64,
    provable_missed: u64,
    detected_unprovable: u64,
    indistinguishable: u64,
    indistinguishable_detected: u64,
    clean: u64,
    clean_provable: u64,
}

fn count(hs: &HeightScene, run: &PlannedRun, min_rays: u32, knobs: Knobs) -> Result<Count, String> {
    let p = run.spec.params;
    let mut out = Count::default();
    pmon_campaign::paired_frames(&hs.scene, &run.spec, |f| {
        let (k, clean, objects, injections, confirmed) = (f.k, f.clean, f.objects, f.injections, f.confirmed);
        let clean_monitor = f.clean_monitor;
        let verdicts: Vec<SensorVerdict> = f.reports.iter().map(|r| r.sensor.verdict).collect();
        let band = (p.ground_z_m + p.min_obstacle_height_m, p.ground_z_m + p.max_obstacle_height_m);
        let Some(rays) = Rays::of(clean, band) else { return Ok(()) };
        let heights = hs.heights.get(k);
        let injected = |j: usize| injections.iter().any(|x| x.index as usize == j);
        // With `NEIGHBOURS=1`: the frame's objects that carry no injected error, with their grown regions (once per
        // frame; each object's test leaves itself out).
        let clean_regions: Vec<(usize, pmon_monitor::geometry::OrientedRect)> = if knobs.neighbours {
            objects
                .iter()
                .enumerate()
                .filter(|&(j, _)| !injected(j))
                .filter_map(|(j, n)| clean_monitor.region_of(n).map(|r| (j, r.grown)))
                .collect()
        } else {
            Vec::new()
        };
        for (i, v) in verdicts.iter().enumerate() {
            if !pmon_campaign::in_scope(*v) || !confirmed.get(i).copied().unwrap_or(false) {
                continue;
            }
            let Some(o) = objects.get(i) else { continue };
            let Some(region) = clean_monitor.region_of(o) else { continue };
            let top = heights.and_then(|h| h.get(&o.id)).copied().unwrap_or(1.5).min(p.max_obstacle_height_m);
            let z = (p.ground_z_m + p.min_obstacle_height_m, p.ground_z_m + top - knobs.below_top_m);
            // The allowance: the grown region's margins, or without the safety margin (3 sigma alone).
            let less = if knobs.three_sigma { p.safety_margin_m } else { 0.0 };
            let margins = ((region.margin_length_m - less).max(0.0), (region.margin_width_m - less).max(0.0));
            let Some(truth) = clean.objects.get(i) else { continue };
            let absorbed = |x: f32, y: f32| clean_regions.iter().any(|&(j, r)| j != i && r.contains(x, y));
            let j = if z.0 < z.1 {
                rays.judge(o, truth, margins, z, (min_rays, knobs.tolerance_m), &absorbed)
            } else {
                Judgement { provable: false, indistinguishable: true }
            };
            let provable = j.provable;
            if injected(i) {
                let alarm = matches!(v, SensorVerdict::Ghost | SensorVerdict::PositionError);
                out.verifiable += 1;
                out.detected += u64::from(alarm);
                out.provable += u64::from(provable);
                out.provable_missed += u64::from(provable && !alarm);
                out.detected_unprovable += u64::from(alarm && !provable);
                out.indistinguishable += u64::from(j.indistinguishable);
                out.indistinguishable_detected += u64::from(j.indistinguishable && alarm);
            } else {
                out.clean += 1;
                out.clean_provable += u64::from(provable);
            }
        }
        Ok(())
    })?;
    Ok(out)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let seed: u64 = args.get(1).map_or(Ok(7), |s| s.parse())?;
    let filter = args.get(2).cloned().unwrap_or_else(|| "towards".into());
    let min_rays: u32 = std::env::var("MIN_RAYS").map_or(Ok(1), |s| s.parse())?;
    let knobs = Knobs {
        three_sigma: std::env::var_os("THREE_SIGMA").is_some(),
        below_top_m: std::env::var("BELOW_TOP").map_or(Ok(0.2), |s| s.parse())?,
        tolerance_m: std::env::var("TOLERANCE").map_or(Ok(0.1), |s| s.parse())?,
        neighbours: std::env::var_os("NEIGHBOURS").is_some(),
    };
    let scenes = scenes(seed)?;
    let ids = SceneIds { pedestrians: 0, intersection: 1, pedestrians_20hz: Some(2), pedestrians_paper: Some(3) };
    let planned = experiments::plan(Scale::Quick, ids, &MonitorParams::default(), seed);
    let chosen: Vec<&PlannedRun> = planned
        .iter()
        .filter(|r| {
            r.probes.iter().any(|p| {
                (p.figure == "position_direction" && p.measure == Measure::SensorRecallVerifiable)
                    || (p.figure == "permanent_position" && p.measure == Measure::SensorRecall)
            }) && label(r).contains(&filter)
        })
        .collect();
    let results: Vec<(String, Count, f64)> = chosen
        .par_iter()
        .map(|r| {
            let hs = scenes.get(r.spec.scene).ok_or("no scene")?;
            if hs.scene.frames.is_empty() {
                return Err(format!("{}: scene not simulated", label(r)));
            }
            let res = run_one(&hs.scene, &r.spec)?;
            let c = count(hs, r, min_rays, knobs)?;
            Ok::<_, String>((label(r), c, res.metrics.sensor_verifiable.recall().value))
        })
        .collect::<Result<_, _>>()?;
    println!(
        "seed {seed}, quick plan, at least {min_rays} ray(s) per shift, allowance {}, volume up to {} m below the top, returns explained within {} m{}",
        if knobs.three_sigma { "3 sigma" } else { "grown-region margins" },
        knobs.below_top_m,
        knobs.tolerance_m,
        if knobs.neighbours { " or by a clean neighbour's grown region" } else { "" }
    );
    for (l, c, recall) in &results {
        let pct = |a: u64, b: u64| 100.0 * a as f64 / b.max(1) as f64;
        println!(
            "{l:<55} n {:>5}  detected {:5.1} % (run_one {:5.1} %)  provable {:5.1} %  provable missed {:>5}  detected unprovable {:>4}  indistinguishable {:5.1} % (detected {})  ceiling {:5.1} %  clean provable {} of {}",
            c.verifiable,
            pct(c.detected, c.verifiable),
            100.0 * recall,
            pct(c.provable, c.verifiable),
            c.provable_missed,
            c.detected_unprovable,
            pct(c.indistinguishable, c.verifiable),
            c.indistinguishable_detected,
            100.0 - pct(c.indistinguishable, c.verifiable),
            c.clean_provable,
            c.clean
        );
    }
    if let Some(path) = std::env::var_os("SVG") {
        use pmon_report::{LineChart, RefLine, Series, SeriesColor};
        let x = |r: &(String, Count, f64)| r.0.rsplit(" @ ").next().and_then(|v| v.parse::<f64>().ok()).unwrap_or(0.0);
        let pct = |a: u64, b: u64| 100.0 * a as f64 / b.max(1) as f64;
        let curve = |f: &dyn Fn(&Count) -> f64| results.iter().map(|r| (x(r), f(&r.1))).collect::<Vec<_>>();
        let chart = LineChart::new(
            format!("Towards the ego, seed {seed} (quick plan, 0.5 m cells, verifiable errors)"),
            "position error towards the ego [m]",
            "share of verifiable errors [%]",
        )
        .with_y_range(0.0, 100.0)
        .with_ref_line(RefLine::horizontal(90.0, "goal 90 %"))
        .with_series(
            Series::new("detected by pmon today", curve(&|c| pct(c.detected, c.verifiable)))
                .with_markers()
                .with_color(SeriesColor::Palette(0)),
        )
        .with_series(
            Series::new(
                "provable by rays through the box (free space alone)",
                curve(&|c| pct(c.provable, c.verifiable)),
            )
            .with_markers()
            .with_color(SeriesColor::Palette(1)),
        )
        .with_series(
            Series::new(
                "ceiling: not indistinguishable from a correct box",
                curve(&|c| 100.0 - pct(c.indistinguishable, c.verifiable)),
            )
            .dashed()
            .with_color(SeriesColor::Palette(3)),
        );
        let path = std::path::PathBuf::from(path);
        if path.extension().is_some_and(|e| e == "png") {
            chart.render_png(&path, 1000, 600)?;
        } else {
            chart.render_svg(&path)?;
        }
        let mut csv = path.clone().into_os_string();
        csv.push(".csv");
        chart.write_csv(csv)?;
    }
    Ok(())
}
