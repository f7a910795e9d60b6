//! `pmon reproduce`: every experiment of the paper on the built-in scenarios, and a report.

use std::fmt::Write as _;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{bail, Context, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use pmon_campaign::experiments::{self, Claim, Figure, PlannedRun, Scale, SceneIds};
use pmon_campaign::sim_tasks::{self, SceneSpec};
use pmon_campaign::{replay_to, run_all, Direction, Fault, RunResult, RunSpec, Scene};
use pmon_monitor::theory::{dv_min_mps, Margins, SpeedError};
use pmon_monitor::{Frame, Monitor, MonitorParams, ObjectClass, ObjectState, Pose2, Uncertainty};
use pmon_report::{BarChart, BarGroup, CellClass, HtmlReport, LineChart, RefLine, Series, TableCell};
use serde::Serialize;

use crate::config::load_params;
use crate::output::OutputDir;
use crate::run_dir::{self, run_python, RunDir};
use crate::view::{top_view, write_view, Checked};

/// Arguments of `pmon reproduce`.
#[derive(Args, Debug, Clone)]
pub struct ReproduceArgs {
    /// Output folder for the report (index.html, figures as SVG and PNG, CSV data, results.json).
    #[arg(long, short, default_value = "pmon-report")]
    pub out: PathBuf,
    /// Coarser sweeps over shorter scenes: a few minutes on 2 cores, for first contact and CI.
    #[arg(long)]
    pub quick: bool,
    /// Seed of the scenes and of every injection.
    #[arg(long, default_value_t = 7)]
    pub seed: u64,
    /// Monitor parameters (TOML) for every run, or a profile pmon ships (`profile:recall`); defaults to the
    /// paper's Table I. (The 0.2 m cell curves override the cell size only.)
    #[arg(long)]
    pub params: Option<PathBuf>,
    /// Length of each simulated scene, seconds (default: the scenario's own, 15 s with --quick).
    #[arg(long)]
    pub duration_s: Option<f64>,
    /// Three points per sweep over 3 s scenes: checks the pipeline end to end (tests), no conclusions.
    #[arg(long, hide = true)]
    pub smoke: bool,
    /// Folder of the real driving data (KITTI, nuScenes, Argoverse 2, CommonRoad extracts in their native
    /// layouts). Default: `$PMON_DATA_DIR`, else `../shared/data`. Absent: the real-data section is skipped.
    #[arg(long)]
    pub data: Option<PathBuf>,
    /// Worker threads (default: all cores). Results do not depend on it.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Replace `--out` even when it holds files pmon reproduce did not write.
    #[arg(long)]
    pub force: bool,
    /// Also write the paper-vs-pmon table into this Markdown file (the README), between its two marker lines
    /// (`<!-- paper-vs-pmon:begin ... -->`, `<!-- paper-vs-pmon:end -->`), with the run's seed and scale.
    #[arg(long, value_name = "FILE")]
    pub readme: Option<PathBuf>,
    /// Where the simulated runs go: `local` (this process, `--threads` at a time), or, through the Python package
    /// (`--python`), `dask://HOST:PORT`, `dask-local:N`, `ray`, `ray://HOST:PORT`, `ray-local:N`: one task per run,
    /// the same results (docs/campaigns.md). The real-data experiments, latency and examples run here.
    #[arg(long, default_value = "local")]
    pub scheduler: String,
    /// Run folder of a `--scheduler` run other than `local`: the tasks (`tasks.json`) and one result per finished
    /// task; a rerun with the same folder runs only the missing tasks. Default: OUT.run beside the report.
    #[arg(long)]
    pub run_dir: Option<PathBuf>,
    /// The Python interpreter with the `pmon` package (and dask or ray). Default: `$PMON_PYTHON`, else `python3`.
    #[arg(long)]
    pub python: Option<PathBuf>,
    /// No progress display (by default bars on a terminal).
    #[arg(long, short)]
    pub quiet: bool,
}

#[derive(Serialize)]
struct SceneSummary {
    name: String,
    source: String,
    frames: usize,
    object_states: usize,
    mean_points: f64,
}

#[derive(Serialize)]
struct TheoryCheck {
    kind: &'static str,
    dt_s: f64,
    speed_mps: f64,
    dv_min_mps: f64,
    flagged_below: bool,
    flagged_above: bool,
}

#[derive(Serialize)]
struct Results<'a> {
    pmon_version: &'static str,
    scale: &'static str,
    seed: u64,
    params: &'a MonitorParams,
    scenes: Vec<SceneSummary>,
    claims: &'a [Claim],
    figures: &'a [Figure],
    latency_ms: Option<(f64, f64)>,
    theory_checks: &'a [TheoryCheck],
    real_data: &'a pmon_campaign::real_data::RealDataResults,
    runs: usize,
    elapsed_s: f64,
}

