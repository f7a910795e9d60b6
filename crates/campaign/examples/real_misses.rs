//! Counts the misses of the real-sensor experiment by cause (a development aid):
//! `cargo run --release -p pmon-campaign --example real_misses -- SPEC MAGNITUDE_M [OUT_DIR]`, e.g.
//! `av2:../shared/data/av2/sensor/val/7fab2350-7eaf-3b7e-a39d-6937a4c1bede 1.0`.
//!
//! Every box is displaced away from the ego by MAGNITUDE_M (as the experiment's "every box displaced" run). For
//! each box that the monitor confirms on the clean frame and does not flag once displaced, prints the verdict and
//! where its own evidence went: the conflict cluster that holds the clean box's band returns (in the region of
//! interest or not, taken by another object or left as a missed object, whether it fits the box) or, when no
//! cluster holds it, that it is still explained (by the displaced box itself or a neighbour). With OUT_DIR, the
//! displaced frames are written as a recording for `pmon view` (with the dataset's parameters as params.toml).
//! `GROUND=auto|local|recorded` and `ROI=auto|none|corridor:W` choose the ground and the region of interest. With
//! `ONE_BOX=1`, each box consistent on its clean frame is displaced alone instead (the other boxes keep their
//! labels; every check starts with a fresh track memory), as the experiment's one-box curve. With `ONE_BOX=1
//! HISTORY=1`, only frames that follow another sweep are used, and the previous sweep, clean, is checked right before
//! each displaced box (the error starts at this sweep: the evidence memory knows where each object's evidence was).
//! With `HISTORY=1` alone, every box is displaced at once as without it, but each displaced frame's check starts with
//! a fresh track memory and a check of the previous sweep, clean (the paper's form at the onset of the error).
//! `BEYOND=N` checks with the params key `returns_beyond_cells = N` (own returns beyond the grown region),
//! `SPILLGAP=M` checks with the params key `spill_gap_m = M` (spill-over across a gap of empty cells),
//! `SEEN_OVER=1` with `seen_over` (`BEYOND=1 FACE=1 SEEN_OVER=1`: the parameters of `--params profile:recall`).
//! `FACE=1` checks with the params key `face_in_front`, `BODY=1` with `seen_body` (the free-space test counts only
//! rays that end on the body), `MEMGATE=1` with `memory_gate` (evidence beyond the gate is never a box's),
//! `FOLLOWGATE=1` with `follow_gate` (step 8 alone bounded by the gate); both `seen_body` and `follow_gate` are the
//! default since issue #10's round "Rays on the body with step 8 gated": `NOBODY=1` / `NOFOLLOWGATE=1` turn them off.
//! `jump_from_returns` (step 9 from the returns) and `jump_first_return` (their mean from each cell's first return)
//! are the default since issue #10: `NOJUMP=1` checks without both, `NOFIRST=1` without the first return;
//! `NOPRED=1` without `jump_evidence_at_prediction`, `NOCOINC=1` without `jump_coincident_boxes`, `NOJUMPED=1`
//! without `jump_jumped_boxes` (all three the default since issue #10 too).
//! `DETAIL=1` (with `ONE_BOX=1 HISTORY=1`) prints, for each clean box flagged beside a displaced one, where both stand
//! and the cluster that flagged it.
//! `NOSPILLFRONT=1` checks with the params key `spill_in_front` off (on by default since issue #10's round
//! "Spill-over in front of the box"); `STRETCH=1` with `spill_least_stretch` on (off by default; the round "The
//! box a cluster stretches least"); `NONEARSIDE=1` with `spill_near_side` off (on by default since the round "The
//! near side of the box").
//! `NOFRONT=1` checks with the params key `front_cluster` off (on by default since issue #10's round "Two rules
//! together": a free cluster in front of a confirmed box, fitting it, goes to it when the evidence confirming the box
//! runs on beyond it; `FRONT=1` is kept and changes nothing). `WHERE=1` adds to each miss's cause where the clean
//! box's own returns went (to itself, a neighbour's region, a neighbour's cluster, a free cluster, or nowhere) and
//! whose cells confirm it in its displaced region (its own clean returns, a neighbour's box, scenery).
//! `GRAZE=f` checks with the grazing rule at `roi_graze_fraction = f` (`GRAZE=0`: off; unset: the default, 0.5).
//! `HOLD=S` checks with the params key `memory_hold_s = S` (a displaced offset held over frames without an alarm; 1 s
//! by default, `HOLD=0` turns it off).
//! `SPILL=occupied` checks with `SpillOverFit::Occupied` (spill-over fitted over occupied cells only, the default
//! before issue #10's clean-box round; the default now is every return).
use std::collections::BTreeMap;

