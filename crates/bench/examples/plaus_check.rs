//! Runs `Monitor::check` on the bench's 30-object lists without a cloud (case `objects-30/no-cloud`, or
//! `objects-30/no-cloud/calibrated` with `calibrated`; with `steady`, the steady traffic of case
//! `objects-30/steady`, resp. `objects-30/steady/calibrated`), for instruction counts of the plausibility checks
//! under callgrind (docs/plausibility.md):
//!
//! ```text
//! cargo build --release -p pmon-bench --example plaus_check
//! valgrind --tool=callgrind --collect-atstart=no --toggle-collect='*Monitor::check_inner*' \
//!     target/release/examples/plaus_check CHECKS [paper|calibrated] [wrap|steady]
//! ```
//!
//! `wrap` (the default) is the alarm-heavy worst case: its 6 frames are cycled, so every object jumps back every
//! 6th frame. `steady` is the realistic case the 5 us goal is judged on (no jump, no alarm).
//!
//! The first cycle through the sequence (its frames) fills the tracks and is not counted; then `CHECKS` counted
//! checks. Instructions per check: the difference of two runs' totals over the difference of their `CHECKS`.

use std::process::ExitCode;

use pmon_bench::{Sequence, SyntheticSpec};
use pmon_monitor::{Monitor, MonitorParams, PlausibilityMode};

fn main() -> ExitCode {
    let usage = "usage: plaus_check CHECKS [paper|calibrated] [wrap|steady]";
    let mut args = std::env::args().skip(1);
    let Some(Ok(checks)) = args.next().map(|a| a.parse::<usize>()) else {
        eprintln!("{usage}");
        return ExitCode::from(2);
    };
    let mode = match args.next().as_deref() {
        None | Some("paper") => PlausibilityMode::Paper,
        Some("calibrated") => PlausibilityMode::Calibrated,
        Some(_) => {
            eprintln!("{usage}");
            return ExitCode::from(2);
        }
    };
    let seq = match args.next().as_deref() {
        None | Some("wrap") => Sequence::synthetic(&SyntheticSpec::objects_only(30)),
        Some("steady") => Sequence::steady_traffic(30, pmon_bench::STEADY_SEED),
        Some(_) => {
            eprintln!("{usage}");
            return ExitCode::from(2);
        }
    };
    let p = MonitorParams { cell_size_m: 0.5, grid_size_m: 100.0, plausibility_mode: mode, ..MonitorParams::PAPER };
    let Ok(mut monitor) = Monitor::new(p) else {
        eprintln!("invalid parameters");
        return ExitCode::FAILURE;
    };
    let n = seq.frames.len();
    let mut implausible = 0usize;
    for i in 0..n + checks {
        let Some(f) = seq.frame(i, Sequence::timestamp_s(i)) else { return ExitCode::FAILURE };
        match monitor.check(&f) {
            Ok(r) => {
                implausible += r
                    .objects
                    .iter()
                    .filter(|o| matches!(o.motion.verdict, pmon_monitor::MotionVerdict::Implausible(_)))
                    .count();
            }
            Err(e) => {
                eprintln!("frame {i}: {e}");
                return ExitCode::FAILURE;
            }
        }
    }
    println!("{} checks, {implausible} implausible verdicts", n + checks);
    ExitCode::SUCCESS
}
