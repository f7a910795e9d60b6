//! `pmon calibrate`: a tracker's per-class noise from its own output, written as a parameter file for the
//! calibrated plausibility rule, with the expected false-alarm rate (issue #11; docs/plausibility.md).

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, Result};
use clap::Args;
use pmon_campaign::calibrate::{alarm_rate, AlarmRate, Calibration, ClassEstimate, Collector};
use pmon_datasets::roi::RoiMode;
use pmon_monitor::{MonitorParams, ObjectState, PlausibilityMode, Pose2};

use crate::check::{open_input, read_options};
use crate::config::params_from_str_over;
use crate::output::{OutputFile, FILE_TAG};

/// Arguments of `pmon calibrate`.
#[derive(Args, Debug)]
pub struct CalibrateArgs {
    /// The tracker's output: anything `pmon check` reads (a recording directory, a `.jsonl` object list, `-` for
    /// stdin, or a dataset spec such as `av2:LOG_DIR`, `commonroad:FILE.xml`).
    pub input: PathBuf,
    /// The parameter file to write (TOML). An existing file is replaced only if pmon wrote it, or with --force.
    #[arg(long, short)]
    pub out: PathBuf,
    /// Base parameters (TOML; `false_alarm_probability`, `baseline_s`, `warmup_frames`, ... are kept and
    /// written); defaults to the paper's Table I.
    #[arg(long)]
    pub params: Option<PathBuf>,
    /// Replace `--out` even when it is a file pmon did not write.
    #[arg(long)]
    pub force: bool,
    /// Also print the estimates as JSON on standard output.
    #[arg(long)]
    pub json: bool,
}

/// The object lists of an input, without clouds.
pub struct ObjectLog {
    /// `(timestamp, ego pose, objects)` per frame.
    pub frames: Vec<(f64, Pose2, Vec<ObjectState>)>,
}

impl ObjectLog {
    fn iter(&self) -> impl Iterator<Item = (f64, Pose2, &[ObjectState])> {
        self.frames.iter().map(|(t, p, o)| (*t, *p, o.as_slice()))
    }
}

/// Estimates the noise of a log and returns the calibration and the parameter file's text.
pub fn calibrate_log(log: &ObjectLog, base: &MonitorParams, source: &str) -> Result<(Calibration, String)> {
    let mut c = Collector::new(base);
    for (t, pose, objects) in log.iter() {
        c.add_frame(t, &pose, objects);
    }
    let cal = c.finish();
    let draft = params_text(&cal, source, None, None);
    let written = params_from_str_over(*base, &draft).map_err(|e| anyhow::anyhow!("internal: {e}"))?;
    written.validate().map_err(|e| anyhow::anyhow!("internal: the estimated parameters are invalid: {e}"))?;
    let default_noise = MonitorParams { plausibility_mode: PlausibilityMode::Calibrated, ..*base };
    let before = alarm_rate(&default_noise, log.iter()).map_err(|e| anyhow::anyhow!("{source}: {e}"))?;
    let after = alarm_rate(&written, log.iter()).map_err(|e| anyhow::anyhow!("{source}: {e}"))?;
    let text = params_text(&cal, source, Some(&before), Some(&after));
    Ok((cal, text))
}

fn class_lines(s: &mut String, c: &ClassEstimate) {
    let v = |x: &pmon_campaign::calibrate::Value| {
        if x.samples > 0 {
            format!("{:.4} ({} samples)", x.value, x.samples)
        } else {
            format!("{:.4} ({})", x.value, x.source)
        }
    };
    let _ = writeln!(
        s,
        "#   {:<13} {:>6} tracks {:>8} states: position {}, standstill {}, speed {}, heading {}",
        c.class,
        c.tracks,
        c.states,
        v(&c.position_m),
        v(&c.standstill_position_m),
        v(&c.speed_mps),
        v(&c.heading_rad)
    );
    for b in c.bands.iter().filter(|b| b.states > 0) {
        let o = |x: Option<f32>| x.map_or_else(|| "   -  ".to_string(), |x| format!("{x:.4}"));
        let hi = if b.to_mps.is_finite() { format!("{:>4.1}", b.to_mps) } else { " inf".into() };
        let _ = writeln!(
            s,
            "#     {:>4.1}-{hi} m/s {:>8} states: position {}, speed {}, heading {}",
            b.from_mps,
            b.states,
            o(b.position_m),
            o(b.speed_mps),
            o(b.heading_rad)
        );
    }
}

fn rate_lines(s: &mut String, label: &str, r: &AlarmRate) {
    let _ = write!(s, "#   {label}: {:.2} per mille of {} judged states", AlarmRate::per_mille(r.all), r.all.0);
    for (class, c) in &r.per_class {
        let _ = write!(s, "; {class} {:.2}", AlarmRate::per_mille(*c));
    }
    let _ = writeln!(s);
}

