//! A track's history for the calibrated rule: the remembered states ([`Entry`]), their fixed-capacity ring
//! buffer ([`History`]), and the per-step scatter kept beside them: the studentised speed and heading steps,
//! the one-frame position residual ([`one_frame_d2`]) and the robust speed steps kept in order.

use super::stats::{rms, robust_rank};
use super::{
    add_velocity_cov, mahalanobis2, norm, refit_allowance, shrink, wrap_difference, CalibratedCheck, HISTORY,
    OWN_HEADING_MIN_SPEED_MPS, OWN_SCATTER_MIN_INCREMENTS, SPEED_STEPS,
};

/// One remembered state, world frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Entry {
    /// Timestamp, seconds.
    pub t_s: f64,
    /// Position, metres.
    pub x_m: f64,
    /// Position, metres.
    pub y_m: f64,
    /// Reported speed, m/s.
    pub v_mps: f32,
    /// Reported heading, radians.
    pub heading_rad: f32,
    /// Position sigma along x, metres.
    pub sx_m: f32,
    /// Position sigma along y, metres.
    pub sy_m: f32,
    /// Speed sigma, m/s.
    pub sv_mps: f32,
    /// Heading sigma of a moving object, radians.
    pub sh_rad: f32,
    /// Box length, metres.
    pub length_m: f32,
    /// Box width, metres.
    pub width_m: f32,
    /// The speed is not yet initialised (0 in the track's warm-up).
    pub warmup: bool,
    /// This state raised an alarm (not used as a reference while alarm-free states remain).
    pub suspect: bool,
    /// This state's heading was called flipped (its velocity is left out of the baseline).
    pub flipped: bool,
    /// `(cos, sin)` of `heading_rad`, set by [`History::push`] (computed once per state, not once per use).
    pub unit: [f32; 2],
}

impl Entry {
    /// Every field zero or false (the same as `Entry::default()`, as a constant).
    pub const ZERO: Self = Self {
        t_s: 0.0,
        x_m: 0.0,
        y_m: 0.0,
        v_mps: 0.0,
        heading_rad: 0.0,
        sx_m: 0.0,
        sy_m: 0.0,
        sv_mps: 0.0,
        sh_rad: 0.0,
        length_m: 0.0,
        width_m: 0.0,
        warmup: false,
        suspect: false,
        flipped: false,
        unit: [0.0; 2],
    };

    pub(super) fn heading_sigma(&self) -> f64 {
        let v = f64::from(self.v_mps).max(0.05);
        (f64::from(self.sh_rad) + f64::from(self.sv_mps) / v).min(core::f64::consts::PI)
    }
}

/// A fixed-capacity ring buffer of a track's states, oldest first.
#[derive(Clone, Copy, Debug, Default)]
pub struct History {
    pub(super) items: [Entry; HISTORY],
    /// Per state (same slots as `items`): the speed change from the previous state over its declared sigma
    /// `hypot(sigma_v0, sigma_v1)`, squared, and the same for the heading change (only where the heading is
    /// defined at both states: both speeds `>= OWN_HEADING_MIN_SPEED_MPS`); negative when either state is not
    /// clean (an alarm, a warm-up) or has no kept predecessor.
    steps: [(f32, f32); HISTORY],
    /// Per state: half the Mahalanobis distance squared of its one-frame position residual (see
    /// [`one_frame_d2`]) under the declared covariance; negative like `steps`.
    pos_steps: [f32; HISTORY],
    /// The last [`SPEED_STEPS`] speed steps' studentised squares as in `steps`, kept whatever the alarms (not
    /// kept when either state is in its warm-up), oldest at `speed_start`: the robust own scatter
    /// ([`History::robust_speed_scale`]) takes an order statistic of these, which the track's errors (missed or
    /// caught) do not move. (Longer than the states' ring: a median of 23 steps is nearly as tight as the mean of
    /// squares of 11.)
    pub(super) speed_ring: [f32; SPEED_STEPS],
    /// The same `speed_len` steps in ascending order ([`f32::total_cmp`]; the steps are finite or `+inf`, never
    /// NaN), kept beside the ring by each push (one removal and one insertion), so that
    /// [`History::robust_speed_scale`] reads its order statistic instead of selecting it. Kept as their
    /// [`order_key`]s (a bijection of the bits whose integer order is `total_cmp`'s order, its own inverse), so
    /// that the searches compare integers.
    speed_sorted: [i32; SPEED_STEPS],
    speed_start: u8,
    pub(super) speed_len: u8,
    pub(super) start: u8,
    len: u8,
    /// Sum and count of the kept states' clean speed steps (the oldest state's step is not kept).
    speed_sum: f64,
    speed_n: u8,
    /// The same for the heading steps.
    heading_sum: f64,
    heading_n: u8,
    /// The same for the position steps.
    pos_sum: f64,
    pos_n: u8,
}

