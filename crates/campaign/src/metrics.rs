//! Precision, recall and false-alarm rates with 95 % confidence intervals, scored the paper's way.
//!
//! - An object state is **in scope** when the monitor could place its footprint in the grid (not
//!   `outside_grid`, not `invalid_state`).
//! - **Sensor checks**: an injected error at frame `k` is detected when the object's sensor verdict at `k` is
//!   an alarm (ghost or position error). An alarm at a frame without an injection is a false alarm.
//! - **Plausibility checks** may take up to `window` frames: an error at `k` is detected by an implausible
//!   verdict at any of `k .. k + window - 1`, and an alarm at `f` is a true alarm when the object had an
//!   injection at any of `f - window + 1 ..= f` (the paper: "up to two subsequent time steps", `window = 2`).
//! - **Combined**: detected by either; an alarm of either kind is true when the rule of its check says so.
//! - Errors on objects that the sensor does not confirm even without the error (occluded, too few points:
//!   `eta < tau_tp` in the clean frame) are counted as *not verifiable*.

use std::collections::{BTreeMap, HashMap};

use serde::{Deserialize, Serialize};

/// A proportion with its Wilson score 95 % interval.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Rate {
    /// Successes.
    pub k: u64,
    /// Trials.
    pub n: u64,
    /// `k / n` (NaN when `n = 0`).
    pub value: f64,
    /// Lower bound of the 95 % interval.
    pub lo: f64,
    /// Upper bound of the 95 % interval.
    pub hi: f64,
}

impl Rate {
    /// Wilson score interval for `k` of `n`. At `k = 0` and `k = n` the bound on that side is exactly the rate (0
    /// or 1), as the formula gives it in exact arithmetic (in floating point it came out as 0.9999999999999999 at
    /// 38 of 38: an interval that did not hold its own estimate).
    #[must_use]
    pub fn wilson(k: u64, n: u64) -> Self {
        let (value, lo, hi) = wilson_f64(k as f64, n as f64);
        Self { k, n, value, lo, hi }
    }
}

/// The Wilson score 95 % interval `(k / n, lo, hi)` for a count `k` of `n` that need not be whole (an effective
/// sample size, [`clustered_wilson`]); [`Rate::wilson`] is this function of its integers. NaN when `n` is not
/// positive; the ends are exact at `k = 0` and `k >= n` (see [`Rate::wilson`]).
#[must_use]
pub fn wilson_f64(k: f64, n: f64) -> (f64, f64, f64) {
    if n.is_nan() || n <= 0.0 {
        return (f64::NAN, f64::NAN, f64::NAN);
    }
    let z = 1.959_963_984_540_054_f64;
    let p = k / n;
    let z2n = z * z / n;
    let center = (p + z2n / 2.0) / (1.0 + z2n);
    let half = z * (p * (1.0 - p) / n + z2n / (4.0 * n)).sqrt() / (1.0 + z2n);
    let lo = if k <= 0.0 { 0.0 } else { (center - half).max(0.0) };
    let hi = if k >= n { 1.0 } else { (center + half).min(1.0) };
    (p, lo, hi)
}

/// A 95 % interval for a ratio of counts that come in clusters (the object states of one track), from
/// [`clustered_wilson`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ClusteredRate {
    /// Clusters with at least one trial (`m`).
    pub clusters: u64,
    /// Design effect (at least 1).
    pub deff: f64,
    /// Effective sample size `n / deff`.
    pub n_eff: f64,
    /// Lower bound of the 95 % interval.
    pub lo: f64,
    /// Upper bound of the 95 % interval.
    pub hi: f64,
}

/// The 95 % interval of `p = sum k_i / sum n_i` over clusters of `(k_i, n_i)` (successes, trials), accounting
/// for the correlation within a cluster: the Wilson interval with the effective sample size (Kish's design effect;
/// Korn & Graubard, "Confidence intervals for proportions with small expected number of positive counts estimated
/// from survey data", Survey Methodology 24(2), 1998):
///
/// - `V = m / (m - 1) * sum (k_i - p n_i)^2 / n^2`, the with-replacement variance of the ratio estimator over the
///   `m` clusters with `n_i > 0` (`n = sum n_i`);
/// - `V_srs = p (1 - p) / (n - 1)`, the variance of states drawn independently, with the same small-sample
///   correction (`n / (n - 1)` for `n` clusters of one state), so that clusters of one state each give exactly
///   `deff = 1` and the plain Wilson interval;
/// - `deff = max(1, V / V_srs)` (1 when `p` is 0 or 1 or `m < 2`: one cluster tells nothing of the spread
///   between clusters, and the interval is the per-state one), `n_eff = n / deff`;
/// - the interval: [`wilson_f64`]`(p n_eff, n_eff)`.
///
/// Tracks that are all detected or all missed (clusters of `s` states each, all or nothing) give `deff` close to
/// `s`: `n_eff` close to the number of tracks. The comparison `V <= V_srs` is made in exact integers (where they
/// fit), so that `deff` is exactly 1 when the clusters vary no more than independent states would.
///
/// # Errors
/// A cluster with more successes than trials.
pub fn clustered_wilson(clusters: &[(u64, u64)]) -> Result<ClusteredRate, String> {
    if let Some(i) = clusters.iter().position(|&(k, n)| k > n) {
        return Err(format!("cluster {i}: {} successes of {} trials", clusters[i].0, clusters[i].1));
    }
    let used: Vec<(u128, u128)> =
        clusters.iter().filter(|c| c.1 > 0).map(|&(k, n)| (u128::from(k), u128::from(n))).collect();
    let m = used.len() as u64;
    let (k, n) = used.iter().fold((0u128, 0u128), |(a, b), c| (a + c.0, b + c.1));
    let deff = if m < 2 || k == 0 || k == n { 1.0 } else { design_effect(&used, m, k, n) };
    // `p n_eff` as `k / deff`: at `deff = 1` the very counts of the per-state interval, bit for bit.
    let n_eff = n as f64 / deff;
    let (_, lo, hi) = wilson_f64(k as f64 / deff, n_eff);
    Ok(ClusteredRate { clusters: m, deff, n_eff, lo, hi })
}

