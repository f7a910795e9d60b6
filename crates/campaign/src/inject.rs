//! Fault injectors. Each records exactly what it injected (object, frame, kind, magnitude, vector): the
//! ground truth of the evaluation.

use pmon_monitor::ObjectState;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};

/// Direction of a position error.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Direction {
    /// Increases the object's distance from the ego vehicle (the paper's setting).
    Away,
    /// Decreases it (the paper's admitted blind spot).
    Towards,
    /// A random direction, drawn per injection.
    Random,
}

impl Direction {
    /// Name for reports.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::Away => "away",
            Self::Towards => "towards",
            Self::Random => "random",
        }
    }
}

/// What to inject into the object list.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Fault {
    /// Nothing (clean run).
    None,
    /// A constant position offset on the affected tracks, in every frame.
    PermanentPosition {
        /// Offset, metres.
        magnitude_m: f32,
        /// Direction.
        direction: Direction,
    },
    /// A position offset injected per object and frame with probability `rate`.
    RandomPosition {
        /// Offset, metres.
        magnitude_m: f32,
        /// Probability per object and frame, in [0, 1].
        rate: f64,
        /// Direction.
        direction: Direction,
    },
    /// A constant speed error on the affected tracks (speed changed, direction kept).
    PermanentSpeed {
        /// Error, m/s (the measured speed becomes `|v + dv|`).
        magnitude_mps: f32,
    },
    /// A speed error injected per object and frame with probability `rate`.
    TransientSpeed {
        /// Error, m/s.
        magnitude_mps: f32,
        /// Probability per object and frame.
        rate: f64,
    },
}

impl Fault {
    /// The error's magnitude in its unit (0 for none).
    #[must_use]
    pub fn magnitude(&self) -> f64 {
        match *self {
            Self::None => 0.0,
            Self::PermanentPosition { magnitude_m, .. } | Self::RandomPosition { magnitude_m, .. } => {
                f64::from(magnitude_m)
            }
            Self::PermanentSpeed { magnitude_mps } | Self::TransientSpeed { magnitude_mps, .. } => {
                f64::from(magnitude_mps)
            }
        }
    }
}

/// Injection settings shared by a run.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct InjectionConfig {
    /// The fault.
    pub fault: Fault,
    /// Gaussian noise on positions (both axes), metres, added to every object (the false-alarm experiment).
    pub position_noise_m: f32,
    /// Correlation time of the position noise, seconds: 0 draws it afresh every frame (white noise); `tau > 0`
    /// makes it a first-order Gauss-Markov process per object, `n_k = rho n_(k-1) + sqrt(1 - rho^2) sigma e_k`
    /// with `rho = exp(-dt / tau)`, the way a tracker's errors drift rather than jump.
    pub noise_correlation_s: f32,
    /// Gaussian noise on speeds, m/s.
    pub speed_noise_mps: f32,
    /// Gaussian noise on headings, radians.
    pub heading_noise_rad: f32,
    /// Fraction of tracks that carry a permanent fault (the others stay clean, so precision means something).
    pub permanent_track_fraction: f64,
    /// The object list reports its uncertainty honestly: the sigma of the added noise, or the nominal value
    /// if larger.
    pub report_noise_in_uncertainty: bool,
    /// Seed.
    pub seed: u64,
    /// One faulty object at a time: when above 0, a permanent fault goes to the tracks [`isolated_tracks`]
    /// picks from the scene instead of `permanent_track_fraction` of them: each stays farther than this many
    /// metres (centre to centre) from every other faulty track in every frame they share, so no two faulty
    /// objects ever meet (docs/evaluation.md, "One object at a time"). 0 (the default; not written to JSON at 0,
    /// so the identities of the runs without it are unchanged): by `permanent_track_fraction`.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub isolation_m: f32,
    /// With `isolation_m`: which of the disjoint sets of isolated tracks carries the fault ([`isolated_tracks`]:
    /// set 0 is picked from every track, set 1 from the tracks set 0 left, and so on). Not written at 0.
    #[serde(default, skip_serializing_if = "is_zero_u32")]
    pub isolation_set: u32,
}