/// `j % cap` for the ring positions here (`j` = a start below `cap` plus an offset of at most `cap`: below
/// `2 cap`), without a division; any larger `j` (none) is reduced by the division.
pub(super) const fn ring_index(j: usize, cap: usize) -> usize {
    if j < cap {
        j
    } else if j < 2 * cap {
        j - cap
    } else {
        j % cap
    }
}

/// An integer whose order is [`f32::total_cmp`]'s order of `x` (the same map `total_cmp` makes).
fn order_key(x: f32) -> i32 {
    let b = x.to_bits() as i32;
    b ^ (((b >> 31) as u32) >> 1) as i32
}

/// The bits of the `f32` whose [`order_key`] is `k` (the map keeps the sign bit and flips the other bits of a
/// negative number, so it is its own inverse).
fn order_key_inverse(k: i32) -> u32 {
    (k ^ (((k >> 31) as u32) >> 1) as i32) as u32
}

/// Both states are clean: neither raised an alarm nor is in its warm-up.
pub(super) fn clean_pair(p: &Entry, e: &Entry) -> bool {
    clean_unless_alarm(p, e) && !e.suspect
}

/// [`clean_pair`] for a new state `e` whose own alarm is not decided yet (taken to raise none): `p` raised no alarm,
/// and neither is in its warm-up.
pub(super) fn clean_unless_alarm(p: &Entry, e: &Entry) -> bool {
    !p.suspect && !p.warmup && !e.warmup
}

/// The one-frame position residual of `e` from `p` (the box's motion minus the trapezoid of the two reported
/// velocities, re-fits allowed for as in the baseline test) as its Mahalanobis distance squared under the
/// declared covariance (both positions, both velocities weighted by `dt / 2`). Uses both states'
/// [`Entry::unit`].
#[must_use]
pub fn one_frame_d2(p: &Entry, e: &Entry) -> f64 {
    one_frame_residual(p, e).1
}

/// [`one_frame_d2`] with the residual itself (after the re-fit allowance).
pub(super) fn one_frame_residual(p: &Entry, e: &Entry) -> ([f64; 2], f64) {
    let half = 0.5 * (e.t_s - p.t_s);
    let (v0, v1) = (f64::from(p.v_mps), f64::from(e.v_mps));
    let (c0, s0) = (f64::from(p.unit[0]), f64::from(p.unit[1]));
    let (c1, s1) = (f64::from(e.unit[0]), f64::from(e.unit[1]));
    let raw = [e.x_m - p.x_m - half * (v0 * c0 + v1 * c1), e.y_m - p.y_m - half * (v0 * s0 + v1 * s1)];
    let (dl, dw) = (f64::from(e.length_m - p.length_m), f64::from(e.width_m - p.width_m));
    let r = if p.v_mps.min(e.v_mps) >= OWN_HEADING_MIN_SPEED_MPS {
        refit_allowance(raw, (s1, c1), dl, dw)
    } else {
        // Where the heading is not defined, neither is the box's axis: the re-fit may have moved the reference
        // point in any direction, by up to half the larger size change.
        let n = norm(raw[0], raw[1]);
        let k = if n > 0.0 { shrink(n, 0.5 * dl.abs().max(dw.abs())) / n } else { 0.0 };
        [k * raw[0], k * raw[1]]
    };
    let sq = |x: f32| f64::from(x) * f64::from(x);
    let mut cov = [sq(p.sx_m) + sq(e.sx_m), 0.0, sq(p.sy_m) + sq(e.sy_m)];
    let (sv0, sv1) = (f64::from(p.sv_mps), f64::from(e.sv_mps));
    add_velocity_cov(&mut cov, half, (s0, c0), sv0, v0 * f64::from(p.sh_rad) + sv0);
    add_velocity_cov(&mut cov, half, (s1, c1), sv1, v1 * f64::from(e.sh_rad) + sv1);
    (r, mahalanobis2(r, cov))
}

