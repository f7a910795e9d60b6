//! The real-sensor experiment with **one box displaced at a time**: a condition beside the paper's (where every
//! box of the frame is displaced at once), stated as such wherever it is reported.
//!
//! Why it is measured: with every box displaced away from the ego by the same distance, neighbours move together
//! (parked cars side by side, a row of bollards 1 m apart, two labels on one car), so one displaced box lands on its
//! neighbour's returns and its own returns are taken by another displaced box. That measures a tracker that is
//! wrong about everything at once; a tracker with one wrong object is the case the object-level guarantee is about.
//! Here each box consistent on its clean frame is displaced alone (the others keep their labels) and checked on a
//! single frame with a fresh track memory (as the paper's single keyframes: no motion history). Besides recall, the
//! run counts *collateral* alarms: other boxes flagged in that check that the clean check did not flag (a clean
//! neighbour blamed for the displaced box's evidence).
//!
//! A second condition, **after a clean sweep** ([`OneBoxRun::after_clean_sweep`]): only frames whose previous
//! frame of the log lies at most `max_time_step_s` earlier are used, and before each displaced box's check (with a
//! fresh track memory) that previous frame is checked clean, so that the tracker was right one sweep ago and goes
//! wrong now: step 9 (a box that jumped away from evidence that stayed) knows where the box's evidence was. The
//! boxes counted are the same as in the single sweep (consistent on their clean frame, checked with a fresh memory);
//! collateral alarms there are counted against the clean frame checked after the same clean previous sweep. Frames
//! without such a previous sweep (single keyframes) count nothing. It is the condition of the development example
//! `real_misses` with `ONE_BOX=1 HISTORY=1`.
//!
//! A third, the paper's form of that condition, **every box displaced at once after a clean sweep**
//! ([`OneBoxRun::every_box_after_clean_sweep`]): the same frames (a previous sweep at most `max_time_step_s`
//! earlier); for each, the track memory is reset, the previous frame is checked clean, and then the frame with every
//! box displaced away from the ego by the magnitude, as the experiment's "every box displaced" run does it (an
//! [`Injector`] with `Fault::PermanentPosition { direction: Direction::Away }` and `permanent_track_fraction = 1.0`,
//! seed 7: each box moved by the magnitude along its own bearing from the ego origin). Recall counts the boxes
//! consistent on their clean frame checked with a fresh track memory (the boxes of the one-box conditions), less those
//! judged `not_monitored(OutsideGrid)` once displaced; no collateral alarms are counted (no box stays clean). It is
//! the condition of the development example `real_misses` with `HISTORY=1` (without `ONE_BOX`).

use pmon_datasets::DatasetFrame;
use pmon_monitor::{Monitor, MonitorParams, NotMonitoredReason, ObjectState, SensorVerdict};

use super::short_rate;
use crate::experiments::{Curve, Point};
use crate::inject::{Direction, Fault, InjectionConfig, Injector};
use crate::metrics::{reported_displacement_agrees, Rate};

/// Outcome of the one-box runs at one magnitude.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(super) struct OneBox {
    /// Boxes consistent on their clean frame (in the grid), each displaced alone.
    pub(super) displaced: u64,
    /// Of those, flagged (`ghost` or `position_error`).
    pub(super) detected: u64,
    /// Of the flagged, reported as the displacement they are: `position_error` on the box's own evidence
    /// ([`crate::metrics::reported_displacement_agrees`]).
    pub(super) own: u64,
    /// Of those, judged not monitored (occluded) once displaced.
    pub(super) occluded: u64,
    /// Other boxes flagged in the same checks and not flagged on the clean frame.
    pub(super) collateral: u64,
    /// Frames counted (after a clean sweep: the frames with a previous sweep within `max_time_step_s`).
    pub(super) frames: u64,
}

impl OneBox {
    /// Recall with its 95 % Wilson interval.
    pub(super) fn recall(&self) -> Rate {
        Rate::wilson(self.detected, self.displaced)
    }
}

fn alarm(v: SensorVerdict) -> bool {
    matches!(v, SensorVerdict::Ghost | SensorVerdict::PositionError)
}

/// One magnitude of the one-box runs, advanced one frame at a time: every box consistent on its clean frame
/// displaced alone, away from the ego.
pub(super) struct OneBoxRun {
    monitor: Monitor,
    magnitude_m: f32,
    objects: Vec<ObjectState>,
    /// After a clean sweep: the previous frame stepped with (`None` before the first one); `None` for the
    /// single-sweep run.
    history: Option<History>,
    /// Every box displaced at once (the run [`OneBoxRun::every_box_after_clean_sweep`]): the injector that displaces
    /// them; `None`: one box at a time.
    every_box: Option<Injector>,
    /// The counts so far.
    pub(super) out: OneBox,
}

/// What the run after a clean sweep keeps between frames.
struct History {
    /// The frame stepped with before this one.
    previous: Option<DatasetFrame>,
    /// The longest step from the previous frame that still counts as the sweep before, seconds.
    max_time_step_s: f64,
}