fn noise_table(s: &mut String, n: &pmon_monitor::TrackerNoise) {
    let _ = writeln!(s, "position_m = {:.4}", n.position_m);
    let _ = writeln!(s, "standstill_position_m = {:.4}", n.standstill_position_m);
    let _ = writeln!(s, "speed_mps = {:.4}", n.speed_mps);
    let _ = writeln!(s, "heading_rad = {:.4}", n.heading_rad);
}

/// The parameter file: comments with the estimates and rates, then the keys.
fn params_text(cal: &Calibration, source: &str, before: Option<&AlarmRate>, after: Option<&AlarmRate>) -> String {
    let p = cal.params();
    let mut s = String::new();
    let _ =
        writeln!(s, "# Written by pmon calibrate ({FILE_TAG}) from {source}: the tracker's noise (1 sigma), estimated");
    let _ = writeln!(s, "# from its own output (docs/plausibility.md). Use with: pmon check INPUT --params THIS_FILE");
    let _ = writeln!(
        s,
        "# {} object states read, {} left out (invalid, duplicate ids, time not increasing).",
        cal.states_read, cal.states_skipped
    );
    let _ = writeln!(s, "# Estimates (value, samples or where it came from) and the same per band of reported speed:");
    class_lines(&mut s, &cal.all);
    for c in &cal.per_class {
        class_lines(&mut s, c);
    }
    let _ = writeln!(
        s,
        "# Expected false alarms: at most about 4 x false_alarm_probability = {:.2} per mille of states if the noise",
        4000.0 * p.false_alarm_probability
    );
    let _ = writeln!(
        s,
        "# is Gaussian with these sigmas (four gates). Measured on the input itself (every alarm, the tracker's"
    );
    let _ = writeln!(s, "# real errors included: an upper bound of its false alarms), calibrated rule:");
    if let Some(b) = before {
        rate_lines(&mut s, "with the default noise", b);
    }
    if let Some(a) = after {
        rate_lines(&mut s, "with these parameters  ", a);
    }
    let _ = writeln!(s, "plausibility_mode = \"calibrated\"");
    let _ = writeln!(s, "false_alarm_probability = {:?}", p.false_alarm_probability);
    let _ = writeln!(s, "baseline_s = {:?}", p.baseline_s);
    let _ = writeln!(s, "warmup_frames = {}", p.warmup_frames);
    let _ = writeln!(s, "warmup_speed_sigma_mps = {:?}", p.warmup_speed_sigma_mps);
    let _ = writeln!(s, "heading_min_speed_mps = {:?}", p.heading_min_speed_mps);
    let _ = writeln!(s, "max_time_step_s = {:?}", p.max_time_step_s);
    let _ = writeln!(s, "\n[tracker_noise]");
    noise_table(&mut s, &p.tracker_noise);
    for c in &cal.per_class {
        if let Some(class) = pmon_monitor::ObjectClass::ALL.iter().find(|k| k.name() == c.class) {
            if let Some(n) = p.per_class_noise.get(*class) {
                let _ = writeln!(s, "\n[per_class_noise.{}]", c.class);
                noise_table(&mut s, &n);
            }
        }
    }
    s
}

/// Reads an input's object lists (clouds dropped).
pub fn read_log(input: &std::path::Path) -> Result<(String, ObjectLog, MonitorParams)> {
    let opts = read_options(RoiMode::WholeGrid, 0.0, MonitorParams::default().grid_size_m);
    let (name, inp) = open_input(input, &opts)?;
    let base = inp.base_params;
    let mut frames = Vec::new();
    for f in inp.iter {
        let f = f?;
        frames.push((f.timestamp_s, f.world_from_ego, f.objects));
    }
    if frames.is_empty() {
        anyhow::bail!("{}: no frames: nothing to calibrate", input.display());
    }
    Ok((name, ObjectLog { frames }, base))
}