/// `max(1, V / V_srs)` of [`clustered_wilson`] for `m >= 2` clusters and `0 < k < n`. With `p = k / n` the ratio is
/// `m (n - 1) S / ((m - 1) n^2 k (n - k))`, `S = sum (n k_i - k n_i)^2`: integers, compared exactly when they fit
/// in 128 bits, else in floating point.
fn design_effect(used: &[(u128, u128)], m: u64, k: u128, n: u128) -> f64 {
    let m = u128::from(m);
    let exact = || -> Option<(u128, u128)> {
        let mut s = 0u128;
        for &(ki, ni) in used {
            let d = (n.checked_mul(ki)?).abs_diff(k.checked_mul(ni)?);
            s = s.checked_add(d.checked_mul(d)?)?;
        }
        let num = m.checked_mul(n - 1)?.checked_mul(s)?;
        let den = (m - 1).checked_mul(n.checked_mul(n)?)?.checked_mul(k)?.checked_mul(n - k)?;
        Some((num, den))
    };
    if let Some((num, den)) = exact() {
        return if num <= den { 1.0 } else { num as f64 / den as f64 };
    }
    let (kf, nf, mf) = (k as f64, n as f64, m as f64);
    let p = kf / nf;
    let s: f64 = used.iter().map(|&(ki, ni)| (ki as f64 - p * ni as f64).powi(2)).sum();
    let v = mf / (mf - 1.0) * s / (nf * nf);
    let v_srs = p * (1.0 - p) / (nf - 1.0);
    (v / v_srs).max(1.0)
}

/// One object in one frame, as the evaluation sees it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Outcome {
    /// Frame index within the run.
    pub frame: u64,
    /// Object id.
    pub id: u64,
    /// In scope (see module docs).
    pub in_scope: bool,
    /// An error was injected into this object in this frame.
    pub injected: bool,
    /// Sensor checks raised an alarm.
    pub sensor_alarm: bool,
    /// The error is verifiable by the sensor: the same object without the error (in the clean frame) is
    /// confirmed by its LiDAR evidence (`eta >= tau_tp`). Occluded or evidence-free objects are not.
    pub sensor_judged: bool,
    /// Plausibility checks raised an alarm.
    pub plausibility_alarm: bool,
    /// For an injected position error the sensor checks flagged: whether the verdict reports it as the displacement
    /// it is, on the object's own evidence ([`reported_displacement_agrees`]). `None` when no position error was
    /// injected, nothing was flagged, or the offset was not looked at.
    pub sensor_offset_agrees: Option<bool>,
    /// Which test raised the sensor alarm ([`cause_index`]); `None` without an alarm.
    pub sensor_cause: Option<u8>,
}

/// How near the true box the centroid of the cluster a verdict attributes must stand for that evidence to count as
/// the object's own (metres): returns lie on the object's surface, and a cluster's centroid is that of its cells.
pub const OWN_EVIDENCE_TOLERANCE_M: f32 = 0.5;

/// Whether a flagged position error is reported as the displacement it is: the verdict is `position_error`, and
/// the evidence it rests on is the object's own: the attributed cluster's centroid within
/// [`OWN_EVIDENCE_TOLERANCE_M`] of the true box (`truth`, the object without the error), or, for a verdict without
/// a cluster (free space seen through the box, a jump from remembered evidence), its offset pointing the way the
/// box was displaced ([`offset_agrees`]). A ghost verdict never agrees: it says there is no object.
#[must_use]
pub fn reported_displacement_agrees(
    sensor: &pmon_monitor::SensorOutcome,
    clusters: &[pmon_monitor::ClusterReport],
    truth: &pmon_monitor::ObjectState,
    injected: [f32; 2],
) -> bool {
    if sensor.verdict != pmon_monitor::SensorVerdict::PositionError {
        return false;
    }
    match sensor.cluster.and_then(|k| clusters.get(usize::from(k))) {
        Some(c) => distance_to_box(c.centroid_m, truth) <= OWN_EVIDENCE_TOLERANCE_M,
        None => offset_agrees(sensor.offset_m, injected),
    }
}

/// [`Outcome::sensor_offset_agrees`] of one object state: `injected` is the position offset injected into it
/// (`None`: nothing injected), `truth` the object without the error. For a non-zero offset the sensor checks flagged
/// (`ghost` or `position_error`), whether the verdict reports it as the displacement it is
/// ([`reported_displacement_agrees`]); `None` otherwise.
#[must_use]
pub fn offset_outcome(
    sensor: &pmon_monitor::SensorOutcome,
    clusters: &[pmon_monitor::ClusterReport],
    truth: Option<&pmon_monitor::ObjectState>,
    injected: Option<[f32; 2]>,
) -> Option<bool> {
    let flagged =
        matches!(sensor.verdict, pmon_monitor::SensorVerdict::Ghost | pmon_monitor::SensorVerdict::PositionError);
    let d = injected.filter(|d| flagged && (d[0] != 0.0 || d[1] != 0.0))?;
    truth.map(|t| reported_displacement_agrees(sensor, clusters, t, d))
}