#[allow(clippy::trivially_copy_pass_by_ref)] // serde's `skip_serializing_if` passes a reference
fn is_zero(x: &f32) -> bool {
    *x == 0.0
}

#[allow(clippy::trivially_copy_pass_by_ref)] // serde's `skip_serializing_if` passes a reference
fn is_zero_u32(x: &u32) -> bool {
    *x == 0
}

/// The fixed seed of the order in which [`isolated_tracks`] looks at the tracks: the same for every run of a scene,
/// so that its sets are disjoint and the same tracks carry the error at every magnitude.
const ISOLATION_ORDER_SEED: u64 = 0x0015_07A7_ED5E_7000;

/// The tracks of a scene that carry a permanent fault one at a time ([`InjectionConfig::isolation_m`]), set
/// number `set` of a sequence of disjoint sets: each set takes, from the tracks no earlier set took, in a fixed
/// pseudo-random order of their ids (ties by id), every track whose centre stays farther than `isolation_m` from
/// each track the set took before it in every frame both appear in (the object lists' own positions, the ego frame
/// of each frame). Deterministic for a scene; the same sets at every magnitude of an error.
#[must_use]
pub fn isolated_tracks<'a>(
    isolation_m: f32,
    set: u32,
    frames: impl IntoIterator<Item = &'a [ObjectState]>,
) -> std::collections::BTreeSet<u64> {
    use std::collections::BTreeMap;
    // Per track: (frame, x, y) in frame order.
    let mut tracks: BTreeMap<u64, Vec<(usize, f32, f32)>> = BTreeMap::new();
    for (k, objects) in frames.into_iter().enumerate() {
        for o in objects {
            tracks.entry(o.id).or_default().push((k, o.x_m, o.y_m));
        }
    }
    let mut order: Vec<u64> = tracks.keys().copied().collect();
    order.sort_by(|&a, &b| {
        track_draw(ISOLATION_ORDER_SEED, a).total_cmp(&track_draw(ISOLATION_ORDER_SEED, b)).then(a.cmp(&b))
    });
    let limit2 = isolation_m * isolation_m;
    // True when two tracks come within `isolation_m` of each other in a frame they share.
    let meet = |mine: &[(usize, f32, f32)], theirs: &[(usize, f32, f32)]| {
        // Both lists are in frame order: one merge walk over the frames they share.
        let (mut a, mut b) = (0, 0);
        while let (Some(&(ka, xa, ya)), Some(&(kb, xb, yb))) = (mine.get(a), theirs.get(b)) {
            match ka.cmp(&kb) {
                std::cmp::Ordering::Less => a += 1,
                std::cmp::Ordering::Greater => b += 1,
                std::cmp::Ordering::Equal => {
                    let (dx, dy) = (xa - xb, ya - yb);
                    if dx * dx + dy * dy <= limit2 {
                        return true;
                    }
                    a += 1;
                    b += 1;
                }
            }
        }
        false
    };
    let mut kept: Vec<u64> = Vec::new();
    for _ in 0..=set {
        // Every track is in an earlier set: this one and all after it are empty (bounded whatever `set` says).
        if order.is_empty() {
            return std::collections::BTreeSet::new();
        }
        kept.clear();
        let mut left = Vec::with_capacity(order.len());
        for &id in &order {
            let Some(mine) = tracks.get(&id) else { continue };
            if kept.iter().any(|other| tracks.get(other).is_some_and(|theirs| meet(mine, theirs))) {
                left.push(id);
            } else {
                kept.push(id);
            }
        }
        order = left;
    }
    kept.into_iter().collect()
}

impl InjectionConfig {
    /// A clean configuration with the given fault.
    #[must_use]
    pub fn new(fault: Fault, seed: u64) -> Self {
        Self {
            fault,
            position_noise_m: 0.0,
            noise_correlation_s: 0.0,
            speed_noise_mps: 0.0,
            heading_noise_rad: 0.0,
            permanent_track_fraction: 0.5,
            report_noise_in_uncertainty: true,
            seed,
            isolation_m: 0.0,
            isolation_set: 0,
        }
    }
}