impl OneBoxRun {
    /// The single-sweep run: every check starts with a fresh track memory.
    ///
    /// # Errors
    /// The parameters are invalid.
    pub(super) fn new(params: &MonitorParams, magnitude_m: f32) -> Result<Self, String> {
        Ok(Self {
            monitor: Monitor::new(*params).map_err(|e| e.to_string())?,
            magnitude_m,
            objects: Vec::new(),
            history: None,
            every_box: None,
            out: OneBox::default(),
        })
    }

    /// The run after a clean sweep: each displaced box's check follows a check of the previous frame, clean, when
    /// that frame is at most `params.max_time_step_s` earlier; other frames count nothing.
    ///
    /// # Errors
    /// The parameters are invalid.
    pub(super) fn after_clean_sweep(params: &MonitorParams, magnitude_m: f32) -> Result<Self, String> {
        let mut run = Self::new(params, magnitude_m)?;
        run.history = Some(History { previous: None, max_time_step_s: params.max_time_step_s });
        Ok(run)
    }

    /// The paper's form of the run after a clean sweep: on the same frames as [`OneBoxRun::after_clean_sweep`], one
    /// check per frame (a fresh track memory, the previous frame checked clean) with **every** box displaced at once
    /// away from the ego by `magnitude_m`. The displacement is the one of `real_misses` with `HISTORY=1` (without
    /// `ONE_BOX`) and of the experiment's "every box displaced" run: an [`Injector`] with
    /// `Fault::PermanentPosition { magnitude_m, direction: Direction::Away }`, `permanent_track_fraction = 1.0` and
    /// seed 7, which moves each box by `magnitude_m` along its own bearing from the ego origin (the seed draws
    /// nothing for that fault). The boxes counted are those consistent on their clean frame checked with a fresh
    /// track memory (as the one-box runs), less those judged `not_monitored(OutsideGrid)` once displaced;
    /// `collateral` stays 0 (every box is displaced).
    ///
    /// # Errors
    /// The parameters are invalid.
    pub(super) fn every_box_after_clean_sweep(params: &MonitorParams, magnitude_m: f32) -> Result<Self, String> {
        let mut run = Self::after_clean_sweep(params, magnitude_m)?;
        let fault = Fault::PermanentPosition { magnitude_m, direction: Direction::Away };
        let mut cfg = InjectionConfig::new(fault, 7);
        cfg.permanent_track_fraction = 1.0;
        run.every_box = Some(Injector::new(cfg));
        Ok(run)
    }