/// `pmon calibrate`.
pub fn run(args: &CalibrateArgs) -> Result<ExitCode> {
    if crate::bag::is_mcap(&args.input) {
        anyhow::bail!(
            "{}: pmon calibrate reads recordings, .jsonl object lists and dataset specs; convert a bag first \
             (docs/ros2.md)",
            args.input.display()
        );
    }
    let out = OutputFile::prepare(&args.out, "calibrate", args.force)?;
    let (name, log, input_base) = read_log(&args.input)?;
    let base = crate::config::load_params_over(input_base, args.params.as_deref())?;
    let source = format!("{} ({name})", args.input.display());
    let (cal, text) = calibrate_log(&log, &base, &source)?;
    std::fs::write(out.path(), &text).with_context(|| format!("cannot write {}", out.path().display()))?;
    out.commit()?;
    let mut stdout = std::io::stdout().lock();
    if args.json {
        writeln!(stdout, "{}", serde_json::to_string_pretty(&cal)?)?;
    } else {
        for line in text.lines().take_while(|l| l.starts_with('#')) {
            writeln!(stdout, "{}", line.trim_start_matches("# ").trim_start_matches('#'))?;
        }
    }
    eprintln!("wrote {}", args.out.display());
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use pmon_campaign::tracker::TrackerModelConfig;
    use pmon_campaign::tracker_eval::{run_bed, tracker_output};

    use super::*;

    /// The tracker model's output on a built-in scene, as a log.
    fn bed_log(scene: &pmon_campaign::run::Scene, cfg: TrackerModelConfig) -> ObjectLog {
        let frames = scene
            .frames
            .iter()
            .zip(tracker_output(scene, cfg))
            .map(|(f, (objects, _))| (f.timestamp_s, f.world_from_ego, objects))
            .collect();
        ObjectLog { frames }
    }

    #[test]
    fn calibrate_recovers_known_white_noise_despite_glitches() {
        // Known noise, white (no frame-to-frame correlation), with the bed's glitches (warm-ups, re-fits, id
        // switches, flips, jumps, drop-outs) at their default rates.
        let mut cfg = TrackerModelConfig::new(21);
        cfg.jitter_correlation = 0.0;
        cfg.jitter_moving_m = 0.12;
        cfg.jitter_standstill_m = 0.3;
        cfg.speed_noise_mps = 0.3;
        cfg.heading_noise_rad = 0.04;
        let scenes = crate::tracker_bed::object_scenes(21, 60.0).unwrap();
        let log = bed_log(&scenes[1], cfg); // the intersection at 10 Hz: cars, trucks, pedestrians
        let (cal, text) = calibrate_log(&log, &MonitorParams::default(), "bed").unwrap();
        let all = &cal.all;
        let within = |got: f32, want: f64, tol: f64| (f64::from(got) - want).abs() <= tol * want;
        assert!(within(all.position_m.value, 0.12, 0.25), "{all:?}");
        assert!(within(all.standstill_position_m.value, 0.3, 0.25), "{all:?}");
        assert!(within(all.speed_mps.value, 0.3, 0.2), "{all:?}");
        assert!(within(all.heading_rad.value, 0.04, 0.25), "{all:?}");
        assert!(text.contains("plausibility_mode = \"calibrated\"") && text.contains("[tracker_noise]"));
    }

    #[test]
    fn calibrated_parameters_on_benign_tracker_output() {
        // The bed's default tracker (correlated jitter and speed noise): calibrated on one run, scored on
        // another seed. The goal of issue #11 is <= 1 per mille over the bed; measured 0.88 per mille over the three
        // scenes (0.65-1.07 per scene, 60 s each; 0.84 before the robust own speed scatter, 1.36 before the held flip
        // asked the box's motion): the tighter
        // estimated sigmas expose the simulated pedestrians' instant starts and stops (10-17 m/s^2, true motion
        // that no physical limit admits, labelled benign), true speeds hidden by warm-ups below the bed's 1 m/s
        // label, and echoes of drop-outs in the following baselines. Per scene the assertion is the measured
        // level with a margin; over the three scenes it is the goal.
        let train = crate::tracker_bed::object_scenes(31, 60.0).unwrap();
        let test = crate::tracker_bed::object_scenes(32, 60.0).unwrap();
        let mut results = Vec::new();
        for (i, (tr, te)) in train.iter().zip(&test).enumerate() {
            let log = bed_log(tr, TrackerModelConfig::new(100 + i as u64));
            let (_, text) = calibrate_log(&log, &MonitorParams::default(), "bed").unwrap();
            let params = params_from_str_over(MonitorParams::default(), &text).unwrap();
            let r = run_bed(te, &params, TrackerModelConfig::new(200 + i as u64)).unwrap();
            results.push(r);
        }
        eprintln!("{}", pmon_campaign::tracker_eval::bed_table(&results));
        let (alarms, judged) =
            results.iter().fold((0, 0), |(a, j), r| (a + r.all.benign_alarms, j + r.all.benign_judged));
        assert!(alarms * 1000 <= judged, "{alarms} false alarms on {judged} benign states: above 1 per mille");
        for r in &results {
            let fa = r.all.false_alarm_rate();
            assert!(r.all.benign_judged > 10_000, "{}: {:?}", r.scene, r.all);
            assert!(fa.value <= 1.5e-3, "{}: {:.2} per mille {:?}", r.scene, 1000.0 * fa.value, r.all);
            assert!(r.all.recall().value >= 0.9, "{}: {:?}", r.scene, r.all);
        }
    }
}