/// One injected error.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Injection {
    /// Frame index.
    pub frame: u64,
    /// Object id.
    pub id: u64,
    /// Index of the object in the frame's list.
    pub index: u32,
    /// Position offset applied, ego frame, metres (zero for speed errors).
    pub offset_m: [f32; 2],
    /// Speed error applied, m/s (zero for position errors).
    pub speed_error_mps: f32,
}

/// Seeded, per-track-stable injector.
pub struct Injector {
    config: InjectionConfig,
    rng: ChaCha8Rng,
    /// Per object: the position noise last drawn and when (only for correlated noise; looked up, never
    /// iterated, so its order does not matter).
    noise_state: std::collections::HashMap<u64, (f64, [f32; 2])>,
    /// The faulty tracks when they were chosen from the scene ([`Injector::for_scene`]), else `None` (by draw).
    faulty: Option<std::collections::BTreeSet<u64>>,
}

/// A stable hash of (seed, id) to [0, 1): decides which tracks carry a permanent fault.
fn track_draw(seed: u64, id: u64) -> f64 {
    // SplitMix64.
    let mut z = seed ^ id.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 53) as f64
}

fn direction_vector(direction: Direction, o: &ObjectState, rng: &mut ChaCha8Rng, id_seed: u64) -> [f32; 2] {
    let r = o.x_m.hypot(o.y_m);
    let radial = if r > 1e-3 { [o.x_m / r, o.y_m / r] } else { [1.0, 0.0] };
    match direction {
        Direction::Away => radial,
        Direction::Towards => [-radial[0], -radial[1]],
        Direction::Random => {
            // Permanent faults keep one direction per track; random faults draw per injection.
            let a = if id_seed == u64::MAX {
                rng.random_range(0.0..std::f32::consts::TAU)
            } else {
                (track_draw(id_seed, 0x5eed) * std::f64::consts::TAU) as f32
            };
            [a.cos(), a.sin()]
        }
    }
}

impl Injector {
    /// A new injector.
    #[must_use]
    pub fn new(config: InjectionConfig) -> Self {
        Self {
            config,
            rng: ChaCha8Rng::seed_from_u64(config.seed),
            noise_state: std::collections::HashMap::new(),
            faulty: None,
        }
    }