    /// Frame `k`: one fresh-memory check of the clean frame, then one per displaced box (after a clean sweep:
    /// each preceded by the previous frame, clean, and the clean frame checked once more after it for the
    /// collateral alarms).
    ///
    /// # Errors
    /// A monitor error (too many objects).
    pub(super) fn step(&mut self, k: usize, df: &DatasetFrame) -> Result<(), String> {
        let Self { monitor, magnitude_m, objects, history, every_box, out } = self;
        let magnitude_m = *magnitude_m;
        // After a clean sweep: the previous frame, if it is the sweep just before this one (else nothing counts).
        let previous = match history {
            None => None,
            Some(h) => {
                let max_dt = h.max_time_step_s;
                let before = h.previous.replace(df.clone()).filter(|p| {
                    let dt = df.frame.timestamp_s - p.frame.timestamp_s;
                    dt > 0.0 && dt <= max_dt
                });
                match before {
                    Some(p) => Some(p),
                    None => return Ok(()),
                }
            }
        };
        out.frames += 1;
        let clean = &df.frame;
        let mut polygons = Vec::new();
        let view = clean.as_frame(&mut polygons);
        monitor.reset_tracks();
        let verdicts: Vec<SensorVerdict> = monitor
            .check(&view)
            .map_err(|e| format!("frame {k}: {e}"))?
            .objects
            .iter()
            .map(|r| r.sensor.verdict)
            .collect();
        // Every box displaced at once: one check of the frame with all of them displaced (after the clean previous
        // sweep), the boxes consistent on the clean frame counted.
        if let Some(injector) = every_box {
            objects.clone_from(&clean.objects);
            let injected = injector.apply(k as u64, objects);
            let mut polygons = Vec::new();
            let mut view = clean.as_frame(&mut polygons);
            view.objects = objects;
            monitor.reset_tracks();
            if let Some(p) = &previous {
                check_previous(monitor, k, p)?;
            }
            let rep = monitor.check(&view).map_err(|e| format!("frame {k}: {e}"))?;
            for inj in injected {
                let i = inj.index as usize;
                if !matches!(verdicts.get(i), Some(SensorVerdict::Consistent)) {
                    continue;
                }
                let Some(mine) = rep.objects.get(i) else { continue };
                if matches!(mine.sensor.verdict, SensorVerdict::NotMonitored(NotMonitoredReason::OutsideGrid)) {
                    continue;
                }
                out.displaced += 1;
                out.detected += u64::from(alarm(mine.sensor.verdict));
                out.own += u64::from(clean.objects.get(i).is_some_and(|truth| {
                    reported_displacement_agrees(&mine.sensor, rep.clusters, truth, inj.offset_m)
                }));
                out.occluded +=
                    u64::from(matches!(mine.sensor.verdict, SensorVerdict::NotMonitored(NotMonitoredReason::Occluded)));
            }
            return Ok(());
        }
        // What the collateral alarms are counted against: the clean frame as checked before each displaced box
        // (fresh memory, or after the clean previous sweep).
        let baseline: Vec<SensorVerdict> = match &previous {
            None => verdicts.clone(),
            Some(p) => {
                monitor.reset_tracks();
                check_previous(monitor, k, p)?;
                monitor
                    .check(&view)
                    .map_err(|e| format!("frame {k}: {e}"))?
                    .objects
                    .iter()
                    .map(|r| r.sensor.verdict)
                    .collect()
            }
        };
        for (i, v) in verdicts.iter().enumerate() {
            if !matches!(v, SensorVerdict::Consistent) {
                continue;
            }
            objects.clone_from(&clean.objects);
            let Some(o) = objects.get_mut(i) else { continue };
            let r = o.x_m.hypot(o.y_m);
            let (ux, uy) = if r > 1e-3 { (o.x_m / r, o.y_m / r) } else { (1.0, 0.0) };
            o.x_m += magnitude_m * ux;
            o.y_m += magnitude_m * uy;
            let mut polygons = Vec::new();
            let mut view = clean.as_frame(&mut polygons);
            view.objects = objects;
            monitor.reset_tracks();
            if let Some(p) = &previous {
                check_previous(monitor, k, p)?;
            }
            let rep = monitor.check(&view).map_err(|e| format!("frame {k}: {e}"))?;
            let Some(mine) = rep.objects.get(i) else { continue };
            if matches!(mine.sensor.verdict, SensorVerdict::NotMonitored(NotMonitoredReason::OutsideGrid)) {
                continue;
            }
            out.displaced += 1;
            out.detected += u64::from(alarm(mine.sensor.verdict));
            out.own += u64::from(clean.objects.get(i).is_some_and(|truth| {
                reported_displacement_agrees(&mine.sensor, rep.clusters, truth, [magnitude_m * ux, magnitude_m * uy])
            }));
            out.occluded +=
                u64::from(matches!(mine.sensor.verdict, SensorVerdict::NotMonitored(NotMonitoredReason::Occluded)));
            out.collateral += rep
                .objects
                .iter()
                .zip(&baseline)
                .enumerate()
                .filter(|(j, (r, v))| *j != i && alarm(r.sensor.verdict) && !alarm(**v))
                .count() as u64;
        }
        Ok(())
    }
}

/// Checks the previous frame, clean, so that the monitor's track memory holds where every box and its evidence were
/// one sweep ago.
fn check_previous(monitor: &mut Monitor, k: usize, previous: &DatasetFrame) -> Result<(), String> {
    let mut polygons = Vec::new();
    monitor.check(&previous.frame.as_frame(&mut polygons)).map_err(|e| format!("frame {k}, the sweep before: {e}"))?;
    Ok(())
}

/// The magnitudes of the runs after a clean sweep, metres (run when the sweep of magnitudes holds them).
pub(super) const AFTER_SWEEP_M: [f64; 2] = [1.0, 2.0];

/// What the report says for a set where no frame follows another sweep closely enough (single keyframes).
pub(super) const NO_PREVIOUS_SWEEP: &str = "n/a (no previous sweep within max_time_step_s)";

/// Which of the runs after a clean sweep a part of the report is about. Everything that differs between them is
/// in [`AfterSweep::spec`]: a condition is added there (and in [`AfterSweep::ALL`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum AfterSweep {
    /// [`OneBoxRun::after_clean_sweep`]: one box displaced at a time.
    OneBox,
    /// [`OneBoxRun::every_box_after_clean_sweep`]: every box displaced at once (no collateral alarms to count).
    EveryBox,
}

/// What the runs and the report need of one condition after a clean sweep ([`AfterSweep::spec`]).
pub(super) struct AfterSweepSpec {
    /// The condition as the report words it (in its column and its notes).
    pub(super) name: &'static str,
    /// The run at one magnitude.
    pub(super) new_run: fn(&MonitorParams, f32) -> Result<OneBoxRun, String>,
    /// The curve's label in `real_position_<dataset>`.
    curve_label: &'static str,
    /// The real-sensor table's column (after the others, in the order of [`AfterSweep::ALL`]).
    pub(super) column: String,
    /// The report's note on the condition (followed by the one with its recall).
    pub(super) note: String,
    /// One magnitude in the table's cell ([`after_sweep_cell`]).
    cell: fn(f64, &OneBox) -> String,
    /// One magnitude in the report's sentence ([`after_sweep_text`]).
    text: fn(f64, &OneBox) -> String,
}