fn bar(len: u64, what: &str) -> ProgressBar {
    let pb = ProgressBar::new(len);
    if let Ok(style) = ProgressStyle::with_template("{prefix:>12} [{bar:40}] {pos}/{len} ({eta} left)") {
        pb.set_style(style.progress_chars("=> "));
    }
    pb.set_prefix(what.to_string());
    pb
}

/// Simulates the built-in scenes of `pmon reproduce` (`pmon_campaign::sim_tasks::scenario_config`): the
/// pedestrian street, the intersection, the street at 20 Hz and the street under the paper's conditions.
pub fn build_scenes(specs: &[SceneSpec], quiet: bool) -> Result<Vec<Scene>> {
    let mut scenes = Vec::new();
    for spec in specs {
        let pb = if quiet { ProgressBar::hidden() } else { bar(0, &spec.name) };
        let scene = sim_tasks::simulate(spec, &|done, total| {
            pb.set_length(total);
            pb.set_position(done);
        })
        .map_err(|e| anyhow::anyhow!(e))?;
        pb.finish_and_clear();
        scenes.push(scene);
    }
    Ok(scenes)
}

/// The simulated runs as tasks of a run folder, run on a scheduler through the Python package; their results in
/// plan order (the same counts as [`run_all`]: each task runs [`pmon_campaign::run_one`] on its own scene).
fn run_on_scheduler(args: &ReproduceArgs, planned: &[PlannedRun], scenes: &[SceneSpec]) -> Result<Vec<RunResult>> {
    let tp = sim_tasks::tasks(planned, scenes).map_err(|e| anyhow::anyhow!(e))?;
    let run_dir = args.run_dir.clone().unwrap_or_else(|| {
        let mut name = args.out.file_name().map(std::ffi::OsStr::to_os_string).unwrap_or_else(|| "pmon-report".into());
        name.push(".run");
        args.out.with_file_name(name)
    });
    let run = RunDir::prepare(&run_dir, &tp.tasks, args.force, "pmon reproduce")?;
    let finished = |t: &sim_tasks::SimTask| {
        run.result::<sim_tasks::TaskResult>(&t.id).is_some_and(|r| matches!(r.outcome, sim_tasks::Outcome::Ok(_)))
    };
    let todo = tp.tasks.iter().filter(|t| !finished(t)).count();
    eprintln!(
        "pmon reproduce: {} runs as {} tasks, {} finished in {}, {todo} to run ({})",
        planned.len(),
        tp.tasks.len(),
        tp.tasks.len() - todo,
        run_dir.display(),
        args.scheduler
    );
    if todo > 0 {
        run_python(&run_dir::python(args.python.as_deref()), &run, &args.scheduler, args.quiet)?;
    }
    let mut outputs = Vec::with_capacity(tp.tasks.len());
    let mut problems = Vec::new();
    for t in &tp.tasks {
        match run.result::<sim_tasks::TaskResult>(&t.id).map(|r| r.outcome) {
            Some(sim_tasks::Outcome::Ok(o)) => outputs.push(Some(o.to_run_result())),
            Some(sim_tasks::Outcome::Error(e)) => {
                problems.push(e);
                outputs.push(None);
            }
            None => {
                problems.push(format!("{}: no result in {}", t.id, run.result_path(&t.id).display()));
                outputs.push(None);
            }
        }
    }
    if !problems.is_empty() {
        let shown: Vec<&str> = problems.iter().take(5).map(String::as_str).collect();
        bail!(
            "{} of {} tasks have no result (rerun to run only those): {}{}",
            problems.len(),
            tp.tasks.len(),
            shown.join("; "),
            if problems.len() > shown.len() { "; ..." } else { "" }
        );
    }
    Ok(tp.task_of_run.iter().filter_map(|&i| outputs.get(i).cloned().flatten()).collect())
}

/// Median sensor-check and plausibility-check time per frame over the scenes, milliseconds.
fn latency(scenes: &[Scene], params: &MonitorParams) -> Result<(f64, f64)> {
    let mut sensor = Vec::new();
    let mut plaus = Vec::new();
    for scene in scenes {
        let mut monitor = Monitor::new(*params).map_err(|e| anyhow::anyhow!("{e}"))?;
        for f in &scene.frames {
            let mut polygons = Vec::new();
            let view = f.as_frame(&mut polygons);
            let (_, us) = pmon_bench::timed_check(&mut monitor, &view).map_err(|e| anyhow::anyhow!("{e}"))?;
            // Stages: rasterize, regions, conflicts, plausibility, verdicts; all but plausibility are the sensor
            // checks.
            sensor.push((us[0] + us[1] + us[2] + us[4]) / 1e3);
            plaus.push(us[3] / 1e3);
        }
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
    };
    Ok((median(&mut sensor), median(&mut plaus)))
}