/// Distance from a point to an object's box (0 inside), metres; NaN in, NaN out.
#[must_use]
pub fn distance_to_box(p: [f32; 2], o: &pmon_monitor::ObjectState) -> f32 {
    let (dx, dy) = (p[0] - o.x_m, p[1] - o.y_m);
    let (s, c) = o.heading_rad.sin_cos();
    let (u, v) = (dx * c + dy * s, -dx * s + dy * c);
    let (ou, ov) = ((u.abs() - 0.5 * o.length_m).max(0.0), (v.abs() - 0.5 * o.width_m).max(0.0));
    if u.is_nan() || v.is_nan() {
        return f32::NAN;
    }
    ou.hypot(ov)
}

/// Whether a reported offset (from the evidence to the box, the verdict's `offset_m`) points the way the box was
/// displaced (`injected`, box minus truth): within 45 degrees of it (for verdicts without a cluster; with one, the
/// offset runs to the box's nearest point and can stand at any angle to a diagonal displacement of a long box,
/// so [`reported_displacement_agrees`] looks at the cluster itself). A zero offset (nothing reported) never agrees,
/// and neither does any offset for a zero displacement.
#[must_use]
pub fn offset_agrees(reported: [f32; 2], injected: [f32; 2]) -> bool {
    let (r, d) = ([f64::from(reported[0]), f64::from(reported[1])], [f64::from(injected[0]), f64::from(injected[1])]);
    let dot = r[0] * d[0] + r[1] * d[1];
    let norms = r[0].hypot(r[1]) * d[0].hypot(d[1]);
    norms > 0.0 && dot >= core::f64::consts::FRAC_1_SQRT_2 * norms
}

/// How often the sensor checks report the displacement of the position errors they flag (see
/// [`Outcome::sensor_offset_agrees`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct OffsetTally {
    /// Verifiable injected position errors in scope that the sensor checks flagged and whose offset was looked at.
    pub flagged: u64,
    /// Of those, reported as the displacement they are ([`reported_displacement_agrees`]).
    pub agrees: u64,
}

impl OffsetTally {
    /// `agrees / flagged`.
    #[must_use]
    pub fn rate(&self) -> Rate {
        Rate::wilson(self.agrees, self.flagged)
    }
}

/// The number of alarm causes [`CauseTally`] counts: a ghost, each [`pmon_monitor::PositionCause`], and a position
/// error that names no cause.
pub const CAUSES: usize = 2 + pmon_monitor::PositionCause::ALL.len();

/// The index of the test that raised a sensor alarm, as [`CauseTally`] counts it: 0 for a ghost, `1 + i` for the
/// position cause `PositionCause::ALL[i]`, `CAUSES - 1` for a position error without a cause; `None` when the
/// verdict is not an alarm.
#[must_use]
pub fn cause_index(sensor: &pmon_monitor::SensorOutcome) -> Option<u8> {
    use pmon_monitor::{PositionCause, SensorVerdict};
    match sensor.verdict {
        SensorVerdict::Ghost => Some(0),
        SensorVerdict::PositionError => {
            let i = sensor.position_cause.and_then(|c| PositionCause::ALL.iter().position(|&a| a == c));
            Some(i.map_or(CAUSES - 1, |i| 1 + i) as u8)
        }
        _ => None,
    }
}

/// The name of cause `index` ([`cause_index`]): `ghost`, a position cause's name (`displaced_evidence`, ...), or
/// `position_error (no cause)`.
#[must_use]
pub fn cause_name(index: usize) -> &'static str {
    match index {
        0 => "ghost",
        i => pmon_monitor::PositionCause::ALL.get(i - 1).map_or("position_error (no cause)", |c| c.name()),
    }
}

/// Alarm counts by the test that raised them, one named field per cause (the JSON keys; `no_cause` is a position
/// error that names none), read and written by cause index ([`cause_index`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct CauseCounts {
    /// Ghosts (index 0).
    pub ghost: u64,
    /// `PositionCause::DisplacedEvidence`.
    pub displaced_evidence: u64,
    /// `PositionCause::EvidenceFollowed`.
    pub evidence_followed: u64,
    /// `PositionCause::JumpedFromEvidence`.
    pub jumped_from_evidence: u64,
    /// `PositionCause::SeenThrough`.
    pub seen_through: u64,
    /// `PositionCause::FaceInFront`.
    pub face_in_front: u64,
    /// `PositionCause::ReturnsBeyond`.
    pub returns_beyond: u64,
    /// `PositionCause::EvidenceReleased` (absent from results written before it: 0).
    #[serde(default)]
    pub evidence_released: u64,
    /// `PositionCause::EvidenceRunsOn` (absent from results written before it: 0).
    #[serde(default)]
    pub evidence_runs_on: u64,
    /// `PositionCause::HeldWhileParked` (absent from results written before it: 0).
    #[serde(default)]
    pub held_while_parked: u64,
    /// Position errors without a cause (index `CAUSES - 1`).
    pub no_cause: u64,
}

impl CauseCounts {
    /// The counter of cause `index`; `None` beyond [`CAUSES`].
    pub fn slot(&mut self, index: usize) -> Option<&mut u64> {
        Some(match index {
            0 => &mut self.ghost,
            1 => &mut self.displaced_evidence,
            2 => &mut self.evidence_followed,
            3 => &mut self.jumped_from_evidence,
            4 => &mut self.seen_through,
            5 => &mut self.face_in_front,
            6 => &mut self.returns_beyond,
            7 => &mut self.evidence_released,
            8 => &mut self.evidence_runs_on,
            9 => &mut self.held_while_parked,
            10 => &mut self.no_cause,
            _ => return None,
        })
    }

