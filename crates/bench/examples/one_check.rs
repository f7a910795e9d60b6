//! Runs `Monitor::check` on the synthetic 64-beam frame (120,000 points, 100 objects, paper parameters), for
//! instruction counts under callgrind (see docs/performance.md):
//!
//! ```text
//! cargo build --release -p pmon-bench --example one_check
//! valgrind --tool=callgrind --collect-atstart=no --toggle-collect='*Monitor::check_with_stages*' \
//!     target/release/examples/one_check [CHECKS] [CELL_SIZE_M] [RASTERIZER] [kitti|av2]
//! ```
//!
//! With `kitti`, the six KITTI sweeps with the 64-beam object lists, as `pmon bench`'s `kitti/0.5m` case (read
//! from `PMON_DATA_DIR`, default `<workspace>/../shared/data`), instead of the synthetic frame; with `av2`, the
//! Argoverse 2 sweeps with their map's region of interest, as the `av2/0.5m` case.
//!
//! `RASTERIZER` is `blocked` (the default: AVX2 where the processor has it), `baseline` (the blocked loop on SSE2)
//! or `scalar` (the reference loop); see `pmon_monitor::Rasterizer`.
//!
//! `CHECKS` (default 1) checks run on consecutive frames of the sequence with one reused monitor; the instruction
//! count of one steady-state check is the difference between the runs with 2 and 1 checks.

use std::process::ExitCode;

use pmon_bench::{Sequence, SyntheticSpec};
use pmon_monitor::{Monitor, MonitorParams, Rasterizer};

fn main() -> ExitCode {
    let mut args = std::env::args().skip(1);
    let checks: usize = match args.next().map(|a| a.parse()) {
        None => 1,
        Some(Ok(n)) => n,
        Some(Err(_)) => {
            eprintln!("usage: one_check [CHECKS] [CELL_SIZE_M] [blocked|baseline|scalar]");
            return ExitCode::from(2);
        }
    };
    let cell_size_m: f32 = match args.next().map(|a| a.parse()) {
        None => 0.5,
        Some(Ok(c)) => c,
        Some(Err(_)) => {
            eprintln!("usage: one_check [CHECKS] [CELL_SIZE_M] [blocked|baseline|scalar]");
            return ExitCode::from(2);
        }
    };
    let rasterizer = match args.next().as_deref() {
        None | Some("blocked") => Rasterizer::Blocked,
        Some("baseline") => Rasterizer::BlockedBaseline,
        Some("scalar") => Rasterizer::Scalar,
        Some(other) => {
            eprintln!(
                "unknown rasterizer `{other}`; usage: one_check [CHECKS] [CELL_SIZE_M] [blocked|baseline|scalar]"
            );
            return ExitCode::from(2);
        }
    };
    let seq = match args.next().as_deref() {
        None => Sequence::synthetic(&SyntheticSpec::BEAMS_64),
        Some("kitti") => {
            match pmon_bench::frames::kitti_sweeps(&pmon_bench::frames::data_dir())
                .ok()
                .and_then(|s| Sequence::real("kitti", s, &SyntheticSpec::BEAMS_64))
            {
                Some(seq) => seq,
                None => {
                    eprintln!("error: no KITTI sweeps under {}", pmon_bench::frames::data_dir().display());
                    return ExitCode::FAILURE;
                }
            }
        }
        Some("av2") => {
            match pmon_bench::av2::sweeps(&pmon_bench::frames::data_dir()).ok().and_then(pmon_bench::av2::sequence) {
                Some(seq) => seq,
                None => {
                    eprintln!("error: no Argoverse 2 sweeps under {}", pmon_bench::frames::data_dir().display());
                    return ExitCode::FAILURE;
                }
            }
        }
        Some(other) => {
            eprintln!("unknown case `{other}`; usage: one_check [CHECKS] [CELL_SIZE_M] [RASTERIZER] [kitti|av2]");
            return ExitCode::from(2);
        }
    };
    let mut monitor = match Monitor::new(MonitorParams { cell_size_m, ..MonitorParams::PAPER }) {
        Ok(m) => m,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    };
    monitor.set_rasterizer(rasterizer);
    eprintln!("rasterizer: {}", rasterizer.instruction_set());
    for i in 0..checks {
        let Some(frame) = seq.frame(i, Sequence::timestamp_s(i)) else { return ExitCode::FAILURE };
        match monitor.check(&frame) {
            Ok(r) => println!(
                "check {i}: {} points, {} in band, {} cells hit, {} clusters, {} object alarms",
                r.grid.points_total,
                r.grid.points_in_band,
                r.grid.cells_hit,
                r.grid.clusters_total,
                r.object_alarms()
            ),
            Err(e) => {
                eprintln!("error: {e}");
                return ExitCode::FAILURE;
            }
        }
    }
    ExitCode::SUCCESS
}