/// The position step of `e` from `prev` kept in the history: half of [`one_frame_d2`] between clean states, else
/// negative.
pub(super) fn position_step(prev: Option<&Entry>, e: &Entry) -> f32 {
    match prev.filter(|p| clean_pair(p, e)) {
        Some(p) => {
            let q = 0.5 * one_frame_d2(p, e);
            if q.is_finite() {
                q as f32
            } else {
                -1.0
            }
        }
        None => -1.0,
    }
}

/// The studentised square of the speed step of `e` from `prev` whatever their alarms (see `History::speed_ring`).
pub(super) fn speed_step_any(prev: Option<&Entry>, e: &Entry) -> f32 {
    let Some(p) = prev.filter(|p| !p.warmup && !e.warmup) else { return -1.0 };
    let var_v = f64::from(p.sv_mps) * f64::from(p.sv_mps) + f64::from(e.sv_mps) * f64::from(e.sv_mps);
    let dv = f64::from(e.v_mps) - f64::from(p.v_mps);
    let q = dv * dv / var_v;
    if var_v > 0.0 && q.is_finite() {
        q as f32
    } else {
        -1.0
    }
}

/// The studentised steps of `e` from `prev` (see `History::steps`).
#[cfg(test)]
pub(super) fn steps_from(prev: Option<&Entry>, e: &Entry) -> (f32, f32) {
    steps_from_any(prev, e, speed_step_any(prev, e))
}

/// [`steps_from`] with `any = speed_step_any(prev, e)` given: between clean states the speed step is the same
/// number (the same square over the same variance) where it is finite as an `f32`, so it is not divided out twice.
pub(super) fn steps_from_any(prev: Option<&Entry>, e: &Entry, any: f32) -> (f32, f32) {
    let Some(p) = prev.filter(|p| clean_pair(p, e)) else { return (-1.0, -1.0) };
    let speed = if any >= 0.0 { any } else { -1.0 };
    let heading = if p.v_mps.min(e.v_mps) >= OWN_HEADING_MIN_SPEED_MPS {
        let (a, b) = (p.heading_sigma(), e.heading_sigma());
        let var_h = a * a + b * b;
        let dh = wrap_difference(f64::from(e.heading_rad) - f64::from(p.heading_rad));
        if var_h > 0.0 {
            (dh * dh / var_h) as f32
        } else {
            -1.0
        }
    } else {
        -1.0
    };
    (if speed.is_finite() { speed } else { -1.0 }, if heading.is_finite() { heading } else { -1.0 })
}

impl History {
    /// A history without states (the same as `History::default()`, as a constant).
    pub const EMPTY: Self = Self {
        items: [Entry::ZERO; HISTORY],
        steps: [(0.0, 0.0); HISTORY],
        pos_steps: [0.0; HISTORY],
        speed_ring: [0.0; SPEED_STEPS],
        speed_sorted: [0; SPEED_STEPS],
        speed_start: 0,
        speed_len: 0,
        start: 0,
        len: 0,
        speed_sum: 0.0,
        speed_n: 0,
        heading_sum: 0.0,
        heading_n: 0,
        pos_sum: 0.0,
        pos_n: 0,
    };

    /// Number of states.
    #[must_use]
    pub fn len(&self) -> usize {
        usize::from(self.len)
    }

    /// True when empty.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The `i`-th state, oldest first.
    #[must_use]
    pub fn get(&self, i: usize) -> Option<&Entry> {
        if i >= self.len() {
            return None;
        }
        self.items.get(ring_index(usize::from(self.start) + i, HISTORY))
    }

    /// The newest state.
    #[must_use]
    pub fn last(&self) -> Option<&Entry> {
        self.len().checked_sub(1).and_then(|i| self.get(i))
    }

    /// Appends a state (setting its [`Entry::unit`] and steps), dropping the oldest when full.
    pub fn push(&mut self, mut e: Entry) {
        let (s, c) = libm::sincos(f64::from(e.heading_rad));
        e.unit = [c as f32, s as f32];
        self.push_with_unit(e);
    }

