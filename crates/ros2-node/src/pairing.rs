//! Pairing of point clouds with object lists as they arrive, with bounded buffers.
//!
//! The rule is the one `pmon check bag.mcap` uses (the cloud nearest in stamp within the tolerance), applied
//! to what has arrived so far:
//! - object lists are checked in arrival order (the monitor keeps per-track history, so order matters);
//! - the oldest waiting list is paired as soon as a cloud stamped at or after it has arrived (clouds arrive
//!   in stamp order, so no nearer cloud can come later) and the caller's other inputs are there (the node:
//!   an ego pose at or after the list's stamp), or when it has waited `wait_s` (wall
//!   clock): then with the nearest buffered cloud within the tolerance, or with none (checked with the
//!   plausibility checks only, reported as unpaired);
//! - at most `max_clouds` clouds are held (the oldest goes first; one that never paired is reported) and at
//!   most `max_lists` lists wait (a further list drops the oldest waiting one, reported): the node drops and
//!   reports frames rather than queueing without bound.

use std::collections::VecDeque;
use std::sync::Arc;

/// Limits and tolerances.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PairingConfig {
    /// Largest |list stamp - cloud stamp| for a pairing, seconds.
    pub tolerance_s: f64,
    /// Longest a list waits for its cloud, seconds of wall time.
    pub wait_s: f64,
    /// Clouds held.
    pub max_clouds: usize,
    /// Object lists waiting.
    pub max_lists: usize,
}

impl Default for PairingConfig {
    fn default() -> Self {
        Self { tolerance_s: 0.05, wait_s: 0.3, max_clouds: 4, max_lists: 4 }
    }
}

/// Something the pairing gave up on (reported by the node, never silent).
#[derive(Clone, Debug, PartialEq)]
pub enum Dropped {
    /// An object list dropped unchecked because `max_lists` lists were waiting (stamp, seconds).
    List(f64),
    /// A cloud that left the buffer without being paired with any list (stamp, seconds).
    UnpairedCloud(f64),
}

/// A list ready to be checked, with its cloud (if one was paired; shared, one cloud may serve several lists).
#[derive(Debug)]
pub struct Ready<C, L> {
    /// The object list.
    pub list: L,
    /// Its stamp, seconds.
    pub stamp_s: f64,
    /// The paired cloud and its stamp.
    pub cloud: Option<(f64, Arc<C>)>,
}

struct HeldCloud<C> {
    stamp_s: f64,
    cloud: Arc<C>,
    used: bool,
}

struct Waiting<L> {
    stamp_s: f64,
    list: L,
    arrived_s: f64,
}

/// The pairing buffers.
pub struct Pairer<C, L> {
    cfg: PairingConfig,
    clouds: VecDeque<HeldCloud<C>>,
    lists: VecDeque<Waiting<L>>,
}

impl<C, L> Pairer<C, L> {
    /// Empty buffers. Limits below 1 are raised to 1.
    #[must_use]
    pub fn new(cfg: PairingConfig) -> Self {
        let cfg = PairingConfig { max_clouds: cfg.max_clouds.max(1), max_lists: cfg.max_lists.max(1), ..cfg };
        Self { cfg, clouds: VecDeque::new(), lists: VecDeque::new() }
    }

    /// Adds a cloud stamped `stamp_s`; returns the cloud it pushed out if that one never paired.
    pub fn push_cloud(&mut self, stamp_s: f64, cloud: C) -> Option<Dropped> {
        let mut dropped = None;
        if self.clouds.len() >= self.cfg.max_clouds {
            if let Some(old) = self.clouds.pop_front() {
                if !old.used {
                    dropped = Some(Dropped::UnpairedCloud(old.stamp_s));
                }
            }
        }
        self.clouds.push_back(HeldCloud { stamp_s, cloud: Arc::new(cloud), used: false });
        dropped
    }

    /// Adds an object list stamped `stamp_s` that arrived at wall time `now_s`; returns the list it dropped
    /// when `max_lists` were already waiting.
    pub fn push_list(&mut self, stamp_s: f64, list: L, now_s: f64) -> Option<Dropped> {
        let mut dropped = None;
        if self.lists.len() >= self.cfg.max_lists {
            if let Some(old) = self.lists.pop_front() {
                dropped = Some(Dropped::List(old.stamp_s));
            }
        }
        self.lists.push_back(Waiting { stamp_s, list, arrived_s: now_s });
        dropped
    }