impl AfterSweep {
    /// The conditions, in the order of their runs, curves, columns and notes.
    pub(super) const ALL: [Self; 2] = [Self::OneBox, Self::EveryBox];

    /// The condition's names, run and report forms.
    pub(super) fn spec(self) -> AfterSweepSpec {
        match self {
            Self::OneBox => {
                let name = "one box displaced after a clean sweep (step 9 knows where its evidence was)";
                AfterSweepSpec {
                    name,
                    new_run: OneBoxRun::after_clean_sweep,
                    curve_label: "sensor recall, boxes consistent on the clean frame (one box displaced after a \
                                  clean sweep)",
                    column: format!(
                        "recall, boxes consistent on the clean frame, {name} (flagged on their own evidence; occluded; \
                         collateral alarms on clean neighbours)"
                    ),
                    note: format!(
                        "Real sensor, {name}: a condition beside the single sweep, reported apart from the claims. \
                         Only frames whose previous frame of the log lies at most max_time_step_s earlier count: \
                         before each displaced box's check (a fresh track memory) that previous frame is checked \
                         clean, so the tracker was right one sweep ago and is wrong now. The boxes are those \
                         consistent on their clean frame (a fresh memory, as above); 'collateral' counts clean \
                         neighbours flagged in those checks and not on the clean frame checked after the same sweep. \
                         Single keyframes (KITTI object frames, the nuScenes keyframe) have no previous sweep: \
                         {NO_PREVIOUS_SWEEP}."
                    ),
                    cell: |x, r| {
                        let rate = short_rate(Some(r.recall()));
                        format!(
                            "{x:.1} m: {rate}, {} on its own evidence, {} occluded, {} collateral",
                            r.own, r.occluded, r.collateral
                        )
                    },
                    text: |x, r| {
                        let rate = short_rate(Some(r.recall()));
                        format!(
                            "{x:.1} m: {rate} ({} on their own evidence, {} collateral alarms)",
                            r.own, r.collateral
                        )
                    },
                }
            }
            Self::EveryBox => {
                let name = "every box displaced at once after a clean sweep (the paper's form)";
                AfterSweepSpec {
                    name,
                    new_run: OneBoxRun::every_box_after_clean_sweep,
                    curve_label: "sensor recall, boxes consistent on the clean frame (every box displaced at once \
                                  after a clean sweep)",
                    column: format!(
                        "recall, boxes consistent on the clean frame, {name} (95 % Wilson interval; flagged on their \
                         own evidence; occluded)"
                    ),
                    note: format!(
                        "Real sensor, {name}: the paper displaces every box of the frame at once; this is that form \
                         of the condition after a clean sweep, reported apart from the claims. The frames are those \
                         of the one-box condition (a previous frame of the log at most max_time_step_s earlier); \
                         for each, the track memory is reset, the previous frame is checked clean, and then the \
                         frame with every box displaced away from the ego by the magnitude, as the every-box run \
                         does it. The boxes counted are those consistent on their clean frame (a fresh memory, as \
                         above), less those displaced out of the grid; no collateral alarms are counted (no box \
                         stays clean). Recall is given with its 95 % Wilson interval. Single keyframes have no \
                         previous sweep: {NO_PREVIOUS_SWEEP}."
                    ),
                    cell: |x, r| {
                        let rate = short_rate(Some(r.recall()));
                        format!(
                            "{x:.1} m: {rate} {}, {} on their own evidence, {} occluded",
                            interval(r),
                            r.own,
                            r.occluded
                        )
                    },
                    text: |x, r| {
                        format!(
                            "{x:.1} m: {} {} ({} on their own evidence)",
                            short_rate(Some(r.recall())),
                            interval(r),
                            r.own
                        )
                    },
                }
            }
        }
    }
}

/// The runs after a clean sweep, per condition (by [`AfterSweep`]), each at [`AFTER_SWEEP_M`] (`None`: not run).
/// One field per condition, chosen by a `match`: a new condition that is not given one does not compile.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(super) struct AfterSweepRuns {
    one_box: [Option<OneBox>; 2],
    every_box: [Option<OneBox>; 2],
}

impl AfterSweepRuns {
    /// The runs of one condition.
    pub(super) fn get(&self, kind: AfterSweep) -> &[Option<OneBox>; 2] {
        match kind {
            AfterSweep::OneBox => &self.one_box,
            AfterSweep::EveryBox => &self.every_box,
        }
    }

    /// The runs of one condition, to store their counts.
    pub(super) fn get_mut(&mut self, kind: AfterSweep) -> &mut [Option<OneBox>; 2] {
        match kind {
            AfterSweep::OneBox => &mut self.one_box,
            AfterSweep::EveryBox => &mut self.every_box,
        }
    }
}