    /// [`History::push`] of a state whose [`Entry::unit`] the caller set (to `libm::sincos` of its heading, as
    /// `push` would: the plausibility checks compute it once per state).
    pub(crate) fn push_with_unit(&mut self, e: Entry) {
        let prev = self.last();
        let pos = position_step(prev, &e);
        let any = speed_step_any(prev, &e);
        let step = steps_from_any(prev, &e, any);
        self.push_steps(e, pos, any, step);
    }

    /// [`History::push_with_unit`] with every step of `e` from the newest state given by the check of `e`
    /// against this history: [`CalibratedCheck::position_step`], [`CalibratedCheck::speed_step`] and
    /// [`CalibratedCheck::steps_if_no_alarm`] (the same numbers as the push would compute; a state that raised
    /// an alarm, `e.suspect`, keeps no position step and no clean steps).
    pub(crate) fn push_checked(&mut self, e: Entry, c: &CalibratedCheck) {
        let (pos, step) = if e.suspect { (-1.0, (-1.0, -1.0)) } else { (c.position_step, c.steps_if_no_alarm) };
        self.push_steps(e, pos, c.speed_step, step);
    }

    /// Stores `e` with its steps from the newest state (computed by the callers from one look-up of it): the
    /// position step `pos`, the speed step `any` ([`speed_step_any`]) and the clean steps `step`
    /// ([`steps_from_any`]).
    fn push_steps(&mut self, e: Entry, pos: f32, any: f32, step: (f32, f32)) {
        self.add_steps(step, 1.0);
        self.add_position_step(pos, 1.0);
        if self.len() >= HISTORY {
            // The oldest state leaves, and with it the step of the state after it.
            let next = ring_index(usize::from(self.start) + 1, HISTORY);
            if let Some(&old) = self.steps.get(next) {
                self.add_steps(old, -1.0);
            }
            if let Some(slot) = self.steps.get_mut(next) {
                *slot = (-1.0, -1.0);
            }
            if let Some(&old) = self.pos_steps.get(next) {
                self.add_position_step(old, -1.0);
            }
            if let Some(slot) = self.pos_steps.get_mut(next) {
                *slot = -1.0;
            }
        }
        let idx = if self.len() < HISTORY {
            let idx = ring_index(usize::from(self.start) + self.len(), HISTORY);
            self.len += 1;
            idx
        } else {
            let idx = usize::from(self.start);
            self.start = ring_index(usize::from(self.start) + 1, HISTORY) as u8;
            idx
        };
        if let Some(slot) = self.items.get_mut(idx) {
            *slot = e;
        }
        if let Some(slot) = self.steps.get_mut(idx) {
            *slot = step;
        }
        if let Some(slot) = self.pos_steps.get_mut(idx) {
            *slot = pos;
        }
        if any >= 0.0 {
            self.push_speed_step(any);
        }
    }

    /// Appends a speed step to the ring (dropping the oldest when full) and keeps `speed_sorted` in order: one copy
    /// of the oldest step's key leaves it (equal keys are equal bits, so which copy does not matter) at its first
    /// place `i` (at the end, `i = len`, while the ring is not full), the new key goes to the place `j` of the first
    /// key not below it, and the keys between the two places move by one towards `i` (one `copy_within`).
    pub(super) fn push_speed_step(&mut self, any: f32) {
        let len = usize::from(self.speed_len).min(SPEED_STEPS);
        let at = ring_index(usize::from(self.speed_start) + len, SPEED_STEPS);
        let key = order_key(any);
        let sorted = &mut self.speed_sorted;
        let old = self.speed_ring.get(at).map_or(0, |&x| order_key(x));
        if let Some(slot) = self.speed_ring.get_mut(at) {
            *slot = any;
        }
        if len == SPEED_STEPS && old == key {
            // The step that leaves has the new one's bits: the order stays as it is.
            self.speed_start = ring_index(usize::from(self.speed_start) + 1, SPEED_STEPS) as u8;
            return;
        }
        let (i, filled) = if len == SPEED_STEPS {
            // The first sorted key not below the oldest one: a copy of it.
            (sorted.partition_point(|&k| k < old).min(len - 1), len)
        } else {
            (len, len + 1)
        };
        // The new key's place among the others (the key at `i` left out): before the first key not below it.
        let j = sorted.get(..len).map_or(0, |keys| keys.partition_point(|&k| k < key));
        let j = if j > i {
            // After the leaving key: the keys in (i, j) move down by one, and the new key goes just before the
            // first key not below it.
            if let Some(keys) = sorted.get_mut(..filled) {
                if i < j && j <= keys.len() {
                    keys.copy_within(i + 1..j, i);
                }
            }
            j - 1
        } else {
            // At or before it: the keys in [j, i) move up by one.
            if let Some(keys) = sorted.get_mut(..filled) {
                if j <= i && i < keys.len() {
                    keys.copy_within(j..i, j + 1);
                }
            }
            j
        };
        if let Some(slot) = sorted.get_mut(j) {
            *slot = key;
        }
        if len < SPEED_STEPS {
            self.speed_len += 1;
        } else {
            self.speed_start = ring_index(usize::from(self.speed_start) + 1, SPEED_STEPS) as u8;
        }
    }