    /// The count of cause `index` (0 beyond [`CAUSES`]).
    #[must_use]
    pub fn get(&self, index: usize) -> u64 {
        let mut copy = *self;
        copy.slot(index).map_or(0, |n| *n)
    }

    /// All counts.
    #[must_use]
    pub fn total(&self) -> u64 {
        (0..CAUSES).map(|k| self.get(k)).sum()
    }

    /// Adds `other`'s counts.
    pub fn add(&mut self, other: &Self) {
        for k in 0..CAUSES {
            if let Some(n) = self.slot(k) {
                *n += other.get(k);
            }
        }
    }
}

/// The sensor alarms of a run by the test that raised them ([`cause_index`]): those on verifiable injected errors
/// (they add up to [`Metrics::sensor_verifiable`]`.detected`) and those on clean object states (they add up to the
/// sensor's false alarms), object states in scope only.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct CauseTally {
    /// Alarms on verifiable injected errors, by cause.
    pub found: CauseCounts,
    /// False alarms (alarms on clean object states), by cause.
    pub false_alarms: CauseCounts,
}

impl CauseTally {
    /// Adds `other`'s counts.
    pub fn add(&mut self, other: &Self) {
        self.found.add(&other.found);
        self.false_alarms.add(&other.false_alarms);
    }

    /// Whether it counts no alarm at all.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.found.total() + self.false_alarms.total() == 0
    }
}

/// Detection and alarm counts of one check.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Score {
    /// Injected errors in scope.
    pub injected: u64,
    /// Of those, detected.
    pub detected: u64,
    /// Alarms on object states in scope.
    pub alarms: u64,
    /// Of those, explained by an injection.
    pub true_alarms: u64,
}

impl Score {
    /// Recall `detected / injected`.
    #[must_use]
    pub fn recall(&self) -> Rate {
        Rate::wilson(self.detected, self.injected)
    }

    /// Precision `true_alarms / alarms`.
    #[must_use]
    pub fn precision(&self) -> Rate {
        Rate::wilson(self.true_alarms, self.alarms)
    }

    /// False alarms.
    #[must_use]
    pub fn false_alarms(&self) -> u64 {
        self.alarms - self.true_alarms
    }
}

/// Everything scored over one run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Metrics {
    /// Frames.
    pub frames: u64,
    /// Object states in scope.
    pub states_in_scope: u64,
    /// Object states in scope that carry no injection (the denominator of false-alarm rates).
    pub clean_states_in_scope: u64,
    /// Sensor checks.
    pub sensor: Score,
    /// Plausibility checks.
    pub plausibility: Score,
    /// Both.
    pub combined: Score,
    /// Injected errors in scope on objects the sensor does not confirm even without the error (occluded,
    /// too few points): no LiDAR check can verify them.
    pub not_verifiable: u64,
    /// Injected errors on objects the sensor confirms when clean, and of those detected.
    pub sensor_verifiable: Score,
    /// Missed-object alarms (unattributed conflict clusters in the region of interest).
    pub missed_object_alarms: u64,
    /// The displacement the sensor checks report for the verifiable position errors they flag.
    #[serde(default)]
    pub sensor_offset: OffsetTally,
    /// The sensor alarms by the test that raised them.
    #[serde(default)]
    pub sensor_causes: CauseTally,
}

impl Metrics {
    /// False-alarm rate of a check on clean object states: false alarms / clean states in scope.
    #[must_use]
    pub fn false_alarm_rate(&self, score: &Score) -> Rate {
        Rate::wilson(score.false_alarms(), self.clean_states_in_scope)
    }
}

/// One track's share of a run's sensor-check counts: the clusters of [`clustered_wilson`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct TrackTally {
    /// Object (track) id.
    pub id: u64,
    /// Its verifiable injected errors in scope (its share of [`Metrics::sensor_verifiable`]`.injected`).
    pub verifiable: u64,
    /// Of those, detected by the sensor checks.
    pub detected: u64,
    /// Its sensor alarms in scope (its share of [`Metrics::sensor`]`.alarms`).
    pub alarms: u64,
    /// Of those, explained by an injection.
    pub true_alarms: u64,
    /// Its share of [`Metrics::sensor_offset`]`.flagged`.
    #[serde(default)]
    pub offset_flagged: u64,
    /// Its share of [`Metrics::sensor_offset`]`.agrees`.
    #[serde(default)]
    pub offset_agrees: u64,
}

/// Scores a run's outcomes (any order) with a plausibility window of `window >= 1` frames.
#[must_use]
pub fn score(outcomes: &[Outcome], window: u64, frames: u64, missed_object_alarms: u64) -> Metrics {
    score_by_track(outcomes, window, frames, missed_object_alarms).0
}