/// The runs after a clean sweep at 1 m and 2 m (`None`: not run), each as `line(magnitude, counts)`, joined by
/// `sep`; [`NO_PREVIOUS_SWEEP`] when they counted no frame, "n/a" when none ran.
fn after_sweep_parts(v: &[Option<OneBox>; 2], sep: &str, line: &dyn Fn(f64, &OneBox) -> String) -> String {
    let runs: Vec<(f64, &OneBox)> =
        AFTER_SWEEP_M.into_iter().zip(v).filter_map(|(x, r)| Some((x, r.as_ref()?))).collect();
    if runs.is_empty() {
        "n/a".into()
    } else if runs.iter().all(|(_, r)| r.frames == 0) {
        NO_PREVIOUS_SWEEP.into()
    } else {
        runs.iter().map(|&(x, r)| line(x, r)).collect::<Vec<_>>().join(sep)
    }
}

/// The real-sensor table's cell of the runs after a clean sweep: "1.0 m: 92 % (35/38), 0 occluded, 0 collateral;
/// 2.0 m: ..." (the single-sweep column's form); every box displaced: "1.0 m: 89 % (34/38) [75.9, 95.8], 1 occluded;
/// ..." (with the 95 % Wilson interval, without the collateral alarms).
pub(super) fn after_sweep_cell(mode: AfterSweep, v: &[Option<OneBox>; 2]) -> String {
    after_sweep_parts(v, "; ", &mode.spec().cell)
}

/// The report's sentence on the runs after a clean sweep: "1.0 m: 92 % (35/38) (0 collateral alarms), 2.0 m: ...
/// (1 frame after a sweep)" (the claim rows' form for the single sweep); every box displaced: "1.0 m: 89 % (34/38)
/// [75.9, 95.8], 2.0 m: ..." (with the 95 % Wilson interval, without the collateral alarms).
pub(super) fn after_sweep_text(mode: AfterSweep, v: &[Option<OneBox>; 2]) -> String {
    let text = after_sweep_parts(v, ", ", &mode.spec().text);
    match v.iter().flatten().map(|r| r.frames).max() {
        Some(n) if n > 0 => format!("{text} ({n} {} after a sweep)", if n == 1 { "frame" } else { "frames" }),
        _ => text,
    }
}

/// The 95 % Wilson interval of the recall, percent: "[75.9, 95.8]".
fn interval(r: &OneBox) -> String {
    let rate = r.recall();
    format!("[{:.1}, {:.1}]", 100.0 * rate.lo, 100.0 * rate.hi)
}

/// The figure's curve of the runs after a clean sweep: a point at each magnitude of [`AFTER_SWEEP_M`] that ran
/// and counted a frame (`None` when none did: single keyframes). Its x values are the sweep's own.
pub(super) fn after_sweep_curve(mode: AfterSweep, mags: &[f64], v: &[Option<OneBox>; 2]) -> Option<Curve> {
    let points: Vec<Point> = AFTER_SWEEP_M
        .iter()
        .zip(v)
        .filter_map(|(&x, r)| {
            let r = r.as_ref().filter(|r| r.frames > 0)?;
            let x = mags.iter().copied().find(|&y| (y - x).abs() < 1e-9)?;
            Some(Point::new(x, r.recall()))
        })
        .collect();
    (!points.is_empty()).then(|| Curve { label: mode.spec().curve_label.into(), points, dashed: false })
}

/// One magnitude over frames held in memory (the experiments stream their frames through [`OneBoxRun`]).
#[cfg(test)]
fn one_box_at(frames: &[DatasetFrame], params: &MonitorParams, magnitude_m: f32) -> Result<OneBox, String> {
    run_over(OneBoxRun::new(params, magnitude_m)?, frames)
}

/// [`one_box_at`] after a clean sweep.
#[cfg(test)]
fn after_sweep_at(frames: &[DatasetFrame], params: &MonitorParams, magnitude_m: f32) -> Result<OneBox, String> {
    run_over(OneBoxRun::after_clean_sweep(params, magnitude_m)?, frames)
}

/// [`after_sweep_at`] with every box displaced at once.
#[cfg(test)]
fn every_box_at(frames: &[DatasetFrame], params: &MonitorParams, magnitude_m: f32) -> Result<OneBox, String> {
    run_over(OneBoxRun::every_box_after_clean_sweep(params, magnitude_m)?, frames)
}

/// The sweeps with only their first labelled object (the street's parked car), for the tests.
#[cfg(test)]
fn first_object_only(frames: &[DatasetFrame]) -> Vec<DatasetFrame> {
    frames
        .iter()
        .map(|df| {
            let mut df = df.clone();
            df.frame.objects.truncate(1);
            df.extras.truncate(1);
            df
        })
        .collect()
}

#[cfg(test)]
fn run_over(mut run: OneBoxRun, frames: &[DatasetFrame]) -> Result<OneBox, String> {
    for (k, df) in frames.iter().enumerate() {
        run.step(k, df)?;
    }
    Ok(run.out)
}

#[cfg(test)]
mod tests {
    use pmon_datasets::ObjectExtra;
    use pmon_monitor::{Isometry3, ObjectClass, ObjectState, Pose2};
    use pmon_recording::{OwnedCloud, RecordedFrame};

    use super::*;

