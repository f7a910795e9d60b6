//! The distributions behind the calibrated rule's gates (Student's t, the half-normal, the order statistic of
//! the robust own scatter) and the [`Gates`] of a false-alarm probability.

use super::{HISTORY, OWN_POSITION_FLOOR, OWN_SCATTER_FLOOR, OWN_SCATTER_MIN_INCREMENTS, SPEED_STEPS};

/// The root mean square of `n` studentised steps summing to `sum` (0 without steps).
pub(super) fn rms(sum: f64, n: u8) -> f64 {
    if n == 0 {
        0.0
    } else {
        libm::sqrt(sum / f64::from(n))
    }
}

/// `P(|T| <= t)` for Student's t with `nu >= 1` degrees of freedom (Abramowitz and Stegun 26.7.3, 26.7.4: exact
/// finite sums for integer `nu`).
fn t_abs_cdf(t: f64, nu: u32) -> f64 {
    use core::f64::consts::PI;
    let th = libm::atan(t / libm::sqrt(f64::from(nu)));
    let (s, c) = libm::sincos(th);
    let c2 = c * c;
    let mut sum = 1.0;
    let mut term = 1.0;
    if nu.is_multiple_of(2) {
        for k in 1..nu / 2 {
            term *= f64::from(2 * k - 1) / f64::from(2 * k) * c2;
            sum += term;
        }
        s * sum
    } else if nu == 1 {
        2.0 * th / PI
    } else {
        for k in 1..(nu - 1) / 2 {
            term *= f64::from(2 * k) / f64::from(2 * k + 1) * c2;
            sum += term;
        }
        2.0 / PI * (th + s * c * sum)
    }
}

