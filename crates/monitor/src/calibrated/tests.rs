//! Tests of the calibrated rule, its history and its gates.

use super::history::{clean_pair, position_step, speed_step_any, steps_from, steps_from_any};
use super::stats::t_quantile;
use super::*;

fn e(t: f64, x: f64, v: f32) -> Entry {
    Entry {
        t_s: t,
        x_m: x,
        y_m: 0.0,
        v_mps: v,
        heading_rad: 0.0,
        sx_m: 0.1,
        sy_m: 0.1,
        sv_mps: 0.5,
        sh_rad: 0.1,
        length_m: 4.5,
        width_m: 1.8,
        warmup: false,
        suspect: false,
        flipped: false,
        unit: [1.0, 0.0],
    }
}

fn track(v: f32, frames: usize) -> History {
    let mut h = History::default();
    for k in 0..frames {
        h.push(e(k as f64 * 0.1, f64::from(v) * k as f64 * 0.1, v));
    }
    h
}

/// Uniform numbers in [0, 1) from a seeded 64-bit LCG (the tests' random tracks).
fn uniform(mut seed: u64) -> impl FnMut() -> f64 {
    move || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn run(h: &History, s1: &Entry) -> CalibratedCheck {
    check_calibrated(h, s1, &MotionLimits::default(), &Gates::new(1e-4), 1.0, 0.5)
}

#[test]
fn checked_steps_match_the_push_s_own() {
    // The steps a check hands to the push (`push_checked`) are the ones `push_with_unit` computes: random
    // tracks with warm-ups, alarms, zero sigmas, speeds about the heading threshold and several heading
    // thresholds of the check; two histories, one pushed each way, stay alike.
    let gates = Gates::new(1e-4);
    let mut rnd = uniform(0x9e37_79b9_7f4a_7c15u64);
    for track in 0..200 {
        let min_speed = [1.0, 0.5, 2.0][track % 3];
        let (mut by_check, mut by_push) = (History::default(), History::default());
        let mut t = 0.0;
        for k in 0..40 {
            t += 0.05 + 0.1 * rnd();
            let mut s1 = e(t, 10.0 * rnd(), (3.0 * rnd() - 0.2) as f32);
            if rnd() < 0.2 {
                s1.v_mps = [0.0, 1.0, 0.999_999_9][k % 3];
            }
            s1.heading_rad = (6.4 * rnd() - 3.2) as f32;
            s1.sv_mps = if rnd() < 0.1 { 0.0 } else { rnd() as f32 };
            s1.sh_rad = if rnd() < 0.1 { 0.0 } else { 0.3 * rnd() as f32 };
            s1.warmup = rnd() < 0.15;
            let (sn, cs) = libm::sincos(f64::from(s1.heading_rad));
            s1.unit = [cs as f32, sn as f32];
            let c = check_calibrated(&by_check, &s1, &MotionLimits::default(), &gates, min_speed, 0.5);
            let prev = by_check.last().copied();
            let any = speed_step_any(prev.as_ref(), &s1);
            assert_eq!(c.speed_step.to_bits(), any.to_bits());
            let (a, b) = steps_from_any(prev.as_ref(), &s1, any);
            assert_eq!((c.steps_if_no_alarm.0.to_bits(), c.steps_if_no_alarm.1.to_bits()), (a.to_bits(), b.to_bits()));
            s1.suspect = !c.fired.is_empty() || rnd() < 0.1;
            by_check.push_checked(s1, &c);
            by_push.push_with_unit(s1);
            let bits = |h: &History| {
                let ((sv, nv), (sh, nh)) = h.own_scatter();
                let (p, np) = h.own_position_scatter();
                let (r, nr) = h.robust_speed_scale();
                (sv.to_bits(), nv, sh.to_bits(), nh, p.to_bits(), np, r.to_bits(), nr)
            };
            assert_eq!(bits(&by_check), bits(&by_push));
        }
    }
}

#[test]
fn ordered_baseline_search_finds_the_scan_s_state() {
    // With the times in order (finite, strictly increasing, as the track table keeps them), the check that
    // skips the states before the baseline's window by a binary search gives what the scan gives, to the
    // last bit: random rates (also irregular, some steps much longer than the window), alarms, warm-ups and
    // flips, every history length, windows from 0 to longer than the ring, and new states right after the
    // newest one or long after it.
    let gates = Gates::new(1e-4);
    let mut rnd = uniform(0x2545_f491_4f6c_dd1du64);
    let mut checked = 0usize;
    for track in 0..120 {
        let rate = [0.1, 0.05, 0.033, 0.2, 0.5][track % 5];
        let mut h = History::default();
        let mut t = 1000.0 * rnd();
        for k in 0..30 {
            let mut s = e(t, 10.0 * rnd(), (5.0 * rnd()) as f32);
            s.heading_rad = (6.4 * rnd() - 3.2) as f32;
            s.suspect = rnd() < 0.2;
            s.warmup = rnd() < 0.1;
            s.flipped = s.suspect && rnd() < 0.5;
            let (sn, cs) = libm::sincos(f64::from(s.heading_rad));
            s.unit = [cs as f32, sn as f32];
            for baseline_s in [0.0, 0.1, 0.5, 0.5 + 1e-9, 1.0, 3.0] {
                for gap in [rate, 0.5 * rate, 2.0 * rate, 1.0, 1e-9] {
                    if h.is_empty() {
                        continue;
                    }
                    let mut s1 = s;
                    s1.t_s = h.last().map_or(0.0, |p| p.t_s) + gap;
                    let u1 = libm::sincos(f64::from(s1.heading_rad));
                    let l = MotionLimits::default();
                    let a = check_calibrated_sc(&h, &s1, u1, &l, &gates, 1.0, baseline_s, true);
                    let b = check_calibrated_sc(&h, &s1, u1, &l, &gates, 1.0, baseline_s, false);
                    assert_eq!(format!("{a:?}"), format!("{b:?}"), "track {track}, state {k}");
                    checked += 1;
                }
            }
            h.push(s);
            let step = if rnd() < 0.1 { 5.0 * rnd() + 1e-6 } else { rate * (0.5 + rnd()) };
            t += step;
        }
    }
    assert!(checked > 40_000);
}

#[test]
fn fast_helpers_match_the_careful_ones() {
    for k in -400..=400 {
        let a = f64::from(k) * 0.0157;
        assert!((wrap_difference(a) - wrap_angle(a)).abs() < 1e-12, "{a}");
        assert!((norm(a, 0.3 * a + 1.0) - libm::hypot(a, 0.3 * a + 1.0)).abs() < 1e-12);
    }
}

#[test]
fn gates_match_tables() {
    let g = Gates::new(1e-3);
    assert!((g.chi2_2 - 13.8155).abs() < 1e-3);
    assert!((g.z - 3.2905).abs() < 2e-3, "{}", g.z);
    let g = Gates::new(0.05);
    assert!((g.z - 1.96).abs() < 2e-3, "{}", g.z);
}

#[test]
fn ring_buffer_keeps_the_newest() {
    let h = track(1.0, HISTORY + 5);
    assert_eq!(h.len(), HISTORY);
    assert!((h.get(0).unwrap().t_s - 0.5).abs() < 1e-9);
    assert!((h.last().unwrap().t_s - (HISTORY + 4) as f64 * 0.1).abs() < 1e-9);
}

#[test]
fn steady_motion_is_plausible() {
    let h = track(10.0, 8);
    let c = run(&h, &e(0.8, 8.0, 10.0));
    assert!(c.fired.is_empty(), "{c:?}");
}

#[test]
fn permanent_speed_error_of_3_mps_shows_over_the_baseline() {
    // Reported 13 m/s, moving at 10 m/s: over 0.5 s the box is 1.5 m behind its reported motion.
    let mut h = History::default();
    for k in 0..8 {
        h.push(e(k as f64 * 0.1, k as f64, 13.0));
    }
    let c = run(&h, &e(0.8, 8.0, 13.0));
    assert!(c.fired.contains(Conditions::POSITION), "{c:?}");
    assert_eq!(c.kind, Some(ImplausibilityKind::SpeedInconsistent));
    assert!((c.error_size - 3.0).abs() < 0.3, "{}", c.error_size);
}

#[test]
fn a_jump_is_named_a_jump_and_a_flip_a_flip() {
    let h = track(10.0, 8);
    let c = run(&h, &e(0.8, 8.0, 10.0)); // baseline
    assert!(c.kind.is_none());
    let mut j = e(0.8, 8.0, 10.0);
    j.y_m = 2.0;
    let c = run(&h, &j);
    assert_eq!(c.kind, Some(ImplausibilityKind::PositionJump), "{c:?}");
    assert!((c.error_size - 2.0).abs() < 0.3);
    let mut f = e(0.8, 8.0, 10.0);
    f.heading_rad = 3.1;
    let c = run(&h, &f);
    assert_eq!(c.kind, Some(ImplausibilityKind::HeadingFlip), "{c:?}");
}

#[test]
fn heading_noise_at_standstill_and_refits_are_tolerated() {
    let h = track(0.05, 8);
    let mut s = e(0.8, 0.04, 0.05);
    s.heading_rad = 2.5;
    assert!(run(&h, &s).fired.is_empty());
    // Length grows by 1.6 m, the centre moves by 0.8 m along the box.
    let h = track(0.0, 8);
    let mut s = e(0.8, 0.8, 0.0);
    s.length_m = 6.1;
    assert!(run(&h, &s).fired.is_empty());
}

#[test]
fn warmup_hides_no_large_speed_error() {
    // A car reported at 0 m/s in its warm-up moved 2.7 m in 0.1 s: reported.
    let mut s0 = e(0.0, 0.0, 0.0);
    s0.warmup = true;
    s0.sv_mps = 0.7;
    let h = History::with(s0);
    let mut s1 = e(0.1, 2.7, 0.0);
    s1.warmup = true;
    s1.sv_mps = 0.7;
    let c = run(&h, &s1);
    assert_eq!(c.kind, Some(ImplausibilityKind::SpeedInconsistent), "{c:?}");
    assert!(c.severity >= 1.0);
    // A pedestrian at 1.4 m/s in its warm-up: tolerated.
    let mut s1 = e(0.1, 0.14, 0.0);
    s1.warmup = true;
    s1.sv_mps = 0.7;
    assert!(run(&h, &s1).fired.is_empty());
}

#[test]
fn the_end_of_a_warmup_tells_the_speed_the_tracker_hid() {
    // Reported 0 (warm-up) then 8 m/s, the box moving 0.8 m per frame: the warm-up hid 8 m/s.
    let mut s0 = e(0.0, 0.0, 0.0);
    s0.warmup = true;
    s0.sv_mps = 0.7;
    let h = History::with(s0);
    let c = run(&h, &e(0.1, 0.8, 8.0));
    assert!(c.fired.contains(Conditions::ACCELERATION), "{c:?}");
    assert_eq!(c.kind, Some(ImplausibilityKind::SpeedInconsistent), "{c:?}");
    assert!(c.error_size < -6.0 && c.severity > 2.0, "{c:?}");
    // A walking pedestrian (1.4 m/s) after its warm-up, or a car starting from standstill: tolerated.
    assert!(run(&h, &e(0.1, 0.14, 1.4)).fired.is_empty());
    assert!(run(&h, &e(0.1, 0.03, 0.7)).fired.is_empty());
}

#[test]
fn a_heading_that_stays_flipped_is_called_flipped_in_each_frame() {
    // A pedestrian at 2 m/s whose tracker flips the heading for three frames, then flips it back.
    let mut h = track(2.0, 6);
    let mut verdicts = [None; 4];
    for (k, v) in verdicts.iter_mut().enumerate() {
        let t = (6 + k) as f64 * 0.1;
        let mut s = e(t, 2.0 * t, 2.0);
        s.heading_rad = if k < 3 { 3.1 } else { 0.0 };
        let c = run(&h, &s);
        *v = c.kind;
        s.suspect = !c.fired.is_empty();
        s.flipped = c.kind == Some(ImplausibilityKind::HeadingFlip);
        h.push(s);
    }
    assert_eq!(verdicts, [Some(ImplausibilityKind::HeadingFlip); 4], "{verdicts:?}");
    // A steady heading after a real alarm-free history stays plausible (no flip without a flipped state).
    let h = track(2.0, 8);
    assert!(run(&h, &e(0.8, 1.6, 2.0)).fired.is_empty());
}

/// Checks `states` one after the other against `h` (pushing each with its verdict, as the track table does);
/// returns each state's kind.
fn run_sequence(h: &mut History, states: &[Entry]) -> alloc::vec::Vec<Option<ImplausibilityKind>> {
    states
        .iter()
        .map(|s| {
            let c = run(h, s);
            let mut s = *s;
            s.suspect = !c.fired.is_empty();
            s.flipped = c.kind == Some(ImplausibilityKind::HeadingFlip);
            h.push(s);
            c.kind
        })
        .collect()
}

#[test]
fn a_car_whose_heading_stays_flipped_is_still_a_flip_in_each_frame() {
    // A car at 10 m/s whose tracker reports the heading turned by pi for three frames while the box keeps
    // moving forwards: each flipped frame and the return are flips, also when the box is re-fitted during the
    // flip (length 4.5 -> 3.15 m with the front end fixed: the centre moves 0.68 m backwards, towards the
    // reported, flipped heading).
    use core::f64::consts::PI;
    for refit in [false, true] {
        let mut h = track(10.0, 8);
        let states: alloc::vec::Vec<Entry> = (0..4)
            .map(|k| {
                let t = (8 + k) as f64 * 0.1;
                let mut s = e(t, 10.0 * t, 10.0);
                if k < 3 {
                    s.heading_rad = PI as f32;
                    if refit {
                        s.length_m = 3.15;
                        s.x_m -= 0.675;
                    }
                }
                s
            })
            .collect();
        let kinds = run_sequence(&mut h, &states);
        assert_eq!(kinds, [Some(ImplausibilityKind::HeadingFlip); 4], "re-fit {refit}: {kinds:?}");
    }
}

#[test]
fn a_pedestrian_that_turns_around_is_not_a_flip_once_it_walks_back() {
    // A pedestrian at 1.2 m/s that turns around within one frame (a turn no physical limit admits, so the
    // first state after it is an alarm), then walks back along the new heading: the following states are not
    // flipped headings (the box moves along the new heading), at 10 and 20 Hz.
    use core::f64::consts::PI;
    for dt in [0.1, 0.05] {
        let mut h = History::default();
        for k in 0..8 {
            let t = k as f64 * dt;
            h.push(e(t, 1.2 * t, 1.2));
        }
        let x_turn = 1.2 * 7.0 * dt;
        let states: alloc::vec::Vec<Entry> = (1..=5)
            .map(|k| {
                let t = (7 + k) as f64 * dt;
                let mut s = e(t, x_turn - 1.2 * k as f64 * dt, 1.2);
                s.heading_rad = PI as f32;
                s
            })
            .collect();
        let kinds = run_sequence(&mut h, &states);
        assert_eq!(kinds[0], Some(ImplausibilityKind::HeadingFlip), "dt {dt}: {kinds:?}");
        assert!(kinds[1..].iter().all(Option::is_none), "dt {dt}: {kinds:?}");
    }
}

#[test]
fn t_quantiles_match_tables() {
    for (p, nu, want) in [
        (0.05, 1, 12.706),
        (0.05, 4, 2.776),
        (0.05, 10, 2.228),
        (0.01, 3, 5.841),
        (0.01, 5, 4.032),
        (0.001, 10, 4.587),
        (0.001, 7, 5.408),
    ] {
        let t = t_quantile(p, nu);
        assert!((t - want).abs() < 2e-3 * want, "p {p} nu {nu}: {t} vs {want}");
    }
    // Many degrees of freedom: the normal quantile.
    assert!((t_quantile(1e-4, 400) - Gates::new(1e-4).z).abs() < 0.05);
}

/// Deterministic standard normal draws (xorshift and Box-Muller).
fn normals(seed: u64) -> impl FnMut() -> f64 {
    let mut x = seed | 1;
    move || {
        let mut u = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            ((x >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        let (a, b) = (u(), u());
        libm::sqrt(-2.0 * libm::log(a)) * libm::cos(core::f64::consts::TAU * b)
    }
}

/// A track at `v` m/s along x with white speed and heading noise of the given sigmas (the declared ones stay
/// 0.5 m/s and 0.1 rad), checked state by state; returns (alarms of the speed step, of the heading, states).
fn noisy_run(p: f64, v: f64, sigma_v: f64, sigma_h: f64, dt: f64, states: usize, seed: u64) -> (usize, usize, usize) {
    let gates = Gates::new(p);
    let mut g = normals(seed);
    let mut h = History::default();
    let (mut speed, mut heading, mut judged) = (0, 0, 0);
    for k in 0..states {
        let t = k as f64 * dt;
        let mut s = e(t, v * t, (v + sigma_v * g()) as f32);
        s.heading_rad = (sigma_h * g()) as f32;
        if !h.is_empty() {
            let c = check_calibrated(&h, &s, &MotionLimits::default(), &gates, 1.0, 0.5);
            judged += 1;
            speed += usize::from(c.fired.contains(Conditions::ACCELERATION));
            heading += usize::from(c.fired.contains(Conditions::TURN_RATE));
            s.suspect = !c.fired.is_empty();
        }
        h.push(s);
    }
    (speed, heading, judged)
}

#[test]
fn own_scatter_gate_keeps_its_false_alarm_probability() {
    // Honest declared sigmas (0.5 m/s, 0.1 rad at speed: 0.1 + 0.5 / 10): the own scatter never narrows the
    // margin below z, the rate is the declared gate's. Speeds and headings 10x less noisy than declared: the
    // own-scatter test sets the margin, and its rate must still be about p (the t-test), not more.
    let p = 0.01;
    for (sv, sh, seed) in [(0.05, 0.015, 3u64), (0.5, 0.15, 5), (0.01, 0.002, 7)] {
        let (speed, heading, n) = noisy_run(p, 10.0, sv, sh, 0.01, 60_000, seed);
        let (rs, rh) = (speed as f64 / n as f64, heading as f64 / n as f64);
        #[cfg(feature = "std")]
        std::println!("noise {sv} m/s, {sh} rad: speed-step rate {rs:.4}, heading rate {rh:.4} (p {p})");
        assert!(rs < 1.5 * p, "speed {sv}: {rs}");
        assert!(rh < 1.5 * p, "heading {sh}: {rh}");
    }
}

#[test]
fn a_2_mps_speed_step_on_a_steady_track_is_caught_at_10_and_20_hz() {
    // Declared 1 m/s speed sigma (the paper's margin) on a track whose speeds scatter by 0.05 m/s: a single
    // state reported 2 m/s too fast is beyond `a_acc dt` plus the track's own scatter.
    for dt in [0.1, 0.05] {
        let mut g = normals(11);
        let mut h = History::default();
        for k in 0..HISTORY {
            let t = k as f64 * dt;
            let mut s = e(t, 10.0 * t, (10.0 + 0.05 * g()) as f32);
            s.sv_mps = 1.0;
            h.push(s);
        }
        let t = HISTORY as f64 * dt;
        let mut s = e(t, 10.0 * t, 12.0);
        s.sv_mps = 1.0;
        let c = run(&h, &s);
        assert!(c.fired.contains(Conditions::ACCELERATION), "dt {dt}: {c:?}");
        assert_eq!(c.kind, Some(ImplausibilityKind::SpeedInconsistent), "dt {dt}: {c:?}");
        // A real acceleration at the limit (7 m/s^2) is not a step.
        let mut s = e(t, 10.0 * t, (10.0 + 6.5 * dt) as f32);
        s.sv_mps = 1.0;
        assert!(run(&h, &s).fired.is_empty(), "dt {dt}");
    }
    // A track that scatters as much as it declares: the 2 m/s step is within its noise (z margin).
    let mut g = normals(13);
    let mut h = History::default();
    for k in 0..HISTORY {
        let t = k as f64 * 0.1;
        let mut s = e(t, 10.0 * t, (10.0 + 1.0 * g()) as f32);
        s.sv_mps = 1.0;
        h.push(s);
    }
    let mut s = e(1.2, 12.0, 12.0);
    s.sv_mps = 1.0;
    assert!(!run(&h, &s).fired.contains(Conditions::ACCELERATION));
}

#[test]
fn a_flip_of_a_slow_pedestrian_is_caught_with_a_steady_heading_history() {
    // 1.6 m/s (a flip changes the velocity by 3.2 m/s): the declared heading sigma 0.1 + 0.5 / 1.6 rad leaves
    // no room for a flip, the track's steady headings (0.02 rad) do.
    let mut g = normals(17);
    let mut h = History::default();
    for k in 0..HISTORY {
        let t = k as f64 * 0.1;
        let mut s = e(t, 1.6 * t, 1.6);
        s.heading_rad = (0.02 * g()) as f32;
        h.push(s);
    }
    let mut s = e(1.2, 1.92, 1.6);
    s.heading_rad = 3.1;
    let c = run(&h, &s);
    assert_eq!(c.kind, Some(ImplausibilityKind::HeadingFlip), "{c:?}");
    // Without the history (two states), the declared sigma alone cannot tell.
    let h2 = track(1.6, 2);
    let mut s = e(0.2, 0.32, 1.6);
    s.heading_rad = 3.1;
    assert!(run(&h2, &s).kind != Some(ImplausibilityKind::HeadingFlip));
}

/// A standing object (declared 0.3 m per axis) whose centre jitters as a Gauss-Markov process of `sigma` m per
/// axis and correlation `rho` per frame (white for 0), checked state by state at `p`; returns (alarms of the
/// own-scatter position test, states).
fn jitter_run(p: f64, sigma: f64, rho: f64, dt: f64, states: usize, seed: u64) -> (usize, usize) {
    let gates = Gates::new(p);
    let mut g = normals(seed);
    let mut h = History::default();
    let (mut jx, mut jy) = (g(), g());
    let k = libm::sqrt(1.0 - rho * rho);
    let (mut alarms, mut judged) = (0, 0);
    for i in 0..states {
        jx = rho * jx + k * g();
        jy = rho * jy + k * g();
        let mut s = e(i as f64 * dt, sigma * jx, 0.0);
        s.y_m = sigma * jy;
        s.sx_m = 0.3;
        s.sy_m = 0.3;
        if !h.is_empty() {
            let c = check_calibrated(&h, &s, &MotionLimits::default(), &gates, 1.0, 0.5);
            judged += 1;
            // (The own-scatter test alone: the baseline test's rate at honest sigmas is its own p.)
            alarms += usize::from(c.own_position.is_some());
            s.suspect = !c.fired.is_empty();
        }
        h.push(s);
    }
    (alarms, judged)
}

#[test]
fn own_position_gate_keeps_its_false_alarm_probability() {
    // White jitter from 0.03x to 1x the declared 0.3 m, and the tracker bed's correlated jitter (0.25 m, 0.8
    // per frame): the own-scatter F test must not alarm much more often than p.
    let p = 0.01;
    for (sigma, rho, seed) in [(0.3, 0.0, 3u64), (0.1, 0.0, 5), (0.01, 0.0, 7), (0.25, 0.8, 9), (0.05, 0.8, 11)] {
        let (alarms, n) = jitter_run(p, sigma, rho, 0.1, 60_000, seed);
        let rate = alarms as f64 / n as f64;
        #[cfg(feature = "std")]
        std::println!("jitter {sigma} m, rho {rho}: rate {rate:.4} (p {p})");
        assert!(rate < 1.5 * p, "jitter {sigma} rho {rho}: {rate}");
    }
}

#[test]
fn a_jump_of_a_standing_object_is_caught_by_its_own_scatter() {
    // The bed's standing objects: declared 0.3 m, jitter 0.25 m correlated 0.8 per frame. A 1.55 m jump after a
    // full history is caught at 10 and 20 Hz and named a jump; the declared sigmas alone (the own-position
    // test switched off) miss most of them.
    let without_own = Gates { f: [f64::INFINITY; HISTORY], ..Gates::new(1e-4) };
    let mut declared_only = 0;
    let mut cases = 0;
    for dt in [0.1, 0.05] {
        for seed in [21u64, 23, 25, 27, 29, 31] {
            let mut g = normals(seed);
            let mut h = History::default();
            let (mut jx, mut jy) = (0.0, 0.0);
            for i in 0..HISTORY {
                jx = 0.8 * jx + 0.6 * g();
                jy = 0.8 * jy + 0.6 * g();
                let mut s = e(i as f64 * dt, 0.25 * jx, 0.0);
                s.y_m = 0.25 * jy;
                s.sx_m = 0.3;
                s.sy_m = 0.3;
                h.push(s);
            }
            let last = *h.last().unwrap();
            let mut s = e(HISTORY as f64 * dt, last.x_m + 1.1, 0.0);
            s.y_m = last.y_m - 1.1;
            s.sx_m = 0.3;
            s.sy_m = 0.3;
            let c = run(&h, &s);
            assert_eq!(c.kind, Some(ImplausibilityKind::PositionJump), "dt {dt} seed {seed}: {c:?}");
            let d = check_calibrated(&h, &s, &MotionLimits::default(), &without_own, 1.0, 0.5);
            declared_only += usize::from(!d.fired.is_empty());
            cases += 1;
        }
    }
    assert!(declared_only * 2 < cases, "the declared sigmas alone caught {declared_only} of {cases}");
}

#[test]
fn a_warmup_that_hid_3_mps_is_named_at_its_end() {
    // Reported 0 (warm-up) then 3.2 m/s, the box moving at 3.2 m/s: at 10 and 20 Hz the warm-up hid a
    // safety-critical speed error; a pedestrian at 1.4 m/s (and 2 m/s) after its warm-up is not an alarm.
    for dt in [0.1, 0.05] {
        let mut s0 = e(0.0, 0.0, 0.0);
        s0.warmup = true;
        s0.sv_mps = 0.7;
        let h = History::with(s0);
        let c = run(&h, &e(dt, 3.2 * dt, 3.2));
        assert_eq!(c.kind, Some(ImplausibilityKind::SpeedInconsistent), "dt {dt}: {c:?}");
        assert!(c.severity > 1.0, "dt {dt}: {c:?}");
        assert!(run(&h, &e(dt, 1.4 * dt, 1.4)).fired.is_empty(), "dt {dt}");
        assert!(run(&h, &e(dt, 2.0 * dt, 2.0)).fired.is_empty(), "dt {dt}");
    }
}

#[test]
fn robust_speed_scatter_keeps_its_false_alarm_probability() {
    // The robust own-scatter test alone, without the physical allowance: a new speed step beyond
    // `robust[m] max(q, floor)` declared sigmas. White speed noise (consecutive steps share a state) and the
    // tracker bed's Gauss-Markov noise (0.8 per frame), at the declared sigma and 5x below it: the rate must be
    // `p / 2` (the test's share), neither more (false alarms) nor far less (a test that only looks calibrated).
    let p = 0.01;
    let gates = Gates::new(p);
    for (sigma, rho, seed) in [(0.5, 0.0, 3u64), (0.1, 0.0, 5), (0.5, 0.8, 7), (0.1, 0.8, 9)] {
        let mut g = normals(seed);
        let mut h = History::default();
        let (mut fired, mut judged) = (0usize, 0usize);
        let mut noise = 0.0f64;
        for k in 0..60_000 {
            noise = rho * noise + libm::sqrt(1.0 - rho * rho) * sigma * g();
            let s = e(k as f64 * 0.1, k as f64, (10.0 + noise) as f32);
            if let Some(last) = h.last() {
                let (q, m) = h.robust_speed_scale();
                if m >= OWN_SCATTER_MIN_INCREMENTS {
                    let c = gates.robust[usize::from(m)];
                    let step = f64::from(s.v_mps - last.v_mps) / libm::sqrt(0.5);
                    judged += 1;
                    fired += usize::from(libm::fabs(step) > c * q.max(gates.robust_floor[usize::from(m)]));
                }
            }
            h.push(s);
        }
        let rate = fired as f64 / judged as f64;
        #[cfg(feature = "std")]
        std::println!(
            "speed noise {sigma} m/s (declared 0.5), correlation {rho}: robust test rate {rate:.4} (p / 2 = {})",
            p / 2.0
        );
        assert!(rate < 1.5 * 0.5 * p && rate > 0.5 * 0.5 * p, "sigma {sigma}, rho {rho}: {rate}");
    }
}

/// A car at `v` m/s along x (white noise of 0.05 m on the position and 0.05 m/s on the speed, declared as the
/// simulator's objects declare theirs: 0.1 m, 1 m/s), sampled every `dt`, with the speed reported `+2 m/s` too
/// high at the states `errors` (the campaign's transient errors) that went unnoticed (pushed as alarm-free).
fn car_with_missed_errors(v: f64, dt: f64, states: usize, errors: &[usize], seed: u64) -> History {
    let mut g = normals(seed);
    let mut h = History::default();
    for k in 0..states {
        let t = k as f64 * dt;
        let dv = if errors.contains(&k) { 2.0 } else { 0.0 };
        let mut s = e(t, v * t + 0.05 * g(), (v + 0.05 * g() + dv) as f32);
        s.y_m = 0.05 * g();
        s.sv_mps = 1.0;
        h.push(s);
    }
    h
}

#[test]
fn a_2_mps_transient_error_is_caught_on_a_noisy_track_that_missed_earlier_ones() {
    // Declared 1 m/s: a single 2 m/s error is within the declared sigma (z hypot(1, 1) = 5.5 m/s at p = 1e-4),
    // so only the track's own scatter can tell it. Three earlier errors went unnoticed: their six steps of 2 m/s
    // make the mean of squares of the clean steps (the t-test) as wide as the declared margin; the robust order
    // statistic of the last 24 steps is not moved by them. (At 10 Hz, `a_acc dt` = 0.7 m/s leaves 1.3 m/s for
    // the noise: the track's own speed steps must scatter by less than about a tenth of the declared sigma;
    // with 0.1 m/s of noise it is at the limit.)
    for dt in [0.1, 0.05] {
        let n = 30;
        let h = car_with_missed_errors(8.0, dt, n, &[8, 15, 24], 23);
        let ((rms, _), _) = h.own_scatter();
        assert!(rms > 0.5, "the missed errors inflate the mean of squares: {rms}");
        let t = n as f64 * dt;
        let mut s = e(t, 8.0 * t, 10.0);
        s.sv_mps = 1.0;
        let c = run(&h, &s);
        assert!(c.fired.contains(Conditions::ACCELERATION), "dt {dt}: {c:?}");
        assert_eq!(c.kind, Some(ImplausibilityKind::SpeedInconsistent), "dt {dt}: {c:?}");
        assert!((c.error_size - 2.0).abs() < 0.5, "dt {dt}: the size estimate {}", c.error_size);
        // Benign: the car accelerates at 6.5 m/s^2 (below a_acc = 7), or its speed is 3 of its own sigmas off.
        let mut s = e(t, 8.0 * t, (8.0 + 6.5 * dt) as f32);
        s.sv_mps = 1.0;
        assert!(run(&h, &s).fired.is_empty(), "dt {dt}: {:?}", run(&h, &s));
        let mut s = e(t, 8.0 * t, 8.15);
        s.sv_mps = 1.0;
        assert!(run(&h, &s).fired.is_empty(), "dt {dt}: {:?}", run(&h, &s));
    }
    // A track whose speeds scatter as much as declared (1 m/s): the robust scale is about 1, and the 2 m/s
    // step stays within the declared margin.
    let mut g = normals(29);
    let mut h = History::default();
    for k in 0..30 {
        let t = k as f64 * 0.1;
        let mut s = e(t, 8.0 * t, (8.0 + 1.0 * g()) as f32);
        s.sv_mps = 1.0;
        h.push(s);
    }
    let mut s = e(3.0, 24.0, 10.0);
    s.sv_mps = 1.0;
    assert!(!run(&h, &s).fired.contains(Conditions::ACCELERATION), "{:?}", run(&h, &s));
}

/// The order statistic as selected in a copy of the ring's filled part (the selection the sorted steps
/// replace), with every rank's value for the comparison.
fn selected_from_ring(h: &History) -> ([u32; SPEED_STEPS], usize) {
    let m = usize::from(h.speed_len);
    let mut out = [0u32; SPEED_STEPS];
    for (k, o) in out.iter_mut().enumerate().take(m) {
        let mut buf = h.speed_ring;
        let (_, q, _) = buf[..m].select_nth_unstable_by(k, f32::total_cmp);
        *o = q.to_bits();
    }
    (out, m)
}

fn check_sorted_against_ring(h: &History) -> Result<(), proptest::test_runner::TestCaseError> {
    let (selected, m) = selected_from_ring(h);
    for (k, want) in selected.iter().enumerate().take(m) {
        proptest::prop_assert_eq!(h.sorted_speed_step(k).map(f32::to_bits), Some(*want), "rank {} of {}", k, m);
    }
    if m >= usize::from(OWN_SCATTER_MIN_INCREMENTS) {
        let (q, mm) = h.robust_speed_scale();
        let want = f32::from_bits(selected[robust_rank(m as u8) - 1]);
        proptest::prop_assert_eq!(usize::from(mm), m);
        proptest::prop_assert_eq!(q.to_bits(), libm::sqrt(f64::from(want)).to_bits());
    }
    Ok(())
}

/// The studentised steps as computed before the speed step was shared with `speed_step_any`.
fn steps_from_reference(prev: Option<&Entry>, e: &Entry) -> (f32, f32) {
    let Some(p) = prev.filter(|p| clean_pair(p, e)) else { return (-1.0, -1.0) };
    let sq = |x: f32| f64::from(x) * f64::from(x);
    let var_v = sq(p.sv_mps) + sq(e.sv_mps);
    let dv = f64::from(e.v_mps) - f64::from(p.v_mps);
    let speed = if var_v > 0.0 { (dv * dv / var_v) as f32 } else { -1.0 };
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

proptest::proptest! {
    #[test]
    fn shared_speed_step_gives_the_same_steps(
        a in proptest::collection::vec(
            proptest::prop_oneof![
                proptest::sample::select(vec![0.0f32, -0.0, 1.0, 1e-30, 1e30, f32::MAX, f32::INFINITY, f32::NAN]),
                -50.0f32..50.0,
            ],
            6,
        ),
        flags in proptest::collection::vec(proptest::bool::ANY, 4),
    ) {
        // Speeds, speed sigmas and headings of two states (with zeros, huge, infinite and NaN values), clean or
        // not: the shared speed step gives the steps bit for bit as before.
        let mut p = e(0.0, 0.0, a[0]);
        let mut q = e(0.1, 1.0, a[1]);
        (p.sv_mps, q.sv_mps, p.heading_rad, q.heading_rad) = (a[2], a[3], a[4], a[5]);
        (p.suspect, p.warmup, q.suspect, q.warmup) = (flags[0], flags[1], flags[2], flags[3]);
        for prev in [None, Some(&p)] {
            let (x, y) = steps_from(prev, &q);
            let (xr, yr) = steps_from_reference(prev, &q);
            proptest::prop_assert_eq!((x.to_bits(), y.to_bits()), (xr.to_bits(), yr.to_bits()));
        }
    }

    #[test]
    fn sorted_steps_give_the_ring_s_order_statistic(
        // Steps drawn from a few values (ties, zeros, +inf) and from the whole non-negative range, long enough
        // for several wrap-arounds of the 24-step ring.
        steps in proptest::collection::vec(
            proptest::prop_oneof![
                proptest::sample::select(vec![0.0f32, -0.0, 1.0, 2.5, f32::MIN_POSITIVE, f32::INFINITY]),
                0.0f32..4.0,
                proptest::num::f32::POSITIVE | proptest::num::f32::ZERO | proptest::num::f32::SUBNORMAL,
            ],
            0..120,
        )
    ) {
        let mut h = History::default();
        for &q in &steps {
            h.push_speed_step(q);
            check_sorted_against_ring(&h)?;
        }
    }

    #[test]
    fn sorted_steps_follow_the_pushed_states(
        states in proptest::collection::vec((0.0f32..20.0, 0.0f32..2.0, proptest::bool::ANY), 1..100)
    ) {
        // Through `History::push`: speed steps of random speeds and sigmas, warm-ups (no step) among them.
        let mut h = History::default();
        for (k, &(v, sv, warmup)) in states.iter().enumerate() {
            let mut s = e(k as f64 * 0.1, k as f64, v);
            s.sv_mps = sv;
            s.warmup = warmup;
            h.push(s);
            check_sorted_against_ring(&h)?;
        }
    }

    #[test]
    fn running_scatter_sums_match_a_recount(
        steps in proptest::collection::vec((0.0f32..20.0, -3.2f32..3.2, proptest::bool::ANY, proptest::bool::ANY), 1..60)
    ) {
        let mut h = History::default();
        for (k, &(v, th, suspect, warmup)) in steps.iter().enumerate() {
            let mut s = e(k as f64 * 0.1, k as f64, v);
            s.heading_rad = th;
            s.suspect = suspect;
            s.warmup = warmup;
            h.push(s);
            // Recount from the kept states (the oldest one's step is not kept).
            let (mut sv, mut nv, mut sh, mut nh) = (0.0f64, 0u8, 0.0f64, 0u8);
            let (mut sp, mut np) = (0.0f64, 0u8);
            for i in 1..h.len() {
                let (a, b) = (h.get(i - 1).copied().unwrap_or_default(), h.get(i).copied().unwrap_or_default());
                let (x, y) = steps_from(Some(&a), &b);
                if x >= 0.0 { sv += f64::from(x); nv += 1; }
                if y >= 0.0 { sh += f64::from(y); nh += 1; }
                let q = position_step(Some(&a), &b);
                if q >= 0.0 { sp += f64::from(q); np += 1; }
            }
            let (mp, n_p) = h.own_position_scatter();
            proptest::prop_assert_eq!(n_p, np);
            let want = if np == 0 { 0.0 } else { sp / f64::from(np) };
            proptest::prop_assert!((mp - want).abs() < 1e-6 * (1.0 + mp));
            let rms = |s: f64, n: u8| if n == 0 { 0.0 } else { libm::sqrt(s / f64::from(n)) };
            let ((a, na), (b, nb)) = h.own_scatter();
            proptest::prop_assert_eq!((na, nb), (nv, nh));
            proptest::prop_assert!((a - rms(sv, nv)).abs() < 1e-6 * (1.0 + a));
            proptest::prop_assert!((b - rms(sh, nh)).abs() < 1e-6 * (1.0 + b));
        }
    }

    #[test]
    fn trapezoid_matches_its_reference_bit_for_bit(
        states in proptest::collection::vec(
            (0.01f64..0.3, -2.0f32..20.0, -3.2f32..3.2, 0.0f32..2.0, 0.0f32..0.5, proptest::bool::ANY),
            1..40,
        ),
        last in (0.01f64..0.3, -2.0f32..20.0, -3.2f32..3.2, 0.0f32..2.0),
        b in 0usize..14,
    ) {
        // Random times (also out of order: steps of either sign), speeds, headings, sigmas and flipped states,
        // several wrap-arounds of the ring; every start `b` (also past the end) and both `skip_flipped`.
        let mut h = History::default();
        let mut t = 0.0f64;
        for (k, &(dt, v, th, sv, sh, flipped)) in states.iter().enumerate() {
            t += if k % 7 == 3 { -dt } else { dt };
            let mut s = e(t, k as f64 * 0.7, v);
            s.heading_rad = th;
            s.sv_mps = sv;
            s.sh_rad = sh;
            s.sx_m = 0.1 + sv;
            s.sy_m = 0.2 + sh;
            s.flipped = flipped;
            h.push(s);
            let mut s1 = e(t + last.0, 3.0, last.1);
            s1.heading_rad = last.2;
            s1.sv_mps = last.3;
            let (sn, cs) = libm::sincos(f64::from(s1.heading_rad));
            s1.unit = [cs as f32, sn as f32];
            let from = h.get(b).copied().unwrap_or(s1);
            for skip in [false, true] {
                let (p, c) = trapezoid(&h, &from, b, &s1, skip);
                let (pr, cr) = trapezoid_reference(&h, &from, b, &s1, skip);
                let bits = |x: &[f64]| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
                proptest::prop_assert_eq!(bits(&p), bits(&pr));
                proptest::prop_assert_eq!(bits(&c), bits(&cr));
            }
        }
    }
}