    /// A pedestrian-sized box at (10, 5) and a car at (-15, -6), each filled with returns 0.5-1.5 m above the
    /// ground, seen by a sensor 1.8 m above the ego origin; ground returns around them so that free space is seen.
    fn frame() -> DatasetFrame {
        let obj = |id: u64, class, x_m: f32, y_m: f32, length_m: f32, width_m: f32| ObjectState {
            id,
            class,
            x_m,
            y_m,
            heading_rad: 0.0,
            speed_mps: 0.0,
            length_m,
            width_m,
            uncertainty: None,
        };
        let objects =
            vec![obj(1, ObjectClass::Pedestrian, 10.0, 5.0, 0.6, 0.6), obj(2, ObjectClass::Car, -15.0, -6.0, 4.0, 1.8)];
        let mut points = Vec::new();
        for o in &objects {
            let n = 12;
            for i in 0..n {
                for j in 0..n {
                    for k in 0..5 {
                        let x = o.x_m - 0.5 * o.length_m + o.length_m * (i as f32 + 0.5) / n as f32;
                        let y = o.y_m - 0.5 * o.width_m + o.width_m * (j as f32 + 0.5) / n as f32;
                        points.push([x, y, 0.5 + 0.25 * k as f32 - 1.8]);
                    }
                }
            }
        }
        // Ground returns on rings out to 40 m (z = 0 in the ego frame).
        for r in 1..80 {
            for a in 0..720 {
                let (s, c) = (a as f32 * std::f32::consts::PI / 360.0).sin_cos();
                let d = 0.5 * r as f32;
                points.push([d * c, d * s, -1.8]);
            }
        }
        let mut f = RecordedFrame::empty(0, 0.0, Pose2 { x_m: 0.0, y_m: 0.0, yaw_rad: 0.0 });
        f.cloud =
            Some(OwnedCloud { points_in_sensor: points, ego_from_sensor: Isometry3::from_translation(0.0, 0.0, 1.8) });
        let extras = vec![ObjectExtra::default(); objects.len()];
        f.objects = objects;
        DatasetFrame { frame: f, extras }
    }

    /// Ego-frame points on the faces of `o` that face the sensor at the ego origin, every 0.05 m, at 0.5, 1.0 and
    /// 1.5 m above the ground (the monitor's tests' idealised LiDAR).
    fn faces(o: &ObjectState) -> Vec<[f32; 3]> {
        let (s, c) = o.heading_rad.sin_cos();
        let (hl, hw) = (0.5 * o.length_m, 0.5 * o.width_m);
        let corner = |u: f32, v: f32| [o.x_m + u * c - v * s, o.y_m + u * s + v * c];
        let corners = [corner(hl, hw), corner(-hl, hw), corner(-hl, -hw), corner(hl, -hw)];
        let mut out = Vec::new();
        for (k, a) in corners.iter().enumerate() {
            let b = corners[(k + 1) % 4];
            let (ex, ey) = (b[0] - a[0], b[1] - a[1]);
            let mid = [a[0] + 0.5 * ex, a[1] + 0.5 * ey];
            // Outward normal (ey, -ex) of a counter-clockwise edge, towards the sensor.
            if -(ey * mid[0]) + ex * mid[1] <= 0.0 {
                continue;
            }
            let steps = (ex.hypot(ey) / 0.05).ceil().max(1.0) as usize;
            for i in 0..=steps {
                let t = i as f32 / steps as f32;
                for z in [0.5, 1.0, 1.5] {
                    out.push([a[0] + t * ex, a[1] + t * ey, z]);
                }
            }
        }
        out
    }

    /// A street seen from an ego driving at 10 m/s, the sweep at `t_s` (the monitor's `street_at` in
    /// tests/evidence_attribution.rs): a parked car 28 m ahead (4.5 m long, its length along the ray), an
    /// unlabelled post just beyond it, a pedestrian crossing at 1.5 m/s, ground returns out to 45 m.
    fn street(index: u64, t_s: f32) -> DatasetFrame {
        let ego_x = 10.0 * t_s;
        let obj = |id: u64, class, x_m: f32, y_m: f32, heading_rad: f32, length_m: f32, width_m: f32| ObjectState {
            id,
            class,
            x_m,
            y_m,
            heading_rad,
            speed_mps: 0.0,
            length_m,
            width_m,
            uncertainty: None,
        };
        let car = obj(1, ObjectClass::Car, 30.0 - ego_x, 3.0, 0.05, 4.5, 1.8);
        let ped = ObjectState {
            speed_mps: 1.5,
            ..obj(2, ObjectClass::Pedestrian, 20.0 - ego_x, -4.0 + 1.5 * t_s, std::f32::consts::FRAC_PI_2, 0.6, 0.6)
        };
        let mut points = faces(&car);
        points.extend(faces(&ped));
        points.extend(faces(&obj(9, ObjectClass::Car, 34.0 - ego_x, 3.1, 0.0, 0.3, 0.3)));
        let mut r = 2.0f32;
        while r <= 45.0 {
            for k in 0..1440 {
                let (s, c) = (k as f32 * 0.25).to_radians().sin_cos();
                points.push([r * c, r * s, 0.0]);
            }
            r += 1.0;
        }
        let points_in_sensor = points.iter().map(|p| [p[0], p[1], p[2] - 1.8]).collect();
        let mut f =
            RecordedFrame::empty(index, f64::from(t_s), Pose2 { x_m: f64::from(ego_x), y_m: 0.0, yaw_rad: 0.0 });
        f.cloud = Some(OwnedCloud { points_in_sensor, ego_from_sensor: Isometry3::from_translation(0.0, 0.0, 1.8) });
        f.objects = vec![car, ped];
        DatasetFrame { frame: f, extras: vec![ObjectExtra::default(); 2] }
    }