use pmon_campaign::{Direction, Fault, InjectionConfig, Injector};
use pmon_datasets::roi::RoiOptions;
use pmon_datasets::{open_with, ReadOptions};
use pmon_monitor::geometry::OrientedRect;
use pmon_monitor::{Monitor, MonitorParams, SensorVerdict};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let spec = args.get(1).ok_or("usage: real_misses SPEC MAGNITUDE_M [OUT_DIR]")?;
    let magnitude_m: f32 = args.get(2).map_or(Ok(1.0), |s| s.parse())?;
    // `GRAZE=f`: the grazing rule at `roi_graze_fraction = f` (`GRAZE=0`: off; unset: the default, 0.5).
    let graze = std::env::var("GRAZE").map_or(Ok(MonitorParams::default().roi_graze_fraction), |v| v.parse::<f32>())?;
    let base = MonitorParams { roi_graze_fraction: graze, ..MonitorParams::default() };
    let mode = std::env::var("ROI").unwrap_or_else(|_| "auto".into()).parse()?;
    let roi = RoiOptions { mode, grid_half_extent_m: 0.5 * f64::from(base.grid_size_m), ..RoiOptions::default() };
    let ground = pmon_datasets::ground::GroundMode::parse(&std::env::var("GROUND").unwrap_or_else(|_| "auto".into()))?;
    let ds = open_with(spec, &ReadOptions { load_clouds: true, roi, ground })?;
    let params = MonitorParams {
        ground_z_m: ds.info.ground_z_m,
        ego_footprint_m: ds.info.format.ego_footprint_m(),
        face_in_front: std::env::var_os("FACE").is_some(),
        // `SEEN_OVER=1`: the params key `seen_over` (off by default; with `BEYOND=1 FACE=1`, `profile:recall`).
        seen_over: std::env::var_os("SEEN_OVER").is_some(),
        // `NORELEASE=1`: the params key `release_flagged_claims` off (the default since issue #10's round "Claims a
        // flagged neighbour releases").
        release_flagged_claims: base.release_flagged_claims && std::env::var_os("NORELEASE").is_none(),
        // `RELCONF=1`: the params key `release_to_confirmed` (off by default).
        release_to_confirmed: std::env::var_os("RELCONF").is_some(),
        // `NORUNSON=1` turns the params key `evidence_runs_on` off (on by default).
        evidence_runs_on: base.evidence_runs_on && std::env::var_os("NORUNSON").is_none(),
        // `NOSIDE=1` turns the params key `seen_through_near_side` off (on by default).
        seen_through_near_side: base.seen_through_near_side && std::env::var_os("NOSIDE").is_none(),
        // `SPILLGAP=M`: the params key `spill_gap_m = M` (0.4 by default; `SPILLGAP=0` gives the verdicts before it).
        spill_gap_m: std::env::var("SPILLGAP").ok().and_then(|v| v.parse().ok()).unwrap_or(base.spill_gap_m),
        // `BEYOND=N`: the params key `returns_beyond_cells = N` (off by default).
        returns_beyond_cells: std::env::var("BEYOND").ok().and_then(|v| v.parse().ok()).unwrap_or(0),
        // The jump keys are the default since issue #10: `NOJUMP=1` turns both off, `NOFIRST=1` the first return.
        jump_from_returns: base.jump_from_returns && std::env::var_os("NOJUMP").is_none(),
        jump_first_return: base.jump_first_return
            && std::env::var_os("NOJUMP").is_none()
            && std::env::var_os("NOFIRST").is_none(),
        // The default since issue #10's round "Rays on the body with step 8 gated": `NOBODY=1` / `NOFOLLOWGATE=1`.
        seen_body: (base.seen_body || std::env::var_os("BODY").is_some()) && std::env::var_os("NOBODY").is_none(),
        memory_gate: std::env::var_os("MEMGATE").is_some(),
        follow_gate: (base.follow_gate || std::env::var_os("FOLLOWGATE").is_some())
            && std::env::var_os("NOFOLLOWGATE").is_none(),
        // The default since issue #10's round "Two rules together": `NOFRONT=1` turns it off (`HOLD=0` the other key).
        front_cluster: (base.front_cluster || std::env::var_os("FRONT").is_some())
            && std::env::var_os("NOFRONT").is_none(),
        // The default since issue #10's round "Spill-over in front of the box": `NOSPILLFRONT=1` turns it off.
        spill_in_front: base.spill_in_front && std::env::var_os("NOSPILLFRONT").is_none(),
        // The default since issue #10's round "The near side of the box": `NONEARSIDE=1` turns it off.
        spill_near_side: base.spill_near_side && std::env::var_os("NONEARSIDE").is_none(),
        spill_least_stretch: base.spill_least_stretch || std::env::var_os("STRETCH").is_some(),
        memory_hold_s: std::env::var("HOLD").ok().and_then(|v| v.parse().ok()).unwrap_or(base.memory_hold_s),
        // Default since issue #10: `NOPRED=1` / `NOCOINC=1` turn them off.
        jump_evidence_at_prediction: base.jump_evidence_at_prediction && std::env::var_os("NOPRED").is_none(),
        jump_coincident_boxes: base.jump_coincident_boxes && std::env::var_os("NOCOINC").is_none(),
        jump_jumped_boxes: base.jump_jumped_boxes && std::env::var_os("NOJUMPED").is_none(),
        ..base
    };
    let frames: Vec<_> = ds.frames.iter().filter(|f| f.frame.cloud.is_some()).collect();
    let mut monitor = Monitor::new(params)?;
    let mut clean_monitor = Monitor::new(params)?;
    if std::env::var("SPILL").is_ok_and(|v| v == "occupied") {
        monitor.set_spill_over_fit(pmon_monitor::SpillOverFit::Occupied);
        clean_monitor.set_spill_over_fit(pmon_monitor::SpillOverFit::Occupied);
    }
    let fault = Fault::PermanentPosition { magnitude_m, direction: Direction::Away };
    let mut cfg = InjectionConfig::new(fault, 7);
    cfg.permanent_track_fraction = 1.0;
    let mut injector = Injector::new(cfg);
    let mut writer = match args.get(3) {
        Some(dir) => {
            let meta = pmon_recording::RecordingMeta::new("real_misses", spec.as_str());
            Some(pmon_recording::RecordingWriter::create(std::path::Path::new(dir), meta)?)
        }
        None => None,
    };
    let (lo, hi) = params.obstacle_band_m();
    let geometry = pmon_monitor::GridGeometry::new(params.grid_cells_per_side(), params.cell_size_m);
    let mut causes: BTreeMap<String, u64> = BTreeMap::new();
    let (mut verifiable, mut detected) = (0u64, 0u64);
    let (mut separable_n, mut separable_detected) = (0u64, 0u64);
    for (k, df) in frames.iter().enumerate() {
        let mut croi = Vec::new();
        let cview = df.frame.as_frame(&mut croi);
        if std::env::var("ONE_BOX").is_ok() {
            clean_monitor.reset_tracks();
        }
        let clean_report = clean_monitor.check(&cview)?;
        for c in clean_report.clusters.iter().filter(|c| c.is_missed_object()) {
            println!(
                "clean frame {k} missed object: {} cells at ({:.1}, {:.1}), bounds x {:.1}..{:.1} y {:.1}..{:.1}",
                c.cells, c.centroid_m[0], c.centroid_m[1], c.bounds_m[0], c.bounds_m[2], c.bounds_m[1], c.bounds_m[3]
            );
        }
        for (r, o) in clean_report.objects.iter().zip(&df.frame.objects) {
            if matches!(r.sensor.verdict, SensorVerdict::PositionError | SensorVerdict::Ghost) {
                println!(
                    "clean frame {k} flagged: id {} {} at ({:.1}, {:.1}) L{:.1} W{:.1} {:?} eta {:.2} own {:.2} vis {:.2} offset ({:.1}, {:.1})",
                    o.id, o.class.name(), o.x_m, o.y_m, o.length_m, o.width_m, r.sensor.verdict, r.sensor.eta,
                    r.sensor.eta_own, r.sensor.visible_fraction, r.sensor.offset_m[0], r.sensor.offset_m[1]
                );
            }
        }
        let confirmed: Vec<bool> =
            clean_report.objects.iter().map(|r| matches!(r.sensor.verdict, SensorVerdict::Consistent)).collect();
        let one_box = std::env::var("ONE_BOX").is_ok();
        let mut variants: Vec<(pmon_recording::RecordedFrame, Vec<usize>)> = Vec::new();
        if one_box {
            for (i, ok) in confirmed.iter().enumerate() {
                if !ok {
                    continue;
                }
                let mut f = df.frame.clone();
                if let Some(o) = f.objects.get_mut(i) {
                    let r = o.x_m.hypot(o.y_m).max(1e-3);
                    let (ux, uy) = (o.x_m / r, o.y_m / r);
                    o.x_m += magnitude_m * ux;
                    o.y_m += magnitude_m * uy;
                }
                variants.push((f, vec![i]));
            }
        } else {
            let mut f = df.frame.clone();
            let inj = injector.apply(k as u64, &mut f.objects);
            let idx = inj.iter().map(|x| x.index as usize).collect();
            variants.push((f, idx));
        }
        // With HISTORY=1: only frames that follow another sweep of the log (at most the monitor's `max_time_step_s`
        // earlier) are used, and each check of a displaced box (with ONE_BOX=1) or of the frame with every box
        // displaced is preceded by a check of that previous sweep, clean: the tracker was right one sweep ago and goes
        // wrong now (the onset of the error).
        let history = std::env::var("HISTORY").is_ok();
        let previous = k.checked_sub(1).and_then(|p| frames.get(p)).filter(|p| {
            let dt = df.frame.timestamp_s - p.frame.timestamp_s;
            dt > 0.0 && dt <= params.max_time_step_s
        });
        if history && previous.is_none() {
            continue;
        }
        for (f, inj) in &variants {
            if one_box || history {
                monitor.reset_tracks();
                if let Some(p) = previous.filter(|_| history) {
                    let mut proi = Vec::new();
                    monitor.check(&p.frame.as_frame(&mut proi))?;
                }
            }
            let mut roi = Vec::new();
            let view = f.as_frame(&mut roi);
            let rep = monitor.check(&view)?;
            let (rep_objects, rep_clusters) = (rep.objects.to_vec(), rep.clusters.to_vec());
            let band: Vec<[f32; 3]> = df.points_in_ego().into_iter().filter(|q| q[2] >= lo && q[2] <= hi).collect();
            // With HISTORY=1: the other boxes of the check are clean boxes after a clean sweep (step 9 runs on them).
            if history && one_box {
                for (i, r) in rep_objects.iter().enumerate() {
                    if !inj.contains(&i)
                        && matches!(r.sensor.verdict, SensorVerdict::PositionError | SensorVerdict::Ghost)
                    {
                        println!(
                            "clean box after a clean sweep flagged: frame {k} index {i} id {} {:?} (displaced: {inj:?})",
                            r.id, r.sensor.verdict
                        );
                        if std::env::var_os("DETAIL").is_some() {
                            // Where the flagged box and the displaced ones stand, and what flagged it.
                            let at = |j: usize| {
                                f.objects.get(j).map_or(String::new(), |o| {
                                    format!(
                                        "id {} ({:.1}, {:.1}) {:.1}x{:.1} m heading {:.2}",
                                        o.id, o.x_m, o.y_m, o.length_m, o.width_m, o.heading_rad
                                    )
                                })
                            };
                            let cluster = r.sensor.cluster.and_then(|c| rep_clusters.get(usize::from(c)));
                            println!(
                                "   flagged {} eta {:.2} own {:.2} offset ({:.2}, {:.2}) cluster {}",
                                at(i),
                                r.sensor.eta,
                                r.sensor.eta_own,
                                r.sensor.offset_m[0],
                                r.sensor.offset_m[1],
                                cluster.map_or("none (free space or memory)".to_string(), |c| format!(
                                    "{} cells at ({:.1}, {:.1})",
                                    c.cells, c.centroid_m[0], c.centroid_m[1]
                                ))
                            );
                            for &j in inj {
                                let v = rep_objects.get(j).map(|d| d.sensor.verdict);
                                println!("   displaced {} -> {v:?}", at(j));
                            }
                        }
                    }
                }
            }
            for (i, r) in rep_objects.iter().enumerate() {
                let injected = inj.contains(&i);
                if !injected || !confirmed.get(i).copied().unwrap_or(false) {
                    continue;
                }
                if matches!(
                    r.sensor.verdict,
                    SensorVerdict::NotMonitored(pmon_monitor::NotMonitoredReason::OutsideGrid)
                ) {
                    continue;
                }
                verifiable += 1;
                let flagged = matches!(r.sensor.verdict, SensorVerdict::PositionError | SensorVerdict::Ghost);
                detected += u64::from(flagged);
                let clean = &df.frame.objects[i];
                let moved = &f.objects[i];
                let fp = OrientedRect::new(
                    clean.x_m,
                    clean.y_m,
                    clean.heading_rad,
                    0.5 * clean.length_m,
                    0.5 * clean.width_m,
                );
                // Cells of the clean box's band returns.
                let mut cells: Vec<u32> = band
                    .iter()
                    .filter(|q| fp.contains(q[0], q[1]))
                    .filter_map(|q| geometry.point_to_cell(q[0], q[1]))
                    .collect();
                cells.sort_unstable();
                cells.dedup();
                let half = 0.5 * params.cell_size_m;
                // Separable: no cell of the clean box's own returns overlaps the displaced box's grown region (the
                // displacement exceeds the box's evidence along it plus the margins: the paper's dx_min case).
                let moved_region =
                    pmon_monitor::Region::of(moved, &moved.uncertainty.unwrap_or(params.default_uncertainty), &params);
                let separable = !cells.is_empty()
                    && !cells.iter().any(|&c| {
                        let (x, y) = geometry.cell_center(c);
                        moved_region.grown.overlaps_square(x, y, half)
                    });
                if separable {
                    separable_n += 1;
                    separable_detected += u64::from(flagged);
                }
                if flagged {
                    continue;
                }
                // Where the box's own returns are: cells whose centre lies in the ROI (none: the whole grid).
                let in_roi = cells
                    .iter()
                    .filter(|&&c| {
                        let (x, y) = geometry.cell_center(c);
                        f.roi_in_ego.is_empty()
                            || f.roi_in_ego.iter().any(|p| pmon_monitor::geometry::polygon_contains(p, x, y))
                    })
                    .count();
                let roi_share = match (in_roi, cells.len()) {
                    (_, 0) => "none",
                    (0, _) => "out",
                    (k, n) if k == n => "in",
                    _ => "part",
                };
                let hit_cluster = rep_clusters.iter().enumerate().find(|(_, c)| {
                    cells.iter().any(|&cell| {
                        let (x, y) = geometry.cell_center(cell);
                        x >= c.bounds_m[0] - half
                            && x <= c.bounds_m[2] + half
                            && y >= c.bounds_m[1] - half
                            && y <= c.bounds_m[3] + half
                    })
                });
                let range = clean.x_m.hypot(clean.y_m);
                let where_ev = match hit_cluster {
                    None => "evidence explained (no cluster)".to_string(),
                    Some((_, c)) => {
                        let ext = (c.bounds_m[2] - c.bounds_m[0]).max(c.bounds_m[3] - c.bounds_m[1]);
                        let diag = (clean.length_m + 1.5).hypot(clean.width_m + 1.5);
                        let who = match c.object {
                            None => "free".to_string(),
                            Some(o) if o as usize == i => "itself".to_string(),
                            Some(o) => {
                                format!("other({})", if inj.contains(&(o as usize)) { "displaced" } else { "clean" })
                            }
                        };
                        format!(
                            "cluster roi={} {} {}",
                            u8::from(c.in_roi),
                            who,
                            if ext > diag { "too-big" } else { "fits?" }
                        )
                    }
                };
                let key = format!(
                    "{:?} own{} sep{} cells-in-roi:{roi_share} | {}",
                    r.sensor.verdict,
                    u8::from(r.sensor.eta_own >= params.tau_tp),
                    u8::from(separable),
                    where_ev
                );
                if std::env::var("PMON_DEBUG").is_ok() {
                    println!(
                    "frame {k} id {} {} range {range:.1} at ({:.1},{:.1})->({:.1},{:.1}) L{:.1} W{:.1} eta {:.2} own {:.2} vis {:.2} cells {} | {key}",
                    r.id,
                    clean.class.name(),
                    clean.x_m,
                    clean.y_m,
                    moved.x_m,
                    moved.y_m,
                    clean.length_m,
                    clean.width_m,
                    r.sensor.eta,
                    r.sensor.eta_own,
                    r.sensor.visible_fraction,
                    cells.len()
                );
                }
                if std::env::var("RAYS").is_ok() {
                    let vis = monitor.visibility();
                    let o = vis.origin();
                    let mfp = moved_region.footprint;
                    let mut out = Vec::new();
                    for u in [-0.6f32, 0.0, 0.6] {
                        for v in [-0.6f32, 0.0, 0.6] {
                            let (lu, lv) = (u * mfp.half_length, v * mfp.half_width);
                            let (x, y) = (mfp.cx + lu * mfp.cos - lv * mfp.sin, mfp.cy + lu * mfp.sin + lv * mfp.cos);
                            let (dx, dy) = (x - o[0], y - o[1]);
                            let r = dx.hypot(dy);
                            let (ux, uy) = (dx / r, dy / r);
                            let e = entry(&mfp, o, ux, uy);
                            let eg = entry(&moved_region.grown, o, ux, uy);
                            match vis.nearest_obstacle(x, y) {
                                None => out.push("none".to_string()),
                                Some((near, cell)) => {
                                    let (cx, cy) = geometry.cell_center(cell);
                                    out.push(format!(
                                        "n{near:.1} e{e:.1} g{eg:.1} f{} t{}",
                                        monitor.grid().flags(cell),
                                        u8::from(fp.contains(cx, cy))
                                    ))
                                }
                            }
                        }
                    }
                    println!("   rays: {}", out.join(" | "));
                }
                if std::env::var_os("WHERE").is_some() {
                    let k2 = where_went(&monitor, &geometry, &params, f, i, &cells, &moved_region, separable);
                    if std::env::var("PMON_DEBUG").is_ok() {
                        println!("   where: {k2}");
                    }
                    *causes.entry(format!("{key} || {k2}")).or_default() += 1;
                } else {
                    *causes.entry(key).or_default() += 1;
                }
            }
            if let Some(w) = writer.as_mut() {
                w.write_frame(f)?;
            }
        }
    }
    if let Some(w) = writer {
        w.finish()?;
    }
    println!("{spec} {magnitude_m} m: detected {detected} of {verifiable} boxes consistent on the clean frame");
    println!(
        "  of them separable (no cell of the box's own returns in its displaced grown region): detected \
         {separable_detected} of {separable_n}"
    );
    let mut v: Vec<_> = causes.into_iter().collect();
    v.sort_by_key(|e| std::cmp::Reverse(e.1));
    for (k, n) in v {
        println!("{n:>5}  {k}");
    }
    Ok(())
}