/// [`score`], and the sensor checks' counts per track (sorted by id; only tracks with a verifiable error or an
/// alarm): they add up to `sensor_verifiable.{injected, detected}` and `sensor.{alarms, true_alarms}`.
#[must_use]
pub fn score_by_track(
    outcomes: &[Outcome],
    window: u64,
    frames: u64,
    missed_object_alarms: u64,
) -> (Metrics, Vec<TrackTally>) {
    let window = window.max(1);
    let by_key: HashMap<(u64, u64), &Outcome> = outcomes.iter().map(|o| ((o.id, o.frame), o)).collect();
    let mut m = Metrics { frames, missed_object_alarms, ..Metrics::default() };
    let mut tracks: BTreeMap<u64, TrackTally> = BTreeMap::new();
    for o in outcomes.iter().filter(|o| o.in_scope) {
        if (o.injected && o.sensor_judged) || o.sensor_alarm {
            let t = tracks.entry(o.id).or_insert(TrackTally { id: o.id, ..TrackTally::default() });
            if o.injected && o.sensor_judged {
                t.verifiable += 1;
                t.detected += u64::from(o.sensor_alarm);
                if let (true, Some(agrees)) = (o.sensor_alarm, o.sensor_offset_agrees) {
                    t.offset_flagged += 1;
                    t.offset_agrees += u64::from(agrees);
                }
            }
            if o.sensor_alarm {
                t.alarms += 1;
                t.true_alarms += u64::from(o.injected);
            }
        }
        m.states_in_scope += 1;
        if !o.injected {
            m.clean_states_in_scope += 1;
        }
        let later_plaus = (0..window)
            .any(|j| o.frame.checked_add(j).and_then(|f| by_key.get(&(o.id, f))).is_some_and(|x| x.plausibility_alarm));
        let earlier_injection = (0..window)
            .any(|j| o.frame.checked_sub(j).and_then(|f| by_key.get(&(o.id, f))).is_some_and(|x| x.injected));
        if o.injected {
            m.sensor.injected += 1;
            m.plausibility.injected += 1;
            m.combined.injected += 1;
            m.sensor.detected += u64::from(o.sensor_alarm);
            m.plausibility.detected += u64::from(later_plaus);
            m.combined.detected += u64::from(o.sensor_alarm || later_plaus);
            if o.sensor_judged {
                m.sensor_verifiable.injected += 1;
                m.sensor_verifiable.detected += u64::from(o.sensor_alarm);
                if let (true, Some(agrees)) = (o.sensor_alarm, o.sensor_offset_agrees) {
                    m.sensor_offset.flagged += 1;
                    m.sensor_offset.agrees += u64::from(agrees);
                }
                if let (true, Some(c)) = (o.sensor_alarm, o.sensor_cause) {
                    if let Some(n) = m.sensor_causes.found.slot(usize::from(c)) {
                        *n += 1;
                    }
                }
            } else {
                m.not_verifiable += 1;
            }
        }
        if o.sensor_alarm {
            m.sensor.alarms += 1;
            m.sensor.true_alarms += u64::from(o.injected);
            if let (false, Some(c)) = (o.injected, o.sensor_cause) {
                if let Some(n) = m.sensor_causes.false_alarms.slot(usize::from(c)) {
                    *n += 1;
                }
            }
        }
        if o.plausibility_alarm {
            m.plausibility.alarms += 1;
            m.plausibility.true_alarms += u64::from(earlier_injection);
        }
        if o.sensor_alarm || o.plausibility_alarm {
            m.combined.alarms += 1;
            let explained = (o.sensor_alarm && o.injected) || (o.plausibility_alarm && earlier_injection);
            m.combined.true_alarms += u64::from(explained);
        }
    }
    (m, tracks.into_values().collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wilson_matches_known_values() {
        // 8 of 10: Wilson 95 % interval (0.4902, 0.9433).
        let r = Rate::wilson(8, 10);
        assert!((r.lo - 0.4902).abs() < 1e-3 && (r.hi - 0.9433).abs() < 1e-3, "{r:?}");
        let r = Rate::wilson(0, 100);
        assert!(r.lo.abs() < 1e-12 && (r.hi - 0.0370).abs() < 1e-3, "{r:?}");
        assert!(Rate::wilson(0, 0).value.is_nan());
    }

    /// The interval holds its own estimate at every count, the ends included (38 of 38 gave an upper bound of
    /// 0.9999999999999999 before the ends were made exact).
    #[test]
    fn wilson_interval_holds_the_rate_at_every_count() {
        for n in 1..=400u64 {
            for k in 0..=n {
                let r = Rate::wilson(k, n);
                assert!(r.lo <= r.value && r.value <= r.hi && r.lo >= 0.0 && r.hi <= 1.0, "{k} of {n}: {r:?}");
            }
        }
        assert_eq!(Rate::wilson(38, 38).hi, 1.0);
        assert_eq!(Rate::wilson(0, 38).lo, 0.0);
    }

    /// `Rate::wilson` through `wilson_f64` gives the bits of the integer formula it replaced (kept here verbatim).
    #[test]
    fn wilson_through_f64_keeps_the_integer_bits() {
        let before = |k: u64, n: u64| -> (f64, f64, f64) {
            let z = 1.959_963_984_540_054_f64;
            let nf = n as f64;
            let p = k as f64 / nf;
            let z2n = z * z / nf;
            let center = (p + z2n / 2.0) / (1.0 + z2n);
            let half = z * (p * (1.0 - p) / nf + z2n / (4.0 * nf)).sqrt() / (1.0 + z2n);
            let lo = if k == 0 { 0.0 } else { (center - half).max(0.0) };
            let hi = if k >= n { 1.0 } else { (center + half).min(1.0) };
            (p, lo, hi)
        };
        for n in (1..=300u64).chain([1_000, 4_567, 123_456]) {
            for k in (0..=n).step_by((n / 300).max(1) as usize).chain([n]) {
                let (r, (p, lo, hi)) = (Rate::wilson(k, n), before(k, n));
                assert_eq!(
                    (r.value.to_bits(), r.lo.to_bits(), r.hi.to_bits()),
                    (p.to_bits(), lo.to_bits(), hi.to_bits())
                );
            }
        }
    }

    /// Tracks of one state each are independent states: the plain Wilson interval, bit for bit, `deff = 1`.
    #[test]
    fn clusters_of_one_state_give_the_plain_wilson_interval() {
        for n in 1..=60u64 {
            for k in 0..=n {
                let clusters: Vec<(u64, u64)> = (0..n).map(|i| (u64::from(i < k), 1)).collect();
                let c = clustered_wilson(&clusters).unwrap_or_else(|e| panic!("{e}"));
                let r = Rate::wilson(k, n);
                assert_eq!(
                    (c.lo.to_bits(), c.hi.to_bits(), c.deff, c.clusters),
                    (r.lo.to_bits(), r.hi.to_bits(), 1.0, n)
                );
            }
        }
    }

    /// Tracks all detected or all missed, `s` states each: `deff` close to `s`, `n_eff` close to the number of
    /// tracks, and the interval that of so many independent trials.
    #[test]
    fn all_or_nothing_tracks_count_once_each() {
        for (m, s, hit) in [(40u64, 10u64, 30u64), (12, 50, 5), (3, 7, 1), (200, 3, 150)] {
            let clusters: Vec<(u64, u64)> = (0..m).map(|i| (if i < hit { s } else { 0 }, s)).collect();
            let c = clustered_wilson(&clusters).unwrap_or_else(|e| panic!("{e}"));
            let n = (m * s) as f64;
            // Exactly: deff = (n - 1) / (m - 1), n_eff = n (m - 1) / (n - 1).
            assert!((c.deff - (n - 1.0) / (m - 1) as f64).abs() < 1e-9, "{m} x {s}: {c:?}");
            assert!((c.n_eff - m as f64).abs() < 1.0, "{m} x {s}: {c:?}");
            let (_, lo, hi) = wilson_f64(hit as f64 * c.n_eff / m as f64, c.n_eff);
            assert!((c.lo - lo).abs() < 1e-12 && (c.hi - hi).abs() < 1e-12);
            let r = Rate::wilson(hit * s, m * s);
            assert!(c.lo < r.lo && c.hi > r.hi, "{m} x {s}: {c:?} vs {r:?}");
        }
    }

    #[test]
    fn clustered_edges() {
        // p = 0 and p = 1: nothing varies, deff = 1, the per-state interval.
        for (clusters, k, n) in [(vec![(0, 5), (0, 9)], 0, 14), (vec![(5, 5), (9, 9), (0, 0)], 14, 14)] {
            let c = clustered_wilson(&clusters).unwrap_or_else(|e| panic!("{e}"));
            let r = Rate::wilson(k, n);
            assert_eq!((c.deff, c.lo, c.hi, c.clusters), (1.0, r.lo, r.hi, 2));
        }
        // One cluster: no spread between clusters to measure; the per-state interval, m = 1.
        let c = clustered_wilson(&[(3, 10), (0, 0)]).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!((c.deff, c.lo, c.hi, c.clusters), (1.0, Rate::wilson(3, 10).lo, Rate::wilson(3, 10).hi, 1));
        // Empty: no interval.
        for empty in [vec![], vec![(0, 0)]] {
            let c = clustered_wilson(&empty).unwrap_or_else(|e| panic!("{e}"));
            assert!(c.lo.is_nan() && c.hi.is_nan() && c.clusters == 0 && c.n_eff == 0.0, "{c:?}");
        }
        // More successes than trials: an error naming the cluster.
        assert_eq!(clustered_wilson(&[(1, 2), (3, 2)]), Err("cluster 1: 3 successes of 2 trials".into()));
    }

    /// The clustered interval holds the per-state one (the Wilson interval is nested in `n` at a given rate, and
    /// `n_eff <= n`), and counts too large for the exact comparison still give an interval.
    #[test]
    fn clustered_interval_holds_the_per_state_one() {
        let mut x = 12_345u64;
        let mut next = |b: u64| {
            x = x.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            (x >> 33) % b
        };
        for _ in 0..2000 {
            let clusters: Vec<(u64, u64)> = (0..1 + next(30))
                .map(|_| {
                    let n = next(40);
                    (next(n + 1), n)
                })
                .collect();
            let c = clustered_wilson(&clusters).unwrap_or_else(|e| panic!("{e}"));
            let r = Rate::wilson(clusters.iter().map(|c| c.0).sum(), clusters.iter().map(|c| c.1).sum());
            assert!(c.deff >= 1.0 && c.n_eff <= r.n as f64, "{clusters:?}: {c:?}");
            if r.n > 0 {
                assert!(c.lo <= r.lo + 1e-12 && c.hi >= r.hi - 1e-12, "{clusters:?}: {c:?} vs {r:?}");
            }
        }
        let big = [(u64::MAX / 4, u64::MAX / 2), (1, u64::MAX / 2)];
        let c = clustered_wilson(&big).unwrap_or_else(|e| panic!("{e}"));
        assert!(c.deff > 1.0 && c.lo < 0.25 && c.hi > 0.25, "{c:?}");
    }

    /// The per-track counts add up to the run's totals, whatever mix of scope, injections, verifiability and
    /// alarms the states carry.
    #[test]
    fn track_tallies_add_up_to_the_totals() {
        let mut x = 99u64;
        let mut bit = |one_in: u64| {
            x = x.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            (x >> 33).is_multiple_of(one_in)
        };
        let mut outs = Vec::new();
        for frame in 0..50 {
            for id in [3, 17, 4, 99, 8, 1000] {
                outs.push(Outcome {
                    frame,
                    id,
                    in_scope: !bit(8),
                    injected: bit(2),
                    sensor_alarm: bit(3),
                    sensor_judged: !bit(4),
                    plausibility_alarm: bit(5),
                    sensor_offset_agrees: bit(2).then(|| bit(3)),
                    sensor_cause: None,
                });
            }
        }
        let (m, tracks) = score_by_track(&outs, 2, 50, 0);
        assert_eq!(m, score(&outs, 2, 50, 0));
        let sum = |f: fn(&TrackTally) -> u64| tracks.iter().map(f).sum::<u64>();
        assert_eq!(
            (sum(|t| t.verifiable), sum(|t| t.detected), sum(|t| t.alarms), sum(|t| t.true_alarms)),
            (m.sensor_verifiable.injected, m.sensor_verifiable.detected, m.sensor.alarms, m.sensor.true_alarms)
        );
        assert_eq!(
            (sum(|t| t.offset_flagged), sum(|t| t.offset_agrees)),
            (m.sensor_offset.flagged, m.sensor_offset.agrees)
        );
        assert!(m.sensor_offset.flagged > m.sensor_offset.agrees && m.sensor_offset.agrees > 0);
        assert!(m.sensor_offset.flagged <= m.sensor_verifiable.detected);
        assert!(m.sensor_verifiable.injected > 0 && m.sensor.alarms > m.sensor.true_alarms);
        assert_eq!(tracks.iter().map(|t| t.id).collect::<Vec<_>>(), [3, 4, 8, 17, 99, 1000]);
    }

    /// Within 45 degrees, either way round; nothing reported, or no displacement, never agrees.
    #[test]
    fn offsets_agree_within_45_degrees() {
        assert!(offset_agrees([0.7, 0.0], [1.0, 0.0]));
        assert!(offset_agrees([0.5, 0.49], [2.0, 0.0]));
        assert!(!offset_agrees([0.5, 0.51], [2.0, 0.0]));
        assert!(!offset_agrees([-0.7, 0.0], [1.0, 0.0]));
        assert!(!offset_agrees([0.0, 0.0], [1.0, 0.0]));
        assert!(!offset_agrees([1.0, 0.0], [0.0, 0.0]));
        assert!(!offset_agrees([f32::NAN, 0.0], [1.0, 0.0]));
    }

    /// The cluster decides when there is one (its centroid on the true box, within the tolerance), the offset's
    /// direction when there is none; a ghost never agrees.
    #[test]
    fn a_displacement_is_reported_on_the_objects_own_evidence() {
        use pmon_monitor::{ClusterReport, ObjectClass, ObjectState, SensorOutcome, SensorVerdict};
        let truth = ObjectState {
            id: 1,
            class: ObjectClass::Car,
            x_m: 10.0,
            y_m: 0.0,
            heading_rad: core::f32::consts::FRAC_PI_2,
            speed_mps: 0.0,
            length_m: 4.0,
            width_m: 2.0,
            uncertainty: None,
        };
        assert!((distance_to_box([10.0, 2.5], &truth) - 0.5).abs() < 1e-5);
        assert!((distance_to_box([11.6, 0.0], &truth) - 0.6).abs() < 1e-5);
        assert_eq!(distance_to_box([10.2, -1.0], &truth), 0.0);
        let cluster = |at: [f32; 2]| ClusterReport {
            cells: 4,
            centroid_m: at,
            bounds_m: [at[0], at[1], at[0], at[1]],
            in_roi: true,
            roi: pmon_monitor::RoiStatus::NoRoi,
            object: Some(0),
        };
        let clusters = [cluster([10.9, 1.0]), cluster([13.0, 0.0])];
        let flagged = |verdict, cluster, offset_m| SensorOutcome {
            verdict,
            eta: 0.5,
            eta_own: 0.5,
            margin_length_m: 0.4,
            margin_width_m: 0.4,
            visible_fraction: 1.0,
            cluster,
            offset_m,
            position_cause: None,
        };
        let agrees = |verdict, cluster, offset_m| {
            reported_displacement_agrees(&flagged(verdict, cluster, offset_m), &clusters, &truth, [1.5, 1.5])
        };
        // Its own returns, whatever the angle of the offset to the box's nearest point.
        assert!(agrees(SensorVerdict::PositionError, Some(0), [0.0, -0.4]));
        // A neighbour's, even with an offset that points the right way.
        assert!(!agrees(SensorVerdict::PositionError, Some(1), [1.0, 1.0]));
        // No cluster: the offset's direction.
        assert!(agrees(SensorVerdict::PositionError, None, [0.8, 1.0]));
        assert!(!agrees(SensorVerdict::PositionError, None, [-0.8, 1.0]));
        assert!(!agrees(SensorVerdict::Ghost, Some(0), [0.0, 0.0]));
        // What an outcome records: nothing without an injected offset or an alarm, the agreement otherwise.
        let outcome = |verdict, injected| {
            offset_outcome(&flagged(verdict, Some(0), [0.0, -0.4]), &clusters, Some(&truth), injected)
        };
        assert_eq!(outcome(SensorVerdict::PositionError, Some([1.5, 1.5])), Some(true));
        assert_eq!(outcome(SensorVerdict::Ghost, Some([1.5, 1.5])), Some(false));
        assert_eq!(outcome(SensorVerdict::PositionError, Some([0.0, 0.0])), None);
        assert_eq!(outcome(SensorVerdict::PositionError, None), None);
        assert_eq!(outcome(SensorVerdict::Consistent, Some([1.5, 1.5])), None);
    }

    /// Each verdict's cause has its own slot, and the alarms by cause add up to the errors found and the false
    /// alarms whatever mix of scope, injections, verifiability and alarms the states carry.
    #[test]
    fn alarms_by_cause_add_up_to_the_found_errors_and_the_false_alarms() {
        use pmon_monitor::{PositionCause, SensorOutcome, SensorVerdict};
        let mut sensor = SensorOutcome {
            verdict: SensorVerdict::NotMonitored(pmon_monitor::NotMonitoredReason::Occluded),
            eta: 0.0,
            eta_own: 0.0,
            margin_length_m: 0.0,
            margin_width_m: 0.0,
            visible_fraction: 0.0,
            cluster: None,
            offset_m: [0.0; 2],
            position_cause: None,
        };
        assert_eq!(cause_index(&sensor), None);
        sensor.verdict = SensorVerdict::Consistent;
        assert_eq!(cause_index(&sensor), None);
        sensor.verdict = SensorVerdict::Ghost;
        assert_eq!(cause_index(&sensor), Some(0));
        sensor.verdict = SensorVerdict::PositionError;
        assert_eq!(cause_index(&sensor), Some((CAUSES - 1) as u8));
        let mut names = vec![cause_name(0), cause_name(CAUSES - 1)];
        for (i, c) in PositionCause::ALL.into_iter().enumerate() {
            sensor.position_cause = Some(c);
            assert_eq!(cause_index(&sensor), Some(1 + i as u8));
            assert_eq!(cause_name(1 + i), c.name());
            names.push(c.name());
        }
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), CAUSES);

        let mut x = 7u64;
        let mut draw = |n: u64| {
            x = x.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            (x >> 33) % n
        };
        let mut outs = Vec::new();
        for frame in 0..60 {
            for id in 0..7 {
                let sensor_alarm = draw(3) == 0;
                outs.push(Outcome {
                    frame,
                    id,
                    in_scope: draw(8) != 0,
                    injected: draw(2) == 0,
                    sensor_alarm,
                    sensor_judged: draw(4) != 0,
                    plausibility_alarm: draw(5) == 0,
                    sensor_offset_agrees: None,
                    sensor_cause: sensor_alarm.then(|| draw(CAUSES as u64) as u8),
                });
            }
        }
        let m = score(&outs, 2, 60, 0);
        let c = m.sensor_causes;
        assert!(m.sensor_verifiable.detected > 0 && m.sensor.false_alarms() > 0, "{m:?}");
        assert_eq!(c.found.total(), m.sensor_verifiable.detected);
        assert_eq!(c.false_alarms.total(), m.sensor.false_alarms());
        // Slot by slot: the states of that cause, counted here the straightforward way.
        for k in 0..CAUSES {
            let of = |o: &&Outcome| o.in_scope && o.sensor_alarm && o.sensor_cause == Some(k as u8);
            let found = outs.iter().filter(of).filter(|o| o.injected && o.sensor_judged).count() as u64;
            let false_alarms = outs.iter().filter(of).filter(|o| !o.injected).count() as u64;
            assert_eq!((c.found.get(k), c.false_alarms.get(k)), (found, false_alarms), "cause {k}");
        }
        let mut twice = c;
        twice.add(&c);
        assert_eq!(twice.found.get(1), 2 * c.found.get(1));
        // Its JSON names each cause as `cause_name` does (the last, `position_error (no cause)`, as `no_cause`).
        for k in 0..CAUSES {
            let mut one = CauseCounts::default();
            *one.slot(k).unwrap() = 1;
            let json = serde_json::to_value(one).unwrap();
            let key = if k == CAUSES - 1 { "no_cause" } else { cause_name(k) };
            assert_eq!(json.get(key), Some(&serde_json::json!(1)), "{k}: {json}");
            assert_eq!(one.total(), 1);
        }
        assert!(CauseCounts::default().slot(CAUSES).is_none());
        assert!(!c.is_empty() && CauseTally::default().is_empty());
    }

    fn o(frame: u64, injected: bool, s: bool, p: bool) -> Outcome {
        Outcome {
            frame,
            id: 1,
            in_scope: true,
            injected,
            sensor_alarm: s,
            sensor_judged: true,
            plausibility_alarm: p,
            sensor_offset_agrees: None,
            sensor_cause: None,
        }
    }

    #[test]
    fn plausibility_gets_one_extra_frame() {
        // Error at frame 2, plausibility alarm at frame 3: detected, and the alarm is true.
        let outs =
            [o(1, false, false, false), o(2, true, false, false), o(3, false, false, true), o(4, false, false, false)];
        let m = score(&outs, 2, 4, 0);
        assert_eq!(m.plausibility.detected, 1);
        assert_eq!(m.plausibility.true_alarms, 1);
        assert_eq!(m.plausibility.false_alarms(), 0);
        // With a window of 1 the same alarm is false and the error missed.
        let m = score(&outs, 1, 4, 0);
        assert_eq!(m.plausibility.detected, 0);
        assert_eq!(m.plausibility.false_alarms(), 1);
        assert_eq!(m.clean_states_in_scope, 3);
    }

    #[test]
    fn sensor_alarms_count_only_at_the_same_frame() {
        let outs = [o(1, true, true, false), o(2, false, true, false), o(3, true, false, false)];
        let m = score(&outs, 2, 3, 0);
        assert_eq!((m.sensor.injected, m.sensor.detected, m.sensor.alarms, m.sensor.true_alarms), (2, 1, 2, 1));
        assert_eq!((m.combined.detected, m.combined.false_alarms()), (1, 1));
    }
}