    /// After a clean sweep: the parked car displaced 1 m away from the ego keeps most of its returns in its grown
    /// region, so a single sweep confirms it; after the previous sweep, checked clean, step 9 sees the box jump
    /// away from returns that stayed and flags it. The walking pedestrian (1 m is beyond its 0.6 m box) is flagged
    /// either way, and nobody else is blamed. The first sweep has no sweep before it and counts nothing.
    #[test]
    fn a_box_displaced_after_a_clean_sweep_is_caught_where_a_single_sweep_confirms_it() {
        let params = MonitorParams::default();
        let sweeps = vec![street(0, 0.0), street(1, 0.1)];
        let single = one_box_at(&sweeps[1..], &params, 1.0).unwrap();
        let after = after_sweep_at(&sweeps, &params, 1.0).unwrap();
        // The same boxes are counted (consistent on the clean sweep, a fresh memory); the single sweep misses the car.
        assert_eq!((single.displaced, single.detected, single.collateral), (2, 1, 0), "{single:?}");
        assert_eq!((after.displaced, after.detected, after.collateral, after.frames), (2, 2, 0, 1), "{after:?}");
        // The car alone (the pedestrian's label removed): a miss in one sweep, caught after the clean one.
        let car_only = first_object_only(&sweeps);
        let single = one_box_at(&car_only[1..], &params, 1.0).unwrap();
        let after = after_sweep_at(&car_only, &params, 1.0).unwrap();
        assert_eq!((single.displaced, single.detected), (1, 0), "{single:?}");
        assert_eq!((after.displaced, after.detected, after.collateral), (1, 1, 0), "{after:?}");
        assert_eq!(
            after_sweep_text(AfterSweep::OneBox, &[Some(after), None]),
            "1.0 m: 100 % (1/1) (1 on their own evidence, 0 collateral alarms) (1 frame after a sweep)"
        );
        // The single-sweep run over both sweeps counts each on its own, as before.
        assert_eq!(one_box_at(&car_only, &params, 1.0).unwrap().displaced, 2);
    }

    /// A single frame, or sweeps further apart than `max_time_step_s`, give the run after a clean sweep nothing to
    /// count: the report says n/a, not 0 %.
    #[test]
    fn without_a_previous_sweep_the_run_after_a_clean_sweep_counts_nothing() {
        let params = MonitorParams::default();
        let nothing = OneBox::default();
        assert_eq!(after_sweep_at(&[street(0, 0.1)], &params, 1.0).unwrap(), nothing);
        assert_eq!(after_sweep_at(&[frame()], &params, 2.0).unwrap(), nothing);
        let apart = vec![street(0, 0.0), street(1, 0.1 + params.max_time_step_s as f32)];
        assert_eq!(after_sweep_at(&apart, &params, 1.0).unwrap(), nothing);
        // The same sweep twice (no time between them) is not a previous sweep either.
        assert_eq!(after_sweep_at(&[street(0, 0.1), street(1, 0.1)], &params, 1.0).unwrap(), nothing);
        let v = [Some(nothing), Some(nothing)];
        assert_eq!(after_sweep_text(AfterSweep::OneBox, &v), NO_PREVIOUS_SWEEP);
        assert_eq!(after_sweep_cell(AfterSweep::OneBox, &v), NO_PREVIOUS_SWEEP);
        assert_eq!(after_sweep_curve(AfterSweep::OneBox, &[1.0, 2.0], &v).map(|c| c.points.len()), None);
        assert_eq!(after_sweep_cell(AfterSweep::OneBox, &[None, None]), "n/a");
    }