/// The two-sided quantile `t` with `P(|T| > t) = p` of Student's t with `nu` degrees of freedom (bisection on
/// [`t_abs_cdf`], in the logarithm of `t`).
pub(super) fn t_quantile(p: f64, nu: u32) -> f64 {
    let (mut lo, mut hi) = (libm::log(1e-3), libm::log(1e12));
    for _ in 0..80 {
        let mid = 0.5 * (lo + hi);
        if 1.0 - t_abs_cdf(libm::exp(mid), nu.max(1)) > p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    libm::exp(0.5 * (lo + hi))
}

/// The rank (from the smallest, 1-based) of the order statistic of `m` absolute speed steps that
/// [`History::robust_speed_scale`](super::History::robust_speed_scale) takes: `(m + 1) / 2`, the median (the lower
/// one for even `m`).
#[must_use]
pub const fn robust_rank(m: u8) -> usize {
    (m as usize).div_ceil(2)
}

/// The half-normal distribution function `P(|N| <= q)`.
fn half_normal_cdf(q: f64) -> f64 {
    libm::erf(q * core::f64::consts::FRAC_1_SQRT_2)
}

/// The robust own-scatter test's quantile: `c` with `P(|X| > c Q) = p`, `X` and the `m` steps independent
/// `N(0, s^2)`, `Q` the `k`-th smallest of the `m` absolute steps ([`robust_rank`]), whatever `s`. `P(|X| > c Q)` is
/// the integral of `erfc(c q / sqrt 2)` against the density of `Q`,
/// `m! / ((k - 1)! (m - k)!) F(q)^(k - 1) (1 - F(q))^(m - k) f(q)` (`F`, `f` the half-normal's), by the midpoint
/// rule on `q = 6 u^2` (64 points, dense near 0 where the tail is decided; within 1e-3 of a 2000-point uniform
/// rule at `p` = 1e-4 and 0.01), and `c` by bisection in its logarithm.
fn order_statistic_quantile(p: f64, m: u8, k: usize) -> f64 {
    const N: usize = 64;
    const Q_MAX: f64 = 6.0;
    let (m, k) = (usize::from(m), k.max(1));
    if k > m {
        return f64::INFINITY;
    }
    // log of m! / ((k - 1)! (m - k)!)
    let ln_fact = |n: usize| (1..=n).map(|i| libm::log(i as f64)).sum::<f64>();
    let ln_coef = ln_fact(m) - ln_fact(k - 1) - ln_fact(m - k);
    let mut q = [0.0f64; N];
    let mut w = [0.0f64; N];
    for (i, (qi, wi)) in q.iter_mut().zip(w.iter_mut()).enumerate() {
        let u = (i as f64 + 0.5) / N as f64;
        *qi = Q_MAX * u * u;
        let dq = 2.0 * Q_MAX * u / N as f64;
        let f = half_normal_cdf(*qi);
        let density =
            core::f64::consts::FRAC_2_SQRT_PI * core::f64::consts::FRAC_1_SQRT_2 * libm::exp(-0.5 * *qi * *qi);
        let ln_rest = (k as f64 - 1.0) * libm::log(f.max(1e-300)) + (m - k) as f64 * libm::log((1.0 - f).max(1e-300));
        *wi = libm::exp(ln_coef + ln_rest) * density * dq;
    }
    let tail = |c: f64| -> f64 {
        q.iter().zip(w.iter()).map(|(&qi, &wi)| wi * libm::erfc(c * qi * core::f64::consts::FRAC_1_SQRT_2)).sum()
    };
    let (mut lo, mut hi) = (0.0f64, libm::log(1e7));
    for _ in 0..40 {
        let mid = 0.5 * (lo + hi);
        if tail(libm::exp(mid)) > p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    libm::exp(0.5 * (lo + hi))
}

/// The half-normal quantile `q` with `P(|N| <= q) = u` (bisection).
fn half_normal_quantile(u: f64) -> f64 {
    let (mut lo, mut hi) = (0.0f64, 40.0f64);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if half_normal_cdf(mid) < u {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// Degrees of freedom of the own-scatter test with `n` kept steps: consecutive steps of white noise share a
/// state (correlation -1/2), so the mean of `n` squared steps is worth fewer than `n` independent ones; `n - 1`
/// is conservative (checked by `own_scatter_gate_keeps_its_false_alarm_probability`).
#[must_use]
pub fn own_dof(n: u8) -> u32 {
    u32::from(n).saturating_sub(1).max(1)
}

/// The gates of a false-alarm probability `p`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gates {
    /// Chi-square quantile with 2 degrees of freedom, `-2 ln p`.
    pub chi2_2: f64,
    /// Two-sided normal quantile `z` with `P(|N| > z) = p`.
    pub z: f64,
    /// `t[n]`: the two-sided Student-t quantile at `p` with [`own_dof`]`(n)` degrees of freedom, for a track's
    /// own scatter from `n` kept steps.
    pub t: [f64; HISTORY],
    /// `f[n]`: the upper `p` quantile of Fisher's F with 2 and `2 nu` degrees of freedom (`nu` = [`own_dof`]`(n)`),
    /// `nu (p^(-1/nu) - 1)`, for a one-frame position residual against the track's own scatter from `n` kept steps.
    pub f: [f64; HISTORY],
    /// `t_speed[n]`: as `t`, at `p / 2`: the speed step's own scatter is tested twice (the mean of squares of its
    /// clean steps and the robust order statistic of every step), each at `p / 2`, so that together they keep the
    /// `p` of the one test they replace.
    pub t_speed: [f64; HISTORY],
    /// `robust[m]`: the robust own-scatter test's quantile (`order_statistic_quantile`) at `p / 2` for `m` kept
    /// speed steps and the rank [`robust_rank`]`(m)`.
    pub robust: [f64; SPEED_STEPS + 1],
    /// `robust_floor[m]`: the smallest order statistic used, [`OWN_SCATTER_FLOOR`] times the half-normal's
    /// quantile at `k / (m + 1)` (about the statistic's typical value at unit scale): a track whose speeds never
    /// change is not taken to be noise-free, as for the mean of squares.
    pub robust_floor: [f64; SPEED_STEPS + 1],
}

impl Gates {
    /// Gates for `p` in (0, 0.5) (Abramowitz and Stegun 26.2.23 for `z`, error below 4.5e-4).
    #[must_use]
    pub fn new(p: f64) -> Self {
        let p = p.clamp(1e-300, 0.5);
        let q = 0.5 * p;
        let t = libm::sqrt(-2.0 * libm::log(q));
        let z = t
            - (2.515_517 + 0.802_853 * t + 0.010_328 * t * t)
                / (1.0 + 1.432_788 * t + 0.189_269 * t * t + 0.001_308 * t * t * t);
        let mut t = [f64::INFINITY; HISTORY];
        let mut t_speed = [f64::INFINITY; HISTORY];
        let mut f = [f64::INFINITY; HISTORY];
        let mut robust = [f64::INFINITY; SPEED_STEPS + 1];
        let mut robust_floor = [0.0; SPEED_STEPS + 1];
        for (m, (c, fl)) in
            robust.iter_mut().zip(robust_floor.iter_mut()).enumerate().skip(usize::from(OWN_SCATTER_MIN_INCREMENTS))
        {
            let k = robust_rank(m as u8);
            *c = order_statistic_quantile(0.5 * p, m as u8, k);
            *fl = OWN_SCATTER_FLOOR * half_normal_quantile(k as f64 / (m as f64 + 1.0));
        }
        for (n, ((q, qs), fq)) in t
            .iter_mut()
            .zip(t_speed.iter_mut())
            .zip(f.iter_mut())
            .enumerate()
            .skip(usize::from(OWN_SCATTER_MIN_INCREMENTS))
        {
            let nu = own_dof(n as u8);
            *q = t_quantile(p, nu);
            *qs = t_quantile(0.5 * p, nu);
            *fq = f64::from(nu) * (libm::pow(p, -1.0 / f64::from(nu)) - 1.0);
        }
        Self { chi2_2: -2.0 * libm::log(p), z, t, f, t_speed, robust, robust_floor }
    }

    /// The speed step's margin factor (times the declared sigma of the difference): the smallest of `z`, the
    /// mean-of-squares test's `t_speed[n] rms` (`n` clean steps, `rms` floored at [`OWN_SCATTER_FLOOR`]) and the
    /// robust test's `robust[m] q` ([`History::robust_speed_scale`](super::History::robust_speed_scale): the order
    /// statistic `q` of `m` steps, floored at `robust_floor[m]`); each own-scatter test only with at least
    /// [`OWN_SCATTER_MIN_INCREMENTS`] steps.
    #[must_use]
    pub fn speed_factor(&self, (rms, n): (f64, u8), (q, m): (f64, u8)) -> f64 {
        let mut f = self.z;
        if n >= OWN_SCATTER_MIN_INCREMENTS {
            let t = self.t_speed.get(usize::from(n)).copied().unwrap_or(f64::INFINITY);
            f = f.min(t * rms.max(OWN_SCATTER_FLOOR));
        }
        if m >= OWN_SCATTER_MIN_INCREMENTS {
            let c = self.robust.get(usize::from(m)).copied().unwrap_or(f64::INFINITY);
            let floor = self.robust_floor.get(usize::from(m)).copied().unwrap_or(0.0);
            f = f.min(c * q.max(floor));
        }
        f
    }

    /// The own-position gate on half the one-frame Mahalanobis distance squared: the F quantile times the
    /// track's own mean (floored at [`OWN_POSITION_FLOOR`] squared); infinite with fewer than
    /// [`OWN_SCATTER_MIN_INCREMENTS`] steps.
    #[must_use]
    pub fn position_gate(&self, (mean, n): (f64, u8)) -> f64 {
        if n < OWN_SCATTER_MIN_INCREMENTS {
            return f64::INFINITY;
        }
        let f = self.f.get(usize::from(n)).copied().unwrap_or(f64::INFINITY);
        f * mean.max(OWN_POSITION_FLOOR * OWN_POSITION_FLOOR)
    }

    /// The margin factor (times the declared sigma of the difference): the smaller of `z` and the own-scatter
    /// test's `t rms`, the latter only with at least [`OWN_SCATTER_MIN_INCREMENTS`] steps (`rms` floored at
    /// [`OWN_SCATTER_FLOOR`]).
    #[must_use]
    pub fn factor(&self, (rms, n): (f64, u8)) -> f64 {
        if n < OWN_SCATTER_MIN_INCREMENTS {
            return self.z;
        }
        let t = self.t.get(usize::from(n)).copied().unwrap_or(f64::INFINITY);
        self.z.min(t * rms.max(OWN_SCATTER_FLOOR))
    }
}