    /// The nearest held cloud within the tolerance.
    fn nearest(&self, stamp_s: f64) -> Option<usize> {
        self.clouds
            .iter()
            .enumerate()
            .map(|(i, c)| (i, (c.stamp_s - stamp_s).abs()))
            .filter(|(_, d)| *d <= self.cfg.tolerance_s)
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(i, _)| i)
    }

    /// The oldest waiting list if it can be checked now (wall time `now_s`), with its cloud. `others_ready`
    /// says whether the other inputs for a list stamped so are there; `flush` checks the list without waiting
    /// any longer (at shutdown).
    pub fn next(&mut self, now_s: f64, flush: bool, others_ready: &dyn Fn(f64) -> bool) -> Option<Ready<C, L>> {
        let front = self.lists.front()?;
        let later_cloud = self.clouds.iter().any(|c| c.stamp_s >= front.stamp_s);
        let complete = later_cloud && others_ready(front.stamp_s);
        let timed_out = now_s - front.arrived_s >= self.cfg.wait_s;
        if !complete && !timed_out && !flush {
            return None;
        }
        let w = self.lists.pop_front()?;
        let cloud = self.nearest(w.stamp_s).and_then(|i| self.clouds.get_mut(i)).map(|c| {
            c.used = true;
            (c.stamp_s, Arc::clone(&c.cloud))
        });
        Some(Ready { list: w.list, stamp_s: w.stamp_s, cloud })
    }

    /// Lists waiting.
    #[must_use]
    pub fn waiting(&self) -> usize {
        self.lists.len()
    }

    /// Everything still held at shutdown: the waiting lists' stamps and the clouds that never paired.
    #[must_use]
    pub fn leftovers(&self) -> (Vec<f64>, Vec<f64>) {
        (
            self.lists.iter().map(|w| w.stamp_s).collect(),
            self.clouds.iter().filter(|c| !c.used).map(|c| c.stamp_s).collect(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pairer() -> Pairer<&'static str, u32> {
        Pairer::new(PairingConfig { tolerance_s: 0.05, wait_s: 0.3, max_clouds: 2, max_lists: 2 })
    }

    #[test]
    fn exact_stamp_pairs_at_once_and_order_is_kept() {
        let mut p = pairer();
        assert!(p.push_list(1.0, 10, 0.0).is_none());
        assert!(p.next(0.0, false, &|_| true).is_none(), "no cloud yet: wait");
        assert!(p.push_cloud(1.0, "c1").is_none());
        let r = p.next(0.01, false, &|_| true).unwrap();
        assert_eq!((r.list, r.stamp_s, r.cloud.map(|c| (c.0, *c.1))), (10, 1.0, Some((1.0, "c1"))));
        assert!(p.next(0.01, false, &|_| true).is_none());
    }

    #[test]
    fn a_later_cloud_releases_the_list_with_the_nearest_one_within_tolerance() {
        let mut p = pairer();
        p.push_cloud(0.98, "early");
        p.push_list(1.0, 1, 0.0);
        assert!(p.next(0.0, false, &|_| true).is_none(), "a nearer cloud may still come");
        p.push_cloud(1.2, "late");
        let r = p.next(0.0, false, &|_| true).unwrap();
        assert_eq!(r.cloud.map(|c| *c.1), Some("early"));
        // Outside the tolerance: checked without a cloud.
        p.push_list(1.1, 2, 0.0);
        let r = p.next(0.0, false, &|_| true).unwrap();
        assert!(r.cloud.is_none());
    }

    #[test]
    fn a_list_waits_for_the_other_inputs_too() {
        let mut p = pairer();
        p.push_list(1.0, 1, 0.0);
        p.push_cloud(1.0, "c");
        assert!(p.next(0.1, false, &|t| t <= 0.9).is_none(), "no ego pose at 1.0 s yet");
        assert!(p.next(0.1, false, &|t| t <= 1.0).is_some());
    }

    #[test]
    fn waiting_ends_after_wait_s_and_flush_ends_it_at_once() {
        let mut p = pairer();
        p.push_list(5.0, 1, 100.0);
        assert!(p.next(100.29, false, &|_| true).is_none());
        assert!(p.next(100.31, false, &|_| true).unwrap().cloud.is_none());
        p.push_list(6.0, 2, 200.0);
        assert_eq!(p.next(200.0, true, &|_| true).unwrap().list, 2);
    }

    #[test]
    fn buffers_are_bounded_and_what_falls_out_is_reported() {
        let mut p = pairer();
        p.push_cloud(1.0, "a");
        p.push_cloud(2.0, "b");
        assert_eq!(p.push_cloud(3.0, "c"), Some(Dropped::UnpairedCloud(1.0)));
        p.push_list(2.0, 1, 0.0);
        assert!(p.next(0.0, false, &|_| true).is_some());
        assert_eq!(p.push_cloud(4.0, "d"), None, "cloud b was used: not reported");
        assert_eq!(p.push_cloud(5.0, "e"), Some(Dropped::UnpairedCloud(3.0)));
        p.push_list(10.0, 1, 0.0);
        p.push_list(11.0, 2, 0.0);
        assert_eq!(p.push_list(12.0, 3, 0.0), Some(Dropped::List(10.0)));
        assert_eq!(p.waiting(), 2);
        assert_eq!(p.leftovers(), (vec![11.0, 12.0], vec![4.0, 5.0]));
    }
}