    /// The injector of a run over a scene's frames (their object lists, in order): with
    /// [`InjectionConfig::isolation_m`] above 0 the permanent fault goes to the [`isolated_tracks`] of those
    /// frames; otherwise the same as [`Injector::new`].
    #[must_use]
    pub fn for_scene<'a>(config: InjectionConfig, frames: impl IntoIterator<Item = &'a [ObjectState]>) -> Self {
        let mut injector = Self::new(config);
        if config.isolation_m > 0.0 {
            injector.faulty = Some(isolated_tracks(config.isolation_m, config.isolation_set, frames));
        }
        injector
    }

    /// An injector whose permanent fault goes to exactly these tracks (whatever `permanent_track_fraction` and
    /// `isolation_m` say): one track alone, to check that [`isolated_tracks`] runs equal one-at-a-time runs.
    #[must_use]
    pub fn with_faulty_tracks(config: InjectionConfig, tracks: std::collections::BTreeSet<u64>) -> Self {
        Self { faulty: Some(tracks), ..Self::new(config) }
    }

    /// True when the track carries the permanent fault.
    #[must_use]
    pub fn track_is_faulty(&self, id: u64) -> bool {
        match &self.faulty {
            Some(set) => set.contains(&id),
            None => track_draw(self.config.seed, id) < self.config.permanent_track_fraction,
        }
    }

    /// [`Injector::apply_at`] without a timestamp: correlated noise is drawn afresh.
    pub fn apply(&mut self, frame: u64, objects: &mut [ObjectState]) -> Vec<Injection> {
        self.apply_at(frame, f64::NAN, objects)
    }

    /// Applies noise and the fault to a frame's object list in place; returns what was injected.
    /// Randomness is drawn in object order, so a frame's outcome depends only on the seed and the inputs.
    /// `t_s` is the frame's timestamp (for correlated noise).
    pub fn apply_at(&mut self, frame: u64, t_s: f64, objects: &mut [ObjectState]) -> Vec<Injection> {
        let c = self.config;
        let mut out = Vec::new();
        let noise = |sigma: f32| Normal::new(0.0f32, sigma.max(0.0)).ok();
        let (np, nv, nh) = (noise(c.position_noise_m), noise(c.speed_noise_mps), noise(c.heading_noise_rad));
        for (index, o) in objects.iter_mut().enumerate() {
            if c.position_noise_m > 0.0 {
                if let Some(n) = np {
                    let fresh = [n.sample(&mut self.rng), n.sample(&mut self.rng)];
                    let noise = if c.noise_correlation_s > 0.0 {
                        let next = match self.noise_state.get(&o.id) {
                            Some(&(t0, prev)) if t_s > t0 => {
                                let rho = (-(t_s - t0) / f64::from(c.noise_correlation_s)).exp() as f32;
                                let k = (1.0 - rho * rho).max(0.0).sqrt();
                                [rho * prev[0] + k * fresh[0], rho * prev[1] + k * fresh[1]]
                            }
                            _ => fresh,
                        };
                        self.noise_state.insert(o.id, (t_s, next));
                        next
                    } else {
                        fresh
                    };
                    o.x_m += noise[0];
                    o.y_m += noise[1];
                }
            }
            if c.speed_noise_mps > 0.0 {
                if let Some(n) = nv {
                    o.speed_mps = (o.speed_mps + n.sample(&mut self.rng)).abs();
                }
            }
            if c.heading_noise_rad > 0.0 {
                if let Some(n) = nh {
                    o.heading_rad += n.sample(&mut self.rng);
                }
            }
            if c.report_noise_in_uncertainty
                && (c.position_noise_m > 0.0 || c.speed_noise_mps > 0.0 || c.heading_noise_rad > 0.0)
            {
                if let Some(u) = o.uncertainty.as_mut() {
                    u.x_m = u.x_m.max(c.position_noise_m);
                    u.y_m = u.y_m.max(c.position_noise_m);
                    u.speed_mps = u.speed_mps.max(c.speed_noise_mps);
                    u.heading_rad = u.heading_rad.max(c.heading_noise_rad);
                }
            }
            let id = o.id;
            let frame_u = frame;
            let record = |offset_m: [f32; 2], speed_error_mps: f32| Injection {
                frame: frame_u,
                id,
                index: index as u32,
                offset_m,
                speed_error_mps,
            };
            match c.fault {
                Fault::None => {}
                Fault::PermanentPosition { magnitude_m, direction } => {
                    if self.track_is_faulty(id) {
                        let d = direction_vector(direction, o, &mut self.rng, c.seed ^ id);
                        let off = [d[0] * magnitude_m, d[1] * magnitude_m];
                        o.x_m += off[0];
                        o.y_m += off[1];
                        out.push(record(off, 0.0));
                    }
                }
                Fault::RandomPosition { magnitude_m, rate, direction } => {
                    if self.rng.random_bool(rate.clamp(0.0, 1.0)) {
                        let d = direction_vector(direction, o, &mut self.rng, u64::MAX);
                        let off = [d[0] * magnitude_m, d[1] * magnitude_m];
                        o.x_m += off[0];
                        o.y_m += off[1];
                        out.push(record(off, 0.0));
                    }
                }
                Fault::PermanentSpeed { magnitude_mps } => {
                    if self.track_is_faulty(id) {
                        o.speed_mps = (o.speed_mps + magnitude_mps).abs();
                        out.push(record([0.0, 0.0], magnitude_mps));
                    }
                }
                Fault::TransientSpeed { magnitude_mps, rate } => {
                    if self.rng.random_bool(rate.clamp(0.0, 1.0)) {
                        o.speed_mps = (o.speed_mps + magnitude_mps).abs();
                        out.push(record([0.0, 0.0], magnitude_mps));
                    }
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use pmon_monitor::ObjectClass;

    fn obj(id: u64, x: f32, y: f32) -> ObjectState {
        ObjectState {
            id,
            class: ObjectClass::Pedestrian,
            x_m: x,
            y_m: y,
            heading_rad: 0.0,
            speed_mps: 1.0,
            length_m: 0.5,
            width_m: 0.5,
            uncertainty: None,
        }
    }

    #[test]
    fn permanent_away_offsets_increase_distance_on_the_faulty_half() {
        let cfg = InjectionConfig::new(Fault::PermanentPosition { magnitude_m: 1.0, direction: Direction::Away }, 3);
        let mut inj = Injector::new(cfg);
        let mut objs: Vec<_> = (0..200).map(|i| obj(i, 5.0 + i as f32 * 0.1, -3.0)).collect();
        let before = objs.clone();
        let rec = inj.apply(0, &mut objs);
        assert!(rec.len() > 70 && rec.len() < 130, "about half the tracks: {}", rec.len());
        for r in &rec {
            let (a, b) = (&before[r.index as usize], &objs[r.index as usize]);
            let d = b.x_m.hypot(b.y_m) - a.x_m.hypot(a.y_m);
            assert!((d - 1.0).abs() < 1e-3, "{d}");
        }
        // Same tracks next frame, same seed -> same records.
        let mut again = before.clone();
        let rec2 = Injector::new(cfg).apply(0, &mut again);
        assert_eq!(rec, rec2);
    }

    /// A street of 40 tracks over 30 frames: walkers on a grid of 4 m, drifting at different speeds.
    fn street() -> Vec<Vec<ObjectState>> {
        (0..30)
            .map(|k| {
                (0..40u64)
                    // Track i appears in frames i % 7 to 29 - i % 5.
                    .filter(|&i| k >= (i % 7) as usize && k <= 29 - (i % 5) as usize)
                    .map(|i| {
                        let t = k as f32 * 0.1;
                        obj(100 + i, 4.0 * (i % 10) as f32 + t * (i % 3) as f32, 4.0 * (i / 10) as f32 - t)
                    })
                    .collect()
            })
            .collect()
    }

    #[test]
    fn isolated_tracks_never_meet_and_their_sets_are_disjoint() {
        let frames = street();
        let near = |a: u64, b: u64| {
            frames.iter().any(|f| {
                let (p, q) = (f.iter().find(|o| o.id == a), f.iter().find(|o| o.id == b));
                p.zip(q).is_some_and(|(p, q)| (p.x_m - q.x_m).hypot(p.y_m - q.y_m) <= 9.0)
            })
        };
        let mut seen = std::collections::BTreeSet::new();
        let mut sets = 0;
        for set in 0..40 {
            let tracks = isolated_tracks(9.0, set, frames.iter().map(Vec::as_slice));
            if tracks.is_empty() {
                break;
            }
            sets += 1;
            // No two tracks of a set ever within 9 m; no track in two sets; the same set again on a second call.
            for &a in &tracks {
                for &b in &tracks {
                    assert!(a == b || !near(a, b), "set {set}: {a} and {b} meet");
                }
                assert!(seen.insert(a), "track {a} in two sets");
            }
            assert_eq!(tracks, isolated_tracks(9.0, set, frames.iter().map(Vec::as_slice)));
            // Greedy: every track left out of a set meets one of the set (or an earlier set has it).
            for id in 100..140u64 {
                assert!(
                    tracks.contains(&id)
                        || tracks.iter().any(|&t| near(id, t))
                        || (0..set).any(|s| isolated_tracks(9.0, s, frames.iter().map(Vec::as_slice)).contains(&id)),
                    "set {set}: track {id} could have joined"
                );
            }
        }
        // Every track carries the error in exactly one set, and it took several sets (the street is crowded).
        assert_eq!(seen.len(), 40);
        assert!(sets > 2, "{sets} sets");
        // A set number far beyond the last (a task file's) is empty, and answered at once.
        assert!(isolated_tracks(9.0, u32::MAX, frames.iter().map(Vec::as_slice)).is_empty());
    }

    #[test]
    fn an_isolated_injector_displaces_exactly_its_set() {
        let frames = street();
        let fault = Fault::PermanentPosition { magnitude_m: 1.0, direction: Direction::Away };
        let cfg = InjectionConfig { isolation_m: 9.0, isolation_set: 1, ..InjectionConfig::new(fault, 5) };
        let expected = isolated_tracks(9.0, 1, frames.iter().map(Vec::as_slice));
        let mut inj = Injector::for_scene(cfg, frames.iter().map(Vec::as_slice));
        let mut displaced = std::collections::BTreeSet::new();
        for (k, f) in frames.iter().enumerate() {
            let mut objs = f.clone();
            displaced.extend(inj.apply(k as u64, &mut objs).iter().map(|r| r.id));
        }
        assert_eq!(displaced, expected);
        // Without the isolation the same config displaces about half the tracks, by draw.
        let by_draw = Injector::new(InjectionConfig { isolation_m: 0.0, ..cfg });
        assert!((100..140).filter(|&id| by_draw.track_is_faulty(id)).count() > 10);
        // At its default the key is not written (run identities of the runs without it unchanged), and it reads
        // back.
        let json = serde_json::to_string(&InjectionConfig { isolation_m: 0.0, isolation_set: 0, ..cfg }).unwrap();
        assert!(!json.contains("isolation"), "{json}");
        let back: InjectionConfig = serde_json::from_str(&serde_json::to_string(&cfg).unwrap()).unwrap();
        assert_eq!(back, cfg);
    }

    #[test]
    fn random_rate_is_respected_and_towards_reduces_distance() {
        let cfg = InjectionConfig::new(
            Fault::RandomPosition { magnitude_m: 0.5, rate: 0.2, direction: Direction::Towards },
            11,
        );
        let mut inj = Injector::new(cfg);
        let mut n = 0;
        for f in 0..50 {
            let mut objs: Vec<_> = (0..100).map(|i| obj(i, 10.0, i as f32 * 0.1)).collect();
            let before = objs.clone();
            for r in inj.apply(f, &mut objs) {
                n += 1;
                let (a, b) = (&before[r.index as usize], &objs[r.index as usize]);
                assert!(b.x_m.hypot(b.y_m) < a.x_m.hypot(a.y_m));
            }
        }
        let rate = n as f64 / 5000.0;
        assert!((rate - 0.2).abs() < 0.03, "{rate}");
    }

    #[test]
    fn correlated_noise_has_the_right_spread_and_small_steps() {
        let mut cfg = InjectionConfig::new(Fault::None, 5);
        cfg.position_noise_m = 0.3;
        cfg.noise_correlation_s = 1.0;
        let mut inj = Injector::new(cfg);
        let (mut sum2, mut step2, mut n) = (0.0f64, 0.0f64, 0.0f64);
        let mut last: Vec<f32> = vec![0.0; 50];
        for k in 0..2000u64 {
            let mut objs: Vec<_> = (0..50).map(|i| obj(i, 10.0, 0.0)).collect();
            inj.apply_at(k, k as f64 * 0.1, &mut objs);
            for (i, o) in objs.iter().enumerate() {
                let e = o.x_m - 10.0;
                if k > 50 {
                    sum2 += f64::from(e * e);
                    step2 += f64::from((e - last[i]) * (e - last[i]));
                    n += 1.0;
                }
                last[i] = e;
            }
        }
        let sd = (sum2 / n).sqrt();
        let step = (step2 / n).sqrt();
        // Stationary spread 0.3 m; frame-to-frame steps sigma sqrt(2 (1 - exp(-0.1))) = 0.131 m.
        assert!((sd - 0.3).abs() < 0.03, "{sd}");
        assert!((step - 0.131).abs() < 0.01, "{step}");
    }

    #[test]
    fn speed_errors_keep_direction_and_magnitude() {
        let cfg = InjectionConfig::new(Fault::TransientSpeed { magnitude_mps: -3.0, rate: 1.0 }, 1);
        let mut objs = vec![obj(1, 10.0, 0.0)];
        let rec = Injector::new(cfg).apply(0, &mut objs);
        assert_eq!(rec.len(), 1);
        assert!((objs[0].speed_mps - 2.0).abs() < 1e-6, "|1 - 3| = 2");
        assert!(objs[0].heading_rad.abs() < 1e-9);
    }
}