    /// Every box displaced at once after a clean sweep: the parked car and the pedestrian both moved 1 m away from
    /// the ego in one check (after the previous sweep, checked clean) are both caught, the car by step 9 (a single
    /// sweep confirms it, as in the one-box test above); the first sweep counts nothing. The boxes counted are the
    /// same as in the one-box run; no collateral alarms are counted.
    #[test]
    fn every_box_displaced_after_a_clean_sweep_is_caught() {
        let params = MonitorParams::default();
        let sweeps = vec![street(0, 0.0), street(1, 0.1)];
        let every = every_box_at(&sweeps, &params, 1.0).unwrap();
        assert_eq!(
            (every.displaced, every.detected, every.occluded, every.collateral, every.frames),
            (2, 2, 0, 0, 1),
            "{every:?}"
        );
        assert_eq!(every.displaced, after_sweep_at(&sweeps, &params, 1.0).unwrap().displaced);
        // Moved 0.1 m (far below a cell), neither is flagged: the alarms above are the displacement's doing.
        let near = every_box_at(&sweeps, &params, 0.1).unwrap();
        assert_eq!((near.displaced, near.detected, near.frames), (2, 0, 1), "{near:?}");
        // The car alone: caught only because the previous sweep was checked clean (the single-sweep one-box run
        // misses it, see above).
        let car_only = first_object_only(&sweeps);
        let car = every_box_at(&car_only, &params, 1.0).unwrap();
        assert_eq!((car.displaced, car.detected), (1, 1), "{car:?}");
        let v = [Some(every), Some(near)];
        assert_eq!(
            after_sweep_cell(AfterSweep::EveryBox, &v),
            "1.0 m: 100 % (2/2) [34.2, 100.0], 2 on their own evidence, 0 occluded; 2.0 m: 0 % (0/2) [0.0, 65.8], 0 on \
             their own evidence, 0 occluded"
        );
        assert_eq!(
            after_sweep_text(AfterSweep::EveryBox, &[Some(every), None]),
            "1.0 m: 100 % (2/2) [34.2, 100.0] (2 on their own evidence) (1 frame after a sweep)"
        );
        let curve = after_sweep_curve(AfterSweep::EveryBox, &[0.5, 1.0, 2.0], &v).unwrap();
        assert_eq!(
            curve.points.iter().map(|p| (p.x, p.rate.k, p.rate.n)).collect::<Vec<_>>(),
            [(1.0, 2, 2), (2.0, 0, 2)]
        );
        assert!(curve.label.contains("every box displaced at once after a clean sweep"), "{}", curve.label);
    }

    /// Every box displaced after a clean sweep: a single frame, sweeps further apart than `max_time_step_s`, or the
    /// same sweep twice count nothing, and the report says n/a.
    #[test]
    fn without_a_previous_sweep_the_every_box_run_after_a_clean_sweep_counts_nothing() {
        let params = MonitorParams::default();
        let nothing = OneBox::default();
        assert_eq!(every_box_at(&[street(0, 0.1)], &params, 1.0).unwrap(), nothing);
        assert_eq!(every_box_at(&[frame()], &params, 2.0).unwrap(), nothing);
        let apart = vec![street(0, 0.0), street(1, 0.1 + params.max_time_step_s as f32)];
        assert_eq!(every_box_at(&apart, &params, 1.0).unwrap(), nothing);
        assert_eq!(every_box_at(&[street(0, 0.1), street(1, 0.1)], &params, 1.0).unwrap(), nothing);
        let v = [Some(nothing), Some(nothing)];
        assert_eq!(after_sweep_text(AfterSweep::EveryBox, &v), NO_PREVIOUS_SWEEP);
        assert_eq!(after_sweep_cell(AfterSweep::EveryBox, &v), NO_PREVIOUS_SWEEP);
        assert!(after_sweep_curve(AfterSweep::EveryBox, &[1.0, 2.0], &v).is_none());
    }

    /// [`AfterSweep::ALL`] lists every condition once, in the order of the report, and each condition's runs in
    /// [`AfterSweepRuns`] are its own.
    #[test]
    fn the_conditions_after_a_clean_sweep_are_listed_in_the_order_of_their_runs() {
        for (i, kind) in AfterSweep::ALL.into_iter().enumerate() {
            assert_eq!(kind as usize, i, "{kind:?}");
        }
        let mut runs = AfterSweepRuns::default();
        let counted = OneBox { frames: 1, ..OneBox::default() };
        runs.get_mut(AfterSweep::EveryBox)[1] = Some(counted);
        assert_eq!(runs.get(AfterSweep::OneBox), &[None, None]);
        assert_eq!(runs.get(AfterSweep::EveryBox), &[None, Some(counted)]);
    }

    #[test]
    fn a_box_displaced_alone_is_flagged_and_a_small_shift_is_not() {
        let frames = vec![frame()];
        let params = MonitorParams { ground_z_m: 0.0, ..MonitorParams::PAPER };
        let far = one_box_at(&frames, &params, 2.0).unwrap();
        // Both boxes are consistent on the clean frame and displaced in turn.
        assert_eq!(far.displaced, 2, "{far:?}");
        // The pedestrian moved 2 m away from its returns is flagged; nobody else is blamed.
        assert!(far.detected >= 1, "{far:?}");
        assert_eq!(far.collateral, 0, "{far:?}");
        let near = one_box_at(&frames, &params, 0.1).unwrap();
        assert_eq!((near.displaced, near.detected, near.collateral), (2, 0, 0), "{near:?}");
        assert!((far.recall().value - far.detected as f64 / 2.0).abs() < 1e-12);
    }
}
