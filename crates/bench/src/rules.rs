//! The monitor's rule keys as switches of a benchmark run (`pmon bench --seen-over`, `--no-jump-from-returns`, ...):
//! one list, read by `pmon bench`'s argument parser (the `clap` feature) and applied to the parameters here, so that
//! a new key is added in one place.

use pmon_monitor::MonitorParams;

/// Rule keys switched on or off against the default parameters for a whole run. All off: the defaults. An `no_*`
/// switch wins over the switch of the same key.
#[derive(Clone, Debug, Default, PartialEq)]
#[cfg_attr(feature = "clap", derive(clap::Args))]
pub struct RuleSwitches {
    /// Check with the params key `seen_over` on: the free-space test towards the sensor also looks over
    /// nearer obstacles, at the cost of the returns of the cells it reads, gathered before the verdicts (docs/attribution.md).
    #[cfg_attr(feature = "clap", arg(long))]
    pub seen_over: bool,
    /// Check with the params key `face_in_front` on: a box confirmed by its own evidence whose rays end on that
    /// evidence in front of its grown region is a position error (docs/attribution.md).
    #[cfg_attr(feature = "clap", arg(long))]
    pub face_in_front: bool,
    /// Check with the params key `returns_beyond_cells = N`: a box confirmed by its own evidence with at least N own
    /// cells wholly beyond its grown region (every return of the cell) is a position error (docs/attribution.md, "Own
    /// returns beyond the grown region"). Off by default.
    #[cfg_attr(feature = "clap", arg(long, value_name = "N"))]
    pub returns_beyond_cells: Option<u32>,
    /// Check with the params key `spill_gap_m = M`: spill-over gives a confirmed box of a vehicle's length a cluster
    /// across a gap of empty cells up to M metres wide (whole cells; docs/attribution.md, "Spill-over across a gap").
    /// 0.4 by default since issue #10's round of that name; 0 gives the verdicts before it.
    #[cfg_attr(feature = "clap", arg(long, value_name = "M"))]
    pub spill_gap_m: Option<f32>,
    /// Check with the params key `parked_hold_s = S`: a parked vehicle that alarms found displaced in two or more
    /// consecutive frames stays flagged for S seconds (docs/attribution.md, "Parked cars in a row"). Off (0) by
    /// default.
    #[cfg_attr(feature = "clap", arg(long, value_name = "S"))]
    pub parked_hold_s: Option<f64>,
    /// Check with the params key `jump_from_returns` on: step 9 (a box that jumps away from evidence that
    /// stayed) takes evidence centres from the returns, with a narrower allowance (docs/attribution.md). The
    /// default since issue #10; kept for older commands.
    #[cfg_attr(feature = "clap", arg(long))]
    pub jump_from_returns: bool,
    /// Check with the params keys `jump_from_returns` and `jump_first_return` on: step 9's returns' mean is
    /// each cell's first return, set when the cell is first touched (no per-return sums; docs/attribution.md).
    /// The default since issue #10; kept for older commands.
    #[cfg_attr(feature = "clap", arg(long))]
    pub jump_first_return: bool,
    /// Check with `jump_from_returns` off (and so `jump_first_return`): step 9 on the cells' centres only, the
    /// default before issue #10.
    #[cfg_attr(feature = "clap", arg(long, conflicts_with_all = ["jump_from_returns", "jump_first_return", "no_jump_first_return"]))]
    pub no_jump_from_returns: bool,
    /// Check with `jump_first_return` off: step 9's returns' mean from every return, which the rasterizer sums
    /// per hit cell.
    #[cfg_attr(feature = "clap", arg(long, conflicts_with = "jump_first_return"))]
    pub no_jump_first_return: bool,
    /// Check with the params key `seen_body` on: the free-space test towards the sensor counts only rays that
    /// end on the object's body, not on other returns its grown region owns (docs/attribution.md). The default
    /// since issue #10's round "Rays on the body with step 8 gated"; kept for older commands.
    #[cfg_attr(feature = "clap", arg(long))]
    pub seen_body: bool,
    /// Check with the params key `memory_gate` on: evidence farther than `conflict_association_m` from a box is
    /// never its (step 8 and the occluder rule bounded; docs/attribution.md).
    #[cfg_attr(feature = "clap", arg(long))]
    pub memory_gate: bool,
    /// Check with the params key `follow_gate` on: step 8 counts only evidence within `conflict_association_m`
    /// of a box (the half of `memory_gate` that keeps the object-level guarantee; docs/attribution.md). The
    /// default since issue #10's round "Rays on the body with step 8 gated"; kept for older commands.
    #[cfg_attr(feature = "clap", arg(long))]
    pub follow_gate: bool,
    /// Check with the params key `shadow_gate` on: the shadow of unexplained evidence contradicts a box only
    /// within its gate (docs/attribution.md, "The shadow of far evidence").
    #[cfg_attr(feature = "clap", arg(long))]
    pub shadow_gate: bool,
    /// Check with the params key `follow_owner_fit` on: step 8 does not follow cells that fit the body of the
    /// neighbour whose margin holds them (docs/attribution.md, "Step 8 judged by the evidence it follows").
    #[cfg_attr(feature = "clap", arg(long))]
    pub follow_owner_fit: bool,
    /// Check with the params key `release_flagged_claims` on: a hidden box takes the cells in front of it that a
    /// neighbour with its own evidence elsewhere held only by its reported region (docs/attribution.md, "Claims a
    /// flagged neighbour releases"). The default since issue #10's round of that name; kept for older commands.
    #[cfg_attr(feature = "clap", arg(long))]
    pub release_flagged_claims: bool,
    /// Check with the params key `release_to_confirmed` on: a box confirmed by evidence of its own takes the
    /// released cells in front of it too (docs/attribution.md, "Released claims for a confirmed box").
    #[cfg_attr(feature = "clap", arg(long, conflicts_with = "no_release_flagged_claims"))]
    pub release_to_confirmed: bool,
    /// Check with the params key `evidence_runs_on` off (the default before issue #10's round "Evidence in the
    /// margin that runs on": a box confirmed only by evidence in its margin that runs on into a cluster another box
    /// took is displaced).
    #[cfg_attr(feature = "clap", arg(long))]
    pub no_evidence_runs_on: bool,
    /// Check with the params key `seen_through_near_side` off (the default before issue #10's round "The near side
    /// seen through": the free-space test towards the sensor needs a majority of the box's sample points seen empty).
    #[cfg_attr(feature = "clap", arg(long))]
    pub no_seen_through_near_side: bool,
    /// Check with `release_flagged_claims` off (the default before issue #10's round "Claims a flagged neighbour
    /// releases").
    #[cfg_attr(feature = "clap", arg(long, conflicts_with = "release_flagged_claims"))]
    pub no_release_flagged_claims: bool,
    /// Check with the params key `front_cluster` on: a free cluster in front of a confirmed box, fitting it and
    /// outweighing its own cells, goes to it when the evidence confirming the box runs on beyond it
    /// (docs/attribution.md, "One box displaced 2 m in a single sweep"). The default since issue #10's round
    /// "Two rules together"; kept for older commands.
    #[cfg_attr(feature = "clap", arg(long))]
    pub front_cluster: bool,
    /// Check with `front_cluster` off (the default before issue #10's round "Two rules together").
    #[cfg_attr(feature = "clap", arg(long))]
    pub no_front_cluster: bool,
    /// Check with `spill_in_front` off (the default before issue #10's round "Spill-over in front of the box"):
    /// spill-over gives a confirmed box only clusters that touch its own evidence.
    #[cfg_attr(feature = "clap", arg(long))]
    pub no_spill_in_front: bool,
    /// Check with `spill_near_side` off (the default before issue #10's round "The near side of the box"): spill-over
    /// in front of a confirmed box counts all its own evidence, its far side too.
    #[cfg_attr(feature = "clap", arg(long))]
    pub no_spill_near_side: bool,
    /// Check with `spill_least_stretch` on (off by default; issue #10's round "The box a cluster stretches least"):
    /// a cluster that continues several confirmed boxes' evidence, the nearest of them vehicle-sized, goes to the one
    /// it stretches least.
    #[cfg_attr(feature = "clap", arg(long))]
    pub spill_least_stretch: bool,
    /// Check with `memory_hold_s = 0`: a displaced track's offset lives one frame (the default before issue
    /// #10's round "Two rules together", which made it 1 s; docs/attribution.md, "Step 8 held over a gap").
    #[cfg_attr(feature = "clap", arg(long))]
    pub no_memory_hold: bool,
    /// Check with `seen_body` off (the default before issue #10's round "Rays on the body with step 8 gated").
    #[cfg_attr(feature = "clap", arg(long, conflicts_with = "seen_body"))]
    pub no_seen_body: bool,
    /// Check with `follow_gate` off (the default before issue #10's round "Rays on the body with step 8 gated";
    /// with `--memory-gate` step 8 stays bounded).
    #[cfg_attr(feature = "clap", arg(long, conflicts_with = "follow_gate"))]
    pub no_follow_gate: bool,
    /// Check with the grazing rule of the region of interest on (`roi_graze_fraction = 0.5`): a cluster with
    /// fewer than half its band returns inside the ROI and a return over it above `roi_graze_height_m` is
    /// outside it (docs/datasets.md, "The grazing rule"). The default since issue #10.
    #[cfg_attr(feature = "clap", arg(long))]
    pub roi_graze: bool,
    /// Check with the grazing rule off (`roi_graze_fraction = 0`, the default before issue #10).
    #[cfg_attr(feature = "clap", arg(long, conflicts_with = "roi_graze"))]
    pub no_roi_graze: bool,
}

