//! A sweep handed over as `[x, y, z]` records (`Monitor::check`) or as columns (`Monitor::check_columns`), and
//! what a caller whose points are columns pays today to copy them into records, side by side in one process
//! (docs/performance.md, *Structure-of-arrays input*):
//!
//! ```text
//! cargo build --release -p pmon-bench --example columns
//! target/release/examples/columns [synthetic|kitti|nuscenes|av2] [ITERATIONS]
//! valgrind --tool=callgrind target/release/examples/columns kitti 12   # then callgrind_annotate --inclusive=yes
//! ```
//!
//! Each iteration runs the three ways on the same frame, in an order that rotates (records, columns, copy; then
//! columns, copy, records; ...), with one monitor per way. Prints the medians of the rasterize stage and of the
//! whole sensor checks (rasterize to verdicts), and of the copy, in microseconds, and their ratios. The same
//! case names and frames as `pmon bench` (`PMON_DATA_DIR`, default `<workspace>/../shared/data`).

use std::process::ExitCode;
use std::time::Instant;

use pmon_bench::{Sequence, SyntheticSpec};
use pmon_monitor::{ColumnCloud, Frame, Monitor, MonitorParams, PointCloud, PointColumns, Stage};

/// Rasterize-stage and sensor-check time of one check, microseconds.
fn timed(check: impl FnOnce(&mut dyn FnMut(Stage)) -> bool) -> Option<(f64, f64)> {
    let start = Instant::now();
    let (mut rasterize, mut sensor, mut plausibility_start, mut plausibility) = (0.0, 0.0, 0.0, 0.0);
    let ok = check(&mut |stage| {
        let t = start.elapsed().as_secs_f64() * 1e6;
        match stage {
            Stage::Rasterize => rasterize = t,
            Stage::Conflicts => plausibility_start = t,
            Stage::Plausibility => plausibility = t - plausibility_start,
            Stage::Verdicts => sensor = t - plausibility,
            Stage::Regions => {}
        }
    });
    ok.then_some((rasterize, sensor))
}

#[inline(never)]
fn check_records(m: &mut Monitor, frame: &Frame<'_>, on: &mut dyn FnMut(Stage)) -> bool {
    m.check_with_stages(frame, on).is_ok()
}

#[inline(never)]
fn check_columns(m: &mut Monitor, frame: &Frame<'_>, cloud: &ColumnCloud<'_>, on: &mut dyn FnMut(Stage)) -> bool {
    m.check_columns_with_stages(frame, cloud, on).is_ok()
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let case = args.first().map_or("synthetic", String::as_str);
    let iterations: usize = args.get(1).and_then(|a| a.parse().ok()).unwrap_or(300);
    let data = pmon_bench::frames::data_dir();
    let seq = match case {
        "synthetic" => Some(Sequence::synthetic(&SyntheticSpec::BEAMS_64)),
        "kitti" => pmon_bench::frames::kitti_sweeps(&data)
            .ok()
            .and_then(|s| Sequence::real("kitti", s, &SyntheticSpec::BEAMS_64)),
        "nuscenes" => pmon_bench::frames::nuscenes_sweeps(&data)
            .ok()
            .and_then(|s| Sequence::real("nuscenes", s, &SyntheticSpec::BEAMS_32)),
        "av2" => pmon_bench::av2::sweeps(&data).ok().and_then(pmon_bench::av2::sequence),
        _ => None,
    };
    let Some(seq) = seq else {
        eprintln!("usage: columns [synthetic|kitti|nuscenes|av2] [ITERATIONS] (real data under {})", data.display());
        return ExitCode::from(2);
    };
    let columns = seq.sweep_columns();
    let Ok(mut monitors) = (0..3).map(|_| Monitor::new(MonitorParams::PAPER)).collect::<Result<Vec<_>, _>>() else {
        return ExitCode::FAILURE;
    };
    let mut records: Vec<[f32; 3]> = Vec::with_capacity(seq.max_points());
    // Per way: rasterize-stage and sensor-check samples; and the copy alone.
    let mut samples: [(Vec<f64>, Vec<f64>); 3] = Default::default();
    let mut copy_us = Vec::new();
    for i in 0..iterations + seq.frames.len() {
        let mut roi = Vec::new();
        let Some(frame) = seq.frame_with_roi(i, Sequence::timestamp_s(i), &mut roi) else { return ExitCode::FAILURE };
        let Some(sweep) = seq.frames.get(i % seq.frames.len()).and_then(|f| f.sweep) else { return ExitCode::FAILURE };
        let (Some([x, y, z]), Some(s)) = (columns.get(sweep), seq.sweeps.get(sweep)) else { return ExitCode::FAILURE };
        let Ok(points_in_sensor) = PointColumns::new(x, y, z) else { return ExitCode::FAILURE };
        let cloud = ColumnCloud { points_in_sensor, ego_from_sensor: s.ego_from_sensor };
        let without = Frame { cloud: None, ..frame };
        for k in 0..3 {
            let way = (i + k) % 3;
            let Some(m) = monitors.get_mut(way) else { return ExitCode::FAILURE };
            let t = match way {
                0 => timed(|on| check_records(m, &frame, on)),
                1 => timed(|on| check_columns(m, &without, &cloud, on)),
                _ => {
                    let start = Instant::now();
                    copy_into_records_from(x, y, z, &mut records);
                    let copy = start.elapsed().as_secs_f64() * 1e6;
                    let copied = Frame {
                        cloud: Some(PointCloud { points_in_sensor: &records, ego_from_sensor: s.ego_from_sensor }),
                        ..frame
                    };
                    let t = timed(|on| check_records(m, &copied, on));
                    if i >= seq.frames.len() {
                        copy_us.push(copy);
                    }
                    t.map(|(r, s)| (r + copy, s + copy))
                }
            };
            let Some((rasterize, sensor)) = t else { return ExitCode::FAILURE };
            if i >= seq.frames.len() {
                if let Some((r, s)) = samples.get_mut(way) {
                    r.push(rasterize);
                    s.push(sensor);
                }
            }
        }
    }
    let [(r0, s0), (r1, s1), (r2, s2)] = &mut samples;
    let (r0, s0, r1, s1, r2, s2) = (median(r0), median(s0), median(r1), median(s1), median(r2), median(s2));
    let copy = median(&mut copy_us);
    println!(
        "{case}: {} points, {iterations} iterations, medians us: rasterize records {r0:.1} columns {r1:.1} \
         (columns/records {:.3}), copy {copy:.1}, copy+rasterize {r2:.1} (columns/(copy+records) {:.3}); sensor \
         checks records {s0:.1} columns {s1:.1} ({:.3}), copy+records {s2:.1} ({:.3})",
        seq.max_points(),
        r1 / r0,
        r1 / r2,
        s1 / s0,
        s1 / s2
    );
    ExitCode::SUCCESS
}

/// The copy a caller with columns makes today: into `[x, y, z]` records (a buffer kept across frames).
#[inline(never)]
fn copy_into_records_from(x: &[f32], y: &[f32], z: &[f32], records: &mut Vec<[f32; 3]>) {
    records.clear();
    records.extend(x.iter().zip(y).zip(z).map(|((&x, &y), &z)| [x, y, z]));
}
