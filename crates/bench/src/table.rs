//! [`BenchReport::to_table`]: the report as plain text to paste into a bug report.

use pmon_monitor::Stage;

use crate::{alarm_rate, native, BenchReport, CaseReport, Timing};

impl BenchReport {
    /// A plain-text report to paste into a bug report: machine, frame sizes, per-stage medians, spreads, the
    /// paper's figures and the goals. ASCII only; times in microseconds.
    #[must_use]
    pub fn to_table(&self) -> String {
        use std::fmt::Write as _;
        let mut s = String::new();
        let m = &self.machine;
        let _ =
            writeln!(s, "pmon bench {} ({} build)", self.version, if m.optimized_build { "release" } else { "DEBUG" });
        let load = m.load_average_1min.map_or_else(|| "n/a".to_string(), |l| format!("{l:.2}"));
        let _ = writeln!(
            s,
            "machine: {} | {} logical cores | {} | load average {load} | single thread | rasterize loop: {} | native \
             floor: {}",
            m.cpu_model,
            m.logical_cores,
            m.platform,
            m.rasterizer,
            native::native_instruction_set()
        );
        let _ = writeln!(
            s,
            "iterations: {} per case (median; spread p10-p90); times in microseconds (us)\n",
            self.iterations
        );

        let w = self.cases.iter().map(|c| c.name.len()).max().unwrap_or(4).max(4);
        let _ = writeln!(s, "Frames");
        let _ = writeln!(
            s,
            "{:<w$} {:>7} {:>7} {:>7} {:>5} {:>5} {:>9} {:>9} {:>8} {:>7} {:>11}",
            "case",
            "frames",
            "points",
            "in band",
            "objs",
            "cell",
            "grid",
            "cells",
            "cell hit",
            "clusters",
            "alarms o/oo"
        );
        for c in &self.cases {
            let _ = writeln!(
                s,
                "{:<w$} {:>7} {:>7} {:>7} {:>5} {:>4}m {:>8}m {:>9} {:>8} {:>7} {:>11}",
                c.name,
                c.frames,
                c.points,
                c.points_in_band,
                c.objects,
                c.cell_size_m,
                c.grid_size_m,
                c.grid_cells,
                c.cells_hit,
                c.clusters,
                alarm_rate(c).map_or_else(|| "-".to_string(), |r| format!("{r:.1}"))
            );
        }

        let _ = writeln!(s, "\nMedian per stage (us)");
        let _ = write!(s, "{:<w$}", "case");
        for st in Stage::ALL {
            let _ = write!(s, " {:>12}", st.name());
        }
        let _ = writeln!(
            s,
            " {:>9} {:>9} {:>8} {:>8} {:>8} {:>8}",
            "sensor", "total", "floor", "sens/flr", "native", "sens/nat"
        );
        let opt = |t: Option<Timing>| t.map_or_else(|| "-".to_string(), |f| format!("{:.2}", f.median_us));
        let ratio = |r: Option<f64>| r.map_or_else(|| "-".to_string(), |r| format!("{r:.1}x"));
        for c in &self.cases {
            let _ = write!(s, "{:<w$}", c.name);
            for st in &c.stages {
                let _ = write!(s, " {:>12.2}", st.timing.median_us);
            }
            let _ = writeln!(
                s,
                " {:>9.2} {:>9.2} {:>8} {:>8} {:>8} {:>8}",
                c.sensor_checks.median_us,
                c.total.median_us,
                opt(c.floor),
                ratio(c.sensor_over_floor),
                opt(c.native_floor),
                ratio(c.sensor_over_native_floor)
            );
        }

        let _ = writeln!(
            s,
            "\nSpread p10-p90, worst case p99 and max (us); machine = p99/median of a fixed work of the same median, timed as often right after (the machine's own jitter); cpu = p99/median of the whole check in this thread's CPU time (lost time slices left out), beside the fixed work's"
        );
        let _ = writeln!(
            s,
            "{:<w$} {:>19} {:>9} {:>9} {:>9} {:>8} {:>8} {:>8} {:>8} {:>19} {:>19} {:>7}",
            "case",
            "sensor",
            "median",
            "p99",
            "max",
            "p99/med",
            "machine",
            "cpu",
            "mach cpu",
            "plausibility",
            "total",
            "samples"
        );
        let span = |t: &Timing| format!("{:.2}-{:.2}", t.p10_us, t.p90_us);
        let tail = |t: Option<Timing>| t.map_or("-".to_string(), |j| format!("{:.2}x", j.p99_over_median()));
        for c in &self.cases {
            let t = &c.sensor_checks;
            let _ = writeln!(
                s,
                "{:<w$} {:>19} {:>9.2} {:>9.2} {:>9.2} {:>7.2}x {:>8} {:>8} {:>8} {:>19} {:>19} {:>7}",
                c.name,
                span(t),
                t.median_us,
                t.p99_us,
                t.max_us,
                t.p99_over_median(),
                tail(c.jitter_reference),
                tail(c.check_cpu),
                tail(c.jitter_reference_cpu),
                span(&c.plausibility),
                span(&c.total),
                c.samples
            );
        }

        // Per frame, for the cases with a cloud that cycle through frames of different content.
        let framed: Vec<&CaseReport> = self.cases.iter().filter(|c| c.points > 0 && c.per_frame.len() > 1).collect();
        if !framed.is_empty() {
            let _ = writeln!(
                s,
                "\nSensor checks per frame of the cycle (us): content (the frames' medians) vs jitter (a frame's p99 / its median)"
            );
            let _ = writeln!(
                s,
                "{:<w$} {:>5} {:>8} {:>9} {:>9} {:>9} {:>9} {:>8} {:>7}",
                "case", "frame", "clusters", "median", "p99", "max", "p99/med", "cpu", "samples"
            );
            for c in framed {
                for f in &c.per_frame {
                    let t = &f.sensor_checks;
                    let _ = writeln!(
                        s,
                        "{:<w$} {:>5} {:>8} {:>9.2} {:>9.2} {:>9.2} {:>8.2}x {:>8} {:>7}",
                        c.name,
                        f.frame,
                        f.clusters,
                        t.median_us,
                        t.p99_us,
                        t.max_us,
                        t.p99_over_median(),
                        tail(f.check_cpu),
                        f.samples
                    );
                }
            }
        }

        if !self.paper.is_empty() {
            let _ = writeln!(
                s,
                "\nPaper (Buerkle et al., Sec. IV-G: averages; 100 m grid, 0.5 m cells; Python plausibility)"
            );
            for p in &self.paper {
                let _ = writeln!(
                    s,
                    "{:<34} {:<w$} here {:>9.2} us | {:<30} {:>8.0} us | {:>7.0}x faster here",
                    p.what, p.case, p.measured_us, p.paper_machine, p.paper_us, p.ratio
                );
            }
        }
        if !self.goals.is_empty() {
            let _ = writeln!(s, "\nGoals");
            for g in &self.goals {
                let _ = writeln!(s, "[{}] {}: {}", if g.met { "met" } else { "MISSED" }, g.goal, g.measured);
            }
        }
        if !self.notes.is_empty() {
            let _ = writeln!(s, "\nNotes");
            for n in &self.notes {
                let _ = writeln!(s, "- {n}");
            }
        }
        s
    }
}