/// Checks the analytic dv_min against the monitor itself: two frames of one object, errors just below and
/// just above the bound.
fn theory_checks(params: &MonitorParams) -> Result<Vec<TheoryCheck>> {
    let m = Margins::PAPER;
    let u = Uncertainty {
        x_m: m.position_m as f32,
        y_m: m.position_m as f32,
        heading_rad: m.heading_rad as f32,
        speed_mps: m.speed_mps as f32,
        length_m: 0.0,
        width_m: 0.0,
    };
    let mut out = Vec::new();
    for (kind, name) in [(SpeedError::Permanent, "permanent"), (SpeedError::Transient, "transient")] {
        for dt in [0.05, 0.1, 0.2] {
            for v in [0.5, 2.0, 5.0, 10.0, 20.0] {
                let Some(dv) = dv_min_mps(kind, dt, v, params, &m, 0.02, 60.0) else { continue };
                let flagged = |dv: f64| -> Result<bool> {
                    let mut mon = Monitor::new(*params).map_err(|e| anyhow::anyhow!("{e}"))?;
                    let err = (v + dv).abs() as f32;
                    let (v0, v1) = match kind {
                        SpeedError::Permanent => (err, err),
                        SpeedError::Transient => (v as f32, err),
                    };
                    let o = |x: f32, s: f32| ObjectState {
                        id: 1,
                        class: ObjectClass::Car,
                        x_m: x,
                        y_m: 0.0,
                        heading_rad: 0.0,
                        speed_mps: s,
                        length_m: 4.0,
                        width_m: 1.8,
                        uncertainty: Some(u),
                    };
                    let f0 = [o(10.0, v0)];
                    let f1 = [o(10.0 + (v * dt) as f32, v1)];
                    let mut mk = |t: f64, objs: &[ObjectState]| -> Result<bool> {
                        let frame = Frame {
                            timestamp_s: t,
                            world_from_ego: Pose2::default(),
                            objects: objs,
                            cloud: None,
                            roi_in_ego: &[],
                            static_in_ego: &[],
                        };
                        let r = mon.check(&frame).map_err(|e| anyhow::anyhow!("{e}"))?;
                        Ok(r.objects.first().is_some_and(|o| o.verdict.is_alarm()))
                    };
                    mk(0.0, &f0)?;
                    mk(dt, &f1)
                };
                out.push(TheoryCheck {
                    kind: name,
                    dt_s: dt,
                    speed_mps: v,
                    dv_min_mps: dv,
                    flagged_below: flagged(0.97 * dv)?,
                    flagged_above: flagged(1.03 * dv)?,
                });
            }
        }
    }
    Ok(out)
}

/// A curve's series: its points, and as the shaded band its 95 % interval by track when every point has one (the
/// states of a track are not independent, docs/evaluation.md, "Scoring"), the interval over states otherwise.
fn series_of(curve: &experiments::Curve, color: usize) -> Series {
    let shown = || curve.points.iter().filter(|p| p.rate.n > 0);
    let pts = shown().map(|p| (p.x, p.rate.value)).collect();
    let by_track: Option<Vec<_>> = shown().map(|p| p.by_track.as_ref().map(|t| (p.x, t.lo, t.hi))).collect();
    let band =
        by_track.filter(|b| !b.is_empty()).unwrap_or_else(|| shown().map(|p| (p.x, p.rate.lo, p.rate.hi)).collect());
    let mut s = Series::new(curve.label.clone(), pts)
        .with_band(band)
        .with_markers()
        .with_color(pmon_report::SeriesColor::Palette(color));
    if curve.dashed {
        s = s.dashed();
    }
    s
}