impl RuleSwitches {
    /// The switches applied to `p`.
    pub fn apply(&self, p: &mut MonitorParams) {
        p.seen_over |= self.seen_over;
        p.face_in_front |= self.face_in_front;
        if let Some(n) = self.returns_beyond_cells {
            p.returns_beyond_cells = n;
        }
        if let Some(m) = self.spill_gap_m {
            p.spill_gap_m = m;
        }
        if let Some(s) = self.parked_hold_s {
            p.parked_hold_s = s;
        }
        p.jump_from_returns |= self.jump_from_returns || self.jump_first_return;
        p.jump_first_return |= self.jump_first_return;
        if self.no_jump_first_return {
            p.jump_first_return = false;
        }
        if self.no_jump_from_returns {
            p.jump_from_returns = false;
            p.jump_first_return = false;
        }
        p.seen_body |= self.seen_body;
        p.memory_gate |= self.memory_gate;
        p.follow_gate |= self.follow_gate;
        p.shadow_gate |= self.shadow_gate;
        p.follow_owner_fit |= self.follow_owner_fit;
        p.release_flagged_claims |= self.release_flagged_claims;
        p.release_to_confirmed |= self.release_to_confirmed;
        if self.no_evidence_runs_on {
            p.evidence_runs_on = false;
        }
        if self.no_seen_through_near_side {
            p.seen_through_near_side = false;
        }
        if self.no_release_flagged_claims {
            p.release_flagged_claims = false;
        }
        p.front_cluster |= self.front_cluster;
        if self.no_front_cluster {
            p.front_cluster = false;
        }
        if self.no_spill_in_front {
            p.spill_in_front = false;
        }
        if self.no_spill_near_side {
            p.spill_near_side = false;
        }
        if self.spill_least_stretch {
            p.spill_least_stretch = true;
        }
        if self.no_memory_hold {
            p.memory_hold_s = 0.0;
        }
        if self.no_seen_body {
            p.seen_body = false;
        }
        if self.no_follow_gate {
            p.follow_gate = false;
        }
        if self.roi_graze {
            p.roi_graze_fraction = 0.5;
        }
        if self.no_roi_graze {
            p.roi_graze_fraction = 0.0;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn applied(s: &RuleSwitches) -> MonitorParams {
        let mut p = MonitorParams::PAPER;
        s.apply(&mut p);
        p
    }

    /// No switch leaves the parameters as they are; each switch moves its key, and a `no_*` switch wins.
    #[test]
    fn each_switch_sets_its_key_and_the_no_switch_wins() {
        let d = MonitorParams::PAPER;
        assert_eq!(applied(&RuleSwitches::default()), d);
        let on = |f: fn(&mut RuleSwitches)| {
            let mut s = RuleSwitches::default();
            f(&mut s);
            applied(&s)
        };
        assert!(on(|s| s.seen_over = true).seen_over);
        assert!(on(|s| s.face_in_front = true).face_in_front);
        assert_eq!(on(|s| s.returns_beyond_cells = Some(2)).returns_beyond_cells, 2);
        assert_eq!(on(|s| s.spill_gap_m = Some(0.0)).spill_gap_m.to_bits(), 0.0f32.to_bits());
        assert_eq!(on(|s| s.parked_hold_s = Some(3.0)).parked_hold_s.to_bits(), 3.0f64.to_bits());
        assert!(on(|s| s.shadow_gate = true).shadow_gate);
        assert!(on(|s| s.follow_owner_fit = true).follow_owner_fit);
        assert!(on(|s| s.release_flagged_claims = true).release_flagged_claims);
        assert!(!on(|s| s.no_release_flagged_claims = true).release_flagged_claims);
        assert!(on(|s| s.release_to_confirmed = true).release_to_confirmed);
        assert!(!on(|s| s.no_evidence_runs_on = true).evidence_runs_on);
        assert!(!on(|s| s.no_seen_through_near_side = true).seen_through_near_side);
        assert!(on(|s| s.memory_gate = true).memory_gate);
        let first = on(|s| s.jump_first_return = true);
        assert!(first.jump_from_returns && first.jump_first_return);
        let off = on(|s| {
            s.jump_first_return = true;
            s.no_jump_from_returns = true;
        });
        assert!(!off.jump_from_returns && !off.jump_first_return);
        assert!(!on(|s| s.no_jump_first_return = true).jump_first_return);
        assert!(
            !on(|s| {
                s.seen_body = true;
                s.no_seen_body = true;
            })
            .seen_body
        );
        assert!(!on(|s| s.no_follow_gate = true).follow_gate);
        assert!(!on(|s| s.no_front_cluster = true).front_cluster);
        assert!(!on(|s| s.no_spill_in_front = true).spill_in_front);
        assert!(!on(|s| s.no_spill_near_side = true).spill_near_side);
        assert!(on(|s| s.spill_least_stretch = true).spill_least_stretch);
        assert_eq!(on(|s| s.no_memory_hold = true).memory_hold_s.to_bits(), 0.0f64.to_bits());
        assert_eq!(on(|s| s.no_roi_graze = true).roi_graze_fraction.to_bits(), 0.0f32.to_bits());
        assert_eq!(on(|s| s.roi_graze = true).roi_graze_fraction.to_bits(), 0.5f32.to_bits());
        // The defaults these switches turn off are on in the default parameters (else the switch does nothing).
        assert!(d.seen_body && d.follow_gate && d.front_cluster && d.spill_in_front && d.spill_near_side);
        // ... and the one `spill_least_stretch` turns on is off.
        assert!(!d.spill_least_stretch);
        assert!(d.jump_from_returns && d.memory_hold_s > 0.0);
        assert!(d.roi_graze_fraction > 0.0);
    }
}