/// `WHERE=1`: where the clean box's own returns went once it is displaced (each occupied cell of them: to the box
/// itself, explained by a neighbour's region, in a cluster taken by a neighbour, in a free cluster, or known
/// scenery / not occupied), and, for a box still confirmed, whose returns confirm it in its displaced region (cells
/// it owns there: its own clean returns, inside a neighbour's labelled box, or in no labelled box: scenery).
#[allow(clippy::too_many_arguments)]
fn where_went(
    monitor: &Monitor,
    geometry: &pmon_monitor::GridGeometry,
    params: &MonitorParams,
    f: &pmon_recording::RecordedFrame,
    i: usize,
    own_cells: &[u32],
    moved_region: &pmon_monitor::Region,
    separable: bool,
) -> String {
    let _ = separable;
    let occupied = |c: u32| monitor.grid().probability(c) > params.tau_fn;
    let (mut to_self, mut to_nb, mut nb_cluster, mut free, mut none) = (0, 0, 0, 0, 0);
    for &c in own_cells {
        if !occupied(c) {
            none += 1;
            continue;
        }
        let explained = monitor.grid().flags(c) & pmon_monitor::grid::FLAG_EXPLAINED != 0;
        match monitor.cell_attributed_to(c) {
            Some(o) if o as usize == i => to_self += 1,
            Some(_) if explained => to_nb += 1,
            Some(_) => nb_cluster += 1,
            None if explained => none += 1,
            None => free += 1,
        }
    }
    let mut own_out = String::new();
    for (n, name) in
        [(to_self, "self"), (to_nb, "nb-region"), (nb_cluster, "nb-cluster"), (free, "free"), (none, "none")]
    {
        if n > 0 {
            own_out.push_str(&format!("{name}{n} "));
        }
    }
    // Cells the displaced box owns (in its grown region), by where they stand.
    let boxes: Vec<OrientedRect> = f
        .objects
        .iter()
        .map(|o| OrientedRect::new(o.x_m, o.y_m, o.heading_rad, 0.5 * o.length_m, 0.5 * o.width_m))
        .collect();
    let (mut c_own, mut c_nb, mut c_scen) = (0, 0, 0);
    let half = 0.5 * params.cell_size_m;
    for c in 0..geometry.cell_count() as u32 {
        if !occupied(c) || monitor.cell_attributed_to(c) != Some(i as u32) {
            continue;
        }
        let (x, y) = geometry.cell_center(c);
        if !moved_region.grown.overlaps_square(x, y, half) {
            continue;
        }
        if own_cells.contains(&c) {
            c_own += 1;
        } else if boxes.iter().enumerate().any(|(j, b)| j != i && b.overlaps_square(x, y, half)) {
            c_nb += 1;
        } else {
            c_scen += 1;
        }
    }
    format!("own returns: {}| owned in displaced region: own{c_own} nb{c_nb} scenery{c_scen}", own_out)
}

fn entry(fp: &OrientedRect, origin: [f32; 2], ux: f32, uy: f32) -> f32 {
    let (px, py) = (origin[0] - fp.cx, origin[1] - fp.cy);
    let (ou, ov) = (px * fp.cos + py * fp.sin, -px * fp.sin + py * fp.cos);
    let (du, dv) = (ux * fp.cos + uy * fp.sin, -ux * fp.sin + uy * fp.cos);
    let (mut a, mut b) = (f32::NEG_INFINITY, f32::INFINITY);
    for (o, d, h) in [(ou, du, fp.half_length), (ov, dv, fp.half_width)] {
        if d.abs() < 1e-9 {
            if o.abs() > h {
                return f32::NAN;
            }
            continue;
        }
        let (t1, t2) = ((-h - o) / d, (h - o) / d);
        a = a.max(t1.min(t2));
        b = b.min(t1.max(t2));
    }
    if a <= b {
        a
    } else {
        f32::NAN
    }
}