pub fn render_figure(dir: &Path, fig: &Figure) -> Result<()> {
    let s = &fig.spec;
    let mut chart = LineChart::new(format!("{} ({})", s.title, s.paper_ref), &s.x_label, &s.y_label)
        .with_y_range(s.y_range.0, s.y_range.1);
    for (i, c) in fig.curves.iter().enumerate() {
        chart = chart.with_series(series_of(c, i));
    }
    for (horizontal, v, label) in &s.refs {
        chart = chart.with_ref_line(if *horizontal {
            RefLine::horizontal(*v, label)
        } else {
            RefLine::vertical(*v, label)
        });
    }
    chart.render_svg(dir.join(format!("{}.svg", s.id)))?;
    chart.render_png(dir.join(format!("{}.png", s.id)), 1600, 1000)?;
    // Curves that lie flat on zero beside a large one (the sensor false alarms beside the white-noise
    // plausibility ones) get a zoomed companion figure with only them, its y axis fitted to their data.
    let top = |c: &experiments::Curve| c.points.iter().map(|p| p.rate.hi).fold(0.0f64, f64::max);
    let highest = fig.curves.iter().map(top).fold(0.0f64, f64::max);
    let small: Vec<usize> = (0..fig.curves.len()).filter(|&i| top(&fig.curves[i]) < 0.1 * highest).collect();
    if !small.is_empty() && small.len() < fig.curves.len() {
        let small_top = small.iter().map(|&i| top(&fig.curves[i])).fold(0.0f64, f64::max);
        let mut zoom = LineChart::new(format!("{} — zoom on the curves near zero", s.title), &s.x_label, &s.y_label)
            .with_y_range(0.0, (1.15 * small_top).max(1e-4));
        for &i in &small {
            zoom = zoom.with_series(series_of(&fig.curves[i], i));
        }
        zoom.render_svg(dir.join(format!("{}_zoom.svg", s.id)))?;
        zoom.render_png(dir.join(format!("{}_zoom.png", s.id)), 1600, 1000)?;
    }
    // Curves that all lie near one (precision) sit on top of each other at full scale: a companion figure with
    // the y axis from just under their lowest value above 0.9 to 1 separates them; points further down are off it.
    let near_one = |c: &experiments::Curve| {
        let high = c.points.iter().filter(|p| p.rate.value >= 0.9).count();
        !c.points.is_empty() && high * 4 >= c.points.len() * 3
    };
    if fig.curves.len() >= 2 && fig.curves.iter().all(near_one) && s.y_range.1 <= 1.05 {
        let lo = fig
            .curves
            .iter()
            .flat_map(|c| c.points.iter())
            .filter(|p| p.rate.value >= 0.9)
            .map(|p| p.rate.value)
            .fold(1.0f64, f64::min);
        let lo = ((lo - 0.02) * 100.0).floor() / 100.0;
        let mut top = LineChart::new(format!("{} — zoom on the top (same data)", s.title), &s.x_label, &s.y_label)
            .with_y_range(lo.clamp(0.5, 0.99), s.y_range.1.max(1.0));
        for (i, c) in fig.curves.iter().enumerate() {
            top = top.with_series(series_of(c, i));
        }
        top.render_svg(dir.join(format!("{}_top.svg", s.id)))?;
        top.render_png(dir.join(format!("{}_top.png", s.id)), 1600, 1000)?;
    }
    // The data behind the figure, with counts and intervals: over object states, and clustered by track where the
    // counts are kept per track (empty otherwise); those clusters in `<figure>_tracks.csv`.
    let mut rows = Vec::new();
    let mut tracks = Vec::new();
    for c in &fig.curves {
        for p in &c.points {
            let by_track = p.by_track.map_or([String::new(), String::new(), String::new()], |t| {
                [t.clusters.to_string(), format!("{:.6}", t.lo), format!("{:.6}", t.hi)]
            });
            rows.push(
                [
                    c.label.clone(),
                    format!("{}", p.x),
                    format!("{}", p.rate.k),
                    format!("{}", p.rate.n),
                    format!("{:.6}", p.rate.value),
                    format!("{:.6}", p.rate.lo),
                    format!("{:.6}", p.rate.hi),
                ]
                .into_iter()
                .chain(by_track)
                .collect::<Vec<_>>(),
            );
            for t in &p.clusters {
                let (run, track, k, n) = (t.run, t.track, t.k, t.n);
                tracks.push([
                    c.label.clone(),
                    format!("{}", p.x),
                    format!("{run}"),
                    format!("{track}"),
                    format!("{k}"),
                    format!("{n}"),
                ]);
            }
        }
    }
    pmon_report::write_csv(
        dir.join(format!("{}.csv", s.id)),
        &["curve", "x", "k", "n", "rate", "ci95_lo", "ci95_hi", "tracks", "ci95_tracks_lo", "ci95_tracks_hi"],
        &rows,
    )?;
    if fig.curves.iter().any(|c| c.points.iter().any(|p| p.by_track.is_some())) {
        pmon_report::write_csv(
            dir.join(format!("{}_tracks.csv", s.id)),
            &["curve", "x", "run", "track", "k", "n"],
            &tracks,
        )?;
    }
    // The sensor alarms behind the figure by the test that raised them (`causes.rs`).
    crate::causes::write(dir, fig)?;
    Ok(())
}

