//! The node's own health: what was dropped or lost, latencies, and the `pmon: node` diagnostic status.

use std::collections::VecDeque;

use pmon_ros::msg::{DiagnosticStatus, KeyValue};
use pmon_ros::verdicts::level;

/// Name of the node's own diagnostic status.
pub const NODE_STATUS: &str = "pmon: node";

/// Latency samples kept for the median and p99 (the most recent ones).
const LATENCY_WINDOW: usize = 10_000;

/// Counts of everything the node did not check, and its latencies.
#[derive(Clone, Debug, Default)]
pub struct NodeCounters {
    /// Object lists dropped unchecked (too many waiting, or left at the frame limit).
    pub lists_dropped: u64,
    /// Object lists DDS overwrote before the node took them (gaps in the publisher's sequence numbers).
    pub lists_lost_in_dds: u64,
    /// Clouds DDS overwrote before the node took them.
    pub clouds_lost_in_dds: u64,
    /// Clouds that left the buffer without an object list.
    pub clouds_unpaired: u64,
    /// Verdicts or diagnostics that could not be published.
    pub publish_errors: u64,
    /// Problems logged but not kept for the summary.
    pub problems_not_kept: u64,
    /// Wall time of the run, seconds.
    pub run_time_s: f64,
    /// The monitor's check time per frame, seconds (recent frames).
    pub check_s: VecDeque<f64>,
    /// From the object list's arrival to its verdicts' publication, seconds (recent frames).
    pub latency_s: VecDeque<f64>,
    /// Drops and losses at the last status, to raise WARN only when new ones happened.
    reported: u64,
}

impl NodeCounters {
    /// Records one frame's check time and end-to-end latency.
    pub fn record_latency(&mut self, check_s: f64, latency_s: f64) {
        for (q, v) in [(&mut self.check_s, check_s), (&mut self.latency_s, latency_s)] {
            if q.len() >= LATENCY_WINDOW {
                q.pop_front();
            }
            q.push_back(v);
        }
    }

    /// Everything not checked or lost so far.
    #[must_use]
    pub fn losses(&self) -> u64 {
        self.lists_dropped + self.lists_lost_in_dds + self.clouds_lost_in_dds + self.publish_errors
    }
}

/// The `q` quantile (0..=1) of samples, nearest rank; `None` when empty.
#[must_use]
pub fn quantile(samples: &VecDeque<f64>, q: f64) -> Option<f64> {
    let mut v: Vec<f64> = samples.iter().copied().collect();
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss, clippy::cast_precision_loss)]
    let rank = ((q * v.len() as f64).ceil() as usize).clamp(1, v.len());
    Some(v[rank - 1])
}

fn ms(v: Option<f64>) -> String {
    v.map_or_else(|| "-".into(), |s| format!("{:.3}", s * 1e3))
}

/// The node's status: STALE when no object list was checked for `idle_s` seconds, WARN when object lists
/// or clouds were dropped or lost, or results not published, since the previous status, OK otherwise. The
/// parameters it runs with (`params`, in words), the totals and the latencies (median, p99) are always given.
pub fn node_status(c: &mut NodeCounters, idle_s: Option<f64>, params: &str) -> DiagnosticStatus {
    let kv = |k: &str, v: String| KeyValue { key: k.into(), value: v };
    let values = vec![
        kv("params", params.to_string()),
        kv("lists_dropped", c.lists_dropped.to_string()),
        kv("lists_lost_in_dds", c.lists_lost_in_dds.to_string()),
        kv("clouds_lost_in_dds", c.clouds_lost_in_dds.to_string()),
        kv("clouds_unpaired", c.clouds_unpaired.to_string()),
        kv("publish_errors", c.publish_errors.to_string()),
        kv("check_ms_median", ms(quantile(&c.check_s, 0.5))),
        kv("check_ms_p99", ms(quantile(&c.check_s, 0.99))),
        kv("latency_ms_median", ms(quantile(&c.latency_s, 0.5))),
        kv("latency_ms_p99", ms(quantile(&c.latency_s, 0.99))),
    ];
    let new_losses = c.losses().saturating_sub(c.reported);
    c.reported = c.losses();
    let (lvl, message) = match idle_s {
        Some(idle) => (level::STALE, format!("no object list checked for {idle:.1} s")),
        None if new_losses > 0 => (level::WARN, format!("{new_losses} frames dropped or lost since the last status")),
        None => (level::OK, "keeping up".into()),
    };
    DiagnosticStatus { level: lvl, name: NODE_STATUS.into(), message, hardware_id: "pmon".into(), values }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_by_nearest_rank() {
        let v: VecDeque<f64> = (1..=100).map(f64::from).collect();
        assert_eq!(quantile(&v, 0.5), Some(50.0));
        assert_eq!(quantile(&v, 0.99), Some(99.0));
        assert_eq!(quantile(&VecDeque::new(), 0.5), None);
    }

    #[test]
    fn warn_only_for_new_losses_and_stale_when_idle() {
        let mut c = NodeCounters::default();
        assert_eq!(node_status(&mut c, None, "p").level, level::OK);
        c.lists_dropped = 2;
        let s = node_status(&mut c, None, "p");
        assert_eq!((s.level, s.message.as_str()), (level::WARN, "2 frames dropped or lost since the last status"));
        assert_eq!(node_status(&mut c, None, "p").level, level::OK, "already reported");
        assert_eq!(node_status(&mut c, Some(3.0), "p").level, level::STALE);
    }

    #[test]
    fn the_parameters_are_named_in_every_status() {
        let mut c = NodeCounters::default();
        for idle in [None, Some(3.0)] {
            let s = node_status(&mut c, idle, "the defaults with --params profile:recall over them: seen_over = true");
            let first = s.values.first().map(|kv| (kv.key.as_str(), kv.value.as_str()));
            assert_eq!(
                first,
                Some(("params", "the defaults with --params profile:recall over them: seen_over = true"))
            );
        }
    }
}