    /// The `k`-th smallest kept speed step (0-based), as kept in `speed_sorted`.
    pub(super) fn sorted_speed_step(&self, k: usize) -> Option<f32> {
        self.speed_sorted.get(k).map(|&key| f32::from_bits(order_key_inverse(key)))
    }

    /// The robust own scatter of the speed: of the `m` kept speed steps (the last [`SPEED_STEPS`] steps between
    /// states outside a warm-up, alarms or not), the absolute studentised step of rank [`robust_rank`]`(m)` from
    /// the smallest (about the median), and `m`. A transient speed error adds two large steps (into it and out of it), which
    /// move a mean of squares (and, once missed, widen the margin for the next error) but not this order
    /// statistic while fewer than half of the steps are errors.
    #[must_use]
    pub fn robust_speed_scale(&self) -> (f64, u8) {
        let m = usize::from(self.speed_len);
        if m < usize::from(OWN_SCATTER_MIN_INCREMENTS) {
            return (0.0, m as u8);
        }
        // (Read off the steps kept in order: the same value as selecting it in the ring, see
        // `sorted_steps_give_the_ring_s_order_statistic`.)
        let Some(q) = self.sorted_speed_step(robust_rank(m as u8).saturating_sub(1)) else { return (0.0, 0) };
        (libm::sqrt(f64::from(q)), m as u8)
    }

    fn add_position_step(&mut self, q: f32, sign: f64) {
        if q >= 0.0 {
            self.pos_sum = (self.pos_sum + sign * f64::from(q)).max(0.0);
            self.pos_n = if sign > 0.0 { self.pos_n.saturating_add(1) } else { self.pos_n.saturating_sub(1) };
        }
    }

    /// The track's own one-frame position scatter over its declared one: the mean of the kept clean position
    /// steps (half the Mahalanobis distance squared of each one-frame residual, 1 for honest declared sigmas),
    /// and their number.
    #[must_use]
    pub fn own_position_scatter(&self) -> (f64, u8) {
        (if self.pos_n == 0 { 0.0 } else { self.pos_sum / f64::from(self.pos_n) }, self.pos_n)
    }

    fn add_steps(&mut self, (speed, heading): (f32, f32), sign: f64) {
        if speed >= 0.0 {
            self.speed_sum = (self.speed_sum + sign * f64::from(speed)).max(0.0);
            self.speed_n = if sign > 0.0 { self.speed_n.saturating_add(1) } else { self.speed_n.saturating_sub(1) };
        }
        if heading >= 0.0 {
            self.heading_sum = (self.heading_sum + sign * f64::from(heading)).max(0.0);
            self.heading_n =
                if sign > 0.0 { self.heading_n.saturating_add(1) } else { self.heading_n.saturating_sub(1) };
        }
    }

    /// The track's own scatter over its declared sigma (root mean square of the kept clean studentised steps)
    /// and the number of steps, for the speed and for the heading.
    #[must_use]
    pub fn own_scatter(&self) -> ((f64, u8), (f64, u8)) {
        (self.own_speed_scatter(), self.own_heading_scatter())
    }

    /// The speed half of [`History::own_scatter`].
    pub(super) fn own_speed_scatter(&self) -> (f64, u8) {
        (rms(self.speed_sum, self.speed_n), self.speed_n)
    }

    /// The heading half of [`History::own_scatter`].
    pub(super) fn own_heading_scatter(&self) -> (f64, u8) {
        (rms(self.heading_sum, self.heading_n), self.heading_n)
    }

    /// A history holding only `e`.
    #[must_use]
    pub fn with(e: Entry) -> Self {
        let mut h = Self::default();
        h.push(e);
        h
    }
}