fn render_theory(dir: &Path, params: &MonitorParams) -> Result<()> {
    let speeds: Vec<f64> = (0..=40).map(|i| f64::from(i) * 0.5).collect();
    let dts = [0.05, 0.1, 0.2];
    for (kind, id, title) in [
        (
            SpeedError::Permanent,
            "dv_theory_permanent",
            "Minimal detectable permanent speed error (theory, Fig. dv_theo a)",
        ),
        (
            SpeedError::Transient,
            "dv_theory_transient",
            "Minimal detectable transient speed error (theory, Fig. dv_theo b)",
        ),
    ] {
        let curves = experiments::dv_theory(params, kind, &dts, &speeds);
        let mut chart = LineChart::new(title, "object speed [m/s]", "dv_min [m/s]");
        let mut rows = Vec::new();
        for (i, (dt, pts)) in curves.iter().enumerate() {
            chart = chart.with_series(
                Series::new(format!("dt = {dt} s"), pts.clone()).with_color(pmon_report::SeriesColor::Palette(i)),
            );
            for (v, d) in pts {
                rows.push(vec![format!("{dt}"), format!("{v}"), format!("{d:.4}")]);
            }
            if kind == SpeedError::Transient {
                let c = experiments::transient_closed_form(params, *dt);
                chart = chart.with_series(
                    Series::new(format!("min(a_acc, -a_br) dt + sqrt(2) dv, dt = {dt} s"), vec![(0.0, c), (20.0, c)])
                        .with_color(pmon_report::SeriesColor::Palette(i))
                        .dashed(),
                );
            }
        }
        chart.render_svg(dir.join(format!("{id}.svg")))?;
        chart.render_png(dir.join(format!("{id}.png")), 1600, 1000)?;
        pmon_report::write_csv(dir.join(format!("{id}.csv")), &["dt_s", "speed_mps", "dv_min_mps"], &rows)?;
    }
    Ok(())
}

fn render_latency(dir: &Path, latency: (f64, f64)) -> Result<()> {
    let chart = BarChart::new(
        "Latency per frame (median)",
        "",
        "milliseconds",
        vec!["sensor checks".to_string(), "plausibility checks".to_string()],
    )
    .with_group(BarGroup::new("paper, Core i9-7900X", vec![12.0, 5.0]))
    .with_group(BarGroup::new("paper, Atom C3934", vec![18.0, 13.0]))
    .with_group(BarGroup::new("pmon, this machine", vec![latency.0, latency.1]));
    chart.render_svg(dir.join("latency.svg"))?;
    chart.render_png(dir.join("latency.png"), 1600, 1000)?;
    chart.write_csv(dir.join("latency.csv"))?;
    Ok(())
}

/// Pictures of example frames: a detected permanent error, an error towards the ego (the paper's blind
/// spot), and an occluded one.
fn render_examples(
    dir: &Path,
    scenes: &[Scene],
    ids: SceneIds,
    params: &MonitorParams,
    seed: u64,
    report: &mut HtmlReport,
) -> Result<()> {
    let cases = [
        ("example_away", ids.pedestrians, Fault::PermanentPosition { magnitude_m: 1.0, direction: Direction::Away }, true, "A 1.0 m permanent error away from the ego, detected: the object's LiDAR evidence (red conflict cells) lies outside its grown region."),
        ("example_towards", ids.pedestrians, Fault::PermanentPosition { magnitude_m: 1.0, direction: Direction::Towards }, false, "A 1.0 m permanent error towards the ego, missed: the grown region still covers the true object's near face (the limit the paper admits)."),
        ("example_occluded", ids.intersection, Fault::RandomPosition { magnitude_m: 1.0, rate: 0.2, direction: Direction::Away }, false, "A random error on an object the sensor cannot see: neither its evidence nor its surroundings are visible, so the sensor checks report it as not monitored (occluded)."),
    ];
    for (id, scene_ix, fault, want_detected, caption) in cases {
        let Some(scene) = scenes.get(scene_ix) else { continue };
        let spec = RunSpec {
            scene: scene_ix,
            params: *params,
            injection: pmon_campaign::InjectionConfig::new(fault, seed),
            window: 2,
        };
        let result = pmon_campaign::run_one(scene, &spec).map_err(|e| anyhow::anyhow!(e))?;
        let example = if want_detected {
            result.detected_example
        } else if id == "example_occluded" {
            result.occluded_example
        } else {
            result.missed_example
        };
        let Some(ex) = example else { continue };
        let replay = replay_to(scene, &spec, ex.frame as usize).map_err(|e| anyhow::anyhow!(e))?;
        let centre = replay.frame.objects.iter().find(|o| o.id == ex.id).map_or((0.0, 0.0), |o| (o.x_m, o.y_m));
        let title = format!("{} frame {}, object {}", scene.name, ex.frame, ex.id);
        let checked = Checked {
            frame: &replay.frame,
            objects: &replay.objects,
            clusters: &replay.clusters,
            injections: &replay.injections,
        };
        let view = top_view(&title, &replay.monitor, &checked, centre, 12.0);
        write_view(&view, &dir.join(format!("{id}.png")))?;
        write_view(&view, &dir.join(format!("{id}.svg")))?;
        report.figure(&format!("{id}.png"), caption);
    }
    Ok(())
}

/// The paper-vs-pmon table as Markdown, every claim a row (met, missed and informational alike), generated from
/// the same claims as `results.json`: the README's results table is pasted from this file.
pub fn claims_markdown(claims: &[Claim]) -> String {
    let cell = |s: &str| s.replace('|', "\\|").replace('\n', " ");
    let mut md = String::from("| the paper | pmon | |\n|---|---|---|\n");
    for c in claims {
        let verdict = match c.met {
            Some(true) => "met",
            Some(false) => "missed",
            None => "informational",
        };
        let _ = writeln!(md, "| {} | {} | {verdict} |", cell(&c.paper), cell(&c.pmon));
    }
    md
}

fn claims_table(claims: &[Claim]) -> Vec<Vec<TableCell>> {
    claims
        .iter()
        .map(|c| {
            let verdict = match c.met {
                Some(true) => TableCell::pass("met"),
                Some(false) => TableCell::miss("missed"),
                None => TableCell::with_class("informational", CellClass::Muted),
            };
            vec![TableCell::new(c.paper.clone()), TableCell::new(c.pmon.clone()), verdict]
        })
        .collect()
}

/// `pmon reproduce`.
pub fn run(args: &ReproduceArgs) -> Result<ExitCode> {
    let started = Instant::now();
    run_dir::check_scheduler(&args.scheduler)?;
    if let Some(n) = args.threads {
        rayon::ThreadPoolBuilder::new().num_threads(n).build_global().context("cannot set the thread count")?;
    }
    let params = load_params(args.params.as_deref())?;
    let scale = if args.smoke {
        Scale::Smoke
    } else if args.quick {
        Scale::Quick
    } else {
        Scale::Full
    };
    let out_dir = OutputDir::prepare(&args.out, "reproduce", args.force)?;
    let out = out_dir.path().to_path_buf();
    let duration = if args.smoke { Some(args.duration_s.unwrap_or(3.0)) } else { args.duration_s };
    let scene_specs = sim_tasks::scene_specs(args.quick, args.seed, duration).map_err(|e| anyhow::anyhow!(e))?;
    let ids = SceneIds { pedestrians: 0, intersection: 1, pedestrians_20hz: Some(2), pedestrians_paper: Some(3) };
    let planned = experiments::plan(scale, ids, &params, args.seed);
    let (scenes, results) = if args.scheduler == "local" {
        eprintln!("pmon reproduce: simulating the built-in scenes (seed {})", args.seed);
        let scenes = build_scenes(&scene_specs, args.quiet)?;
        eprintln!("pmon reproduce: {} runs over {} scenes", planned.len(), scenes.len());
        let specs: Vec<RunSpec> = planned.iter().map(|p| p.spec.clone()).collect();
        let pb = if args.quiet { ProgressBar::hidden() } else { bar(specs.len() as u64, "runs") };
        let results: Vec<RunResult> = run_all(&scenes, &specs, &|| pb.inc(1)).map_err(|e| anyhow::anyhow!(e))?;
        pb.finish_and_clear();
        (scenes, results)
    } else {
        let results = run_on_scheduler(args, &planned, &scene_specs)?;
        // This process still needs the scenes: the latency, the example frames and the scene table.
        eprintln!("pmon reproduce: simulating the built-in scenes here (seed {})", args.seed);
        (build_scenes(&scene_specs, args.quiet)?, results)
    };
    let figures = experiments::assemble(&planned, &results);
    let lat = latency(&scenes, &params)?;
    let checks = theory_checks(&params)?;
    let data_dir = args
        .data
        .clone()
        .or_else(|| std::env::var_os("PMON_DATA_DIR").map(PathBuf::from))
        .unwrap_or_else(|| PathBuf::from("../shared/data"));
    eprintln!("pmon reproduce: real-data experiments ({})", data_dir.display());
    let real = pmon_campaign::real_data::real_data_experiments_with(
        &data_dir,
        &params,
        args.seed,
        &if args.smoke {
            pmon_campaign::real_data::RealDataOptions::smoke()
        } else {
            pmon_campaign::real_data::RealDataOptions::full()
        },
    )
    .map_err(|e| anyhow::anyhow!("real data: {e}"))?;
    let mut claims = experiments::claims(&figures, Some(lat));
    claims.extend(real.claims.iter().cloned());
    // Missing data is said every time: on stderr, in the claims table (results.json, index.html) and the notes.
    for n in real.notes.iter().filter(|n| n.contains("skipped") || n.contains("not found")) {
        eprintln!("pmon reproduce: warning: {n}");
    }
    if real.claims.is_empty() {
        let missing = format!(
            "NOT RUN: no real data at {} (give --data DIR or set PMON_DATA_DIR); the real-data rows are missing",
            data_dir.display()
        );
        eprintln!("pmon reproduce: warning: {missing}");
        claims.push(Claim {
            paper: "real sensor data (nuScenes, KITTI, Argoverse 2) and real tracks (CommonRoad)".into(),
            pmon: missing,
            met: None,
        });
    }
    let agree = checks.iter().filter(|c| !c.flagged_below && c.flagged_above).count();
    claims.push(Claim {
        paper: "Fig. dv_theo: the analytic minimal detectable speed errors".into(),
        pmon: format!(
            "the monitor flags 1.03 dv_min and not 0.97 dv_min in {agree} of {} settings (dt, speed, kind)",
            checks.len()
        ),
        met: Some(agree == checks.len()),
    });

    eprintln!("pmon reproduce: writing the report to {}", args.out.display());
    for f in &figures {
        render_figure(&out, f)?;
    }
    render_theory(&out, &params)?;
    render_latency(&out, lat)?;
    for f in &real.figures {
        render_figure(&out, f)?;
    }

    let scene_summaries: Vec<SceneSummary> = scenes
        .iter()
        .map(|s| SceneSummary {
            name: s.name.clone(),
            source: s.source.clone(),
            frames: s.frames.len(),
            object_states: s.frames.iter().map(|f| f.objects.len()).sum(),
            mean_points: s
                .frames
                .iter()
                .map(|f| f.cloud.as_ref().map_or(0, |c| c.points_in_sensor.len()) as f64)
                .sum::<f64>()
                / s.frames.len().max(1) as f64,
        })
        .collect();

    let mut html = HtmlReport::new("pmon: reproducing the lightweight perception monitor");
    let mut intro = String::new();
    let _ = write!(
        intro,
        "Every experiment of Buerkle et al., \"Fault-Tolerant Perception for Automated Driving: A Lightweight Monitoring Approach\" (Section IV), run on pmon's built-in scenes with the paper's parameters (Table I) unless stated. Scale: {}. Seed: {}. {} runs. Reproduce with: pmon reproduce{} --seed {}.",
        if args.quick { "quick (coarser sweeps, 15 s scenes)" } else { "full" },
        args.seed,
        planned.len(),
        if args.quick { " --quick" } else { "" },
        args.seed
    );
    html.paragraph(&intro);
    html.heading("Paper vs pmon");
    html.table(&["the paper", "pmon", ""], &claims_table(&claims));
    html.heading("Scenes");
    let rows: Vec<Vec<TableCell>> = scene_summaries
        .iter()
        .map(|s| {
            vec![
                TableCell::new(s.name.clone()),
                TableCell::new(s.source.clone()),
                TableCell::num(s.frames.to_string()),
                TableCell::num(s.object_states.to_string()),
                TableCell::num(format!("{:.0}", s.mean_points)),
            ]
        })
        .collect();
    html.table(&["scene", "source", "frames", "object states", "LiDAR points per frame"], &rows);
    html.heading("Figures");
    html.paragraph("Shaded bands are 95 % intervals. Where the data (CSV) has the columns tracks, ci95_tracks_lo and ci95_tracks_hi, the band is that interval, which counts the states of a track as one cluster (effective sample size, docs/evaluation.md, \"Scoring\"): the honest one, as the states of a track are not independent; its clusters are in <figure>_tracks.csv, and the narrower Wilson interval over object states is in the CSV's ci95 columns. Other curves' bands are the Wilson intervals over object states (or frames). Precision curves are dashed. Plausibility checks may flag an error in its frame or the next (the paper's rule). Permanent faults affect half of the tracks (chosen by seed), so that precision is measured against clean tracks.");
    for f in &figures {
        html.figure_with_data(
            &format!("{}.png", f.spec.id),
            &format!("{} — reproduces {}", f.spec.title, f.spec.paper_ref),
            &format!("{}.csv", f.spec.id),
        );
        if out.join(format!("{}_zoom.png", f.spec.id)).exists() {
            html.figure_with_data(
                &format!("{}_zoom.png", f.spec.id),
                &format!("{}: the curves near zero, zoomed (same data)", f.spec.title),
                &format!("{}.csv", f.spec.id),
            );
        }
        if out.join(format!("{}_top.png", f.spec.id)).exists() {
            html.figure_with_data(
                &format!("{}_top.png", f.spec.id),
                &format!("{}: the top of the y axis, zoomed so that curves near 1 separate (same data; points lower down are off this view, see the full figure)", f.spec.title),
                &format!("{}.csv", f.spec.id),
            );
        }
        crate::causes::add_to_report(&mut html, f);
    }
    html.figure_with_data("dv_theory_permanent.png", "Theory: minimal detectable permanent speed error against speed and time step (Delta x = 0.1 m, Delta v = 1 m/s, Delta theta = 10 deg).", "dv_theory_permanent.csv");
    html.figure_with_data(
        "dv_theory_transient.png",
        "Theory: minimal detectable transient speed error; dashed: the acceleration-only closed form.",
        "dv_theory_transient.csv",
    );
    html.figure_with_data("latency.png", "Latency of both checks per frame: the paper's measurements and pmon's median on this machine (single thread, includes every stage).", "latency.csv");
    html.heading("Real data");
    if real.figures.is_empty() {
        html.paragraph("The real-data experiments did not run: no data found (see the notes below).");
    }
    for f in &real.figures {
        html.figure_with_data(
            &format!("{}.png", f.spec.id),
            &format!("{} — {}", f.spec.title, f.spec.paper_ref),
            &format!("{}.csv", f.spec.id),
        );
        crate::causes::add_to_report(&mut html, f);
    }
    for (title, headers, rows) in &real.tables {
        html.subheading(title);
        let cells: Vec<Vec<TableCell>> =
            rows.iter().map(|r| r.iter().map(|c| TableCell::new(c.clone())).collect()).collect();
        html.table(headers, &cells);
    }
    for n in &real.notes {
        html.paragraph(n);
    }
    html.heading("Example frames");
    render_examples(&out, &scenes, ids, &params, args.seed, &mut html)?;
    html.heading("Parameters");
    html.paragraph(&match &args.params {
        Some(p) => format!(
            "The defaults with --params {} over them (every key below; a profile's file, crates/session/profiles, lists \
             what it buys and costs).",
            p.display()
        ),
        None => "The defaults: the paper's Table I and the rules made the default since (every key below).".to_string(),
    });
    html.preformatted(&toml::to_string_pretty(&params).unwrap_or_default());

    let elapsed = started.elapsed().as_secs_f64();
    let results_json = Results {
        pmon_version: env!("CARGO_PKG_VERSION"),
        scale: match scale {
            Scale::Full => "full",
            Scale::Quick => "quick",
            Scale::Smoke => "smoke",
        },
        seed: args.seed,
        params: &params,
        scenes: scene_summaries,
        claims: &claims,
        figures: &figures,
        latency_ms: Some(lat),
        theory_checks: &checks,
        real_data: &real,
        runs: planned.len(),
        elapsed_s: elapsed,
    };
    let json = serde_json::to_string_pretty(&results_json).context("cannot serialise results")?;
    fs::write(out.join("results.json"), json + "\n").context("cannot write results.json")?;
    fs::write(out.join("paper-vs-pmon.md"), claims_markdown(&claims)).context("cannot write paper-vs-pmon.md")?;
    html.paragraph(&format!("Generated by pmon {} in {elapsed:.0} s.", env!("CARGO_PKG_VERSION")));
    html.write(out.join("index.html"))?;
    out_dir.commit()?;
    if let Some(readme) = &args.readme {
        let scale = match scale {
            Scale::Full => "full run",
            Scale::Quick => "--quick run",
            Scale::Smoke => "smoke run (no conclusions)",
        };
        let block = format!(
            "Seed {}, {scale}, pmon {}; every claim of `results.json` is a row.\n\n{}",
            args.seed,
            env!("CARGO_PKG_VERSION"),
            claims_markdown(&claims)
        );
        crate::readme_table::update(readme, &block)?;
        eprintln!("pmon reproduce: wrote the results table into {}", readme.display());
    }

    println!("{:<100} {:<70} met", "the paper", "pmon");
    for c in &claims {
        let met = match c.met {
            Some(true) => "yes",
            Some(false) => "NO",
            None => "info",
        };
        println!("{:<100} {:<70} {met}", c.paper, c.pmon);
    }
    println!("\nreport: {}", args.out.join("index.html").display());
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod band_tests {
    use super::*;
    use pmon_campaign::{ClusteredRate, Rate};

    fn point(x: f64, k: u64, n: u64, by_track: Option<(f64, f64)>) -> experiments::Point {
        let mut p = experiments::Point::new(x, Rate::wilson(k, n));
        p.by_track = by_track.map(|(lo, hi)| ClusteredRate { clusters: 5, deff: 3.0, n_eff: n as f64 / 3.0, lo, hi });
        p
    }

    #[test]
    fn the_band_is_the_interval_by_track_when_every_point_has_one() {
        let curve = |points| experiments::Curve { label: "c".into(), points, dashed: false };
        let both = curve(vec![
            point(1.0, 80, 100, Some((0.6, 0.9))),
            point(2.0, 0, 0, None),
            point(3.0, 90, 100, Some((0.7, 0.97))),
        ]);
        assert_eq!(series_of(&both, 0).band, Some(vec![(1.0, 0.6, 0.9), (3.0, 0.7, 0.97)]));
        // One point without it: the interval over states for the whole curve, never a mix.
        let mixed = curve(vec![point(1.0, 80, 100, Some((0.6, 0.9))), point(3.0, 90, 100, None)]);
        let states = Rate::wilson(80, 100);
        let band = series_of(&mixed, 0).band.unwrap_or_default();
        assert_eq!(band.len(), 2);
        assert_eq!(band[0], (1.0, states.lo, states.hi));
        assert!(band[0].1 > 0.6, "the per-state interval is narrower: {band:?}");
    }
}
