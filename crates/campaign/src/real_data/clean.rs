//! What a clean run on real LiDAR says: every flagged labelled box with the likely reason (whose returns lie in its
//! region, which cluster was attributed to it) and the missed-object alarms, summarised as table rows.

use std::collections::BTreeMap;

use pmon_datasets::{points_in_box, DatasetFrame};
use pmon_monitor::geometry::OrientedRect;
use pmon_monitor::{
    ClusterReport, GridGeometry, MonitorParams, NotMonitoredReason, ObjectState, Region, SensorVerdict,
};

use super::sensor::range_of;
use super::StateRecord;

/// "class (dataset label)" of an object.
pub(super) fn object_label(df: &DatasetFrame, index: usize) -> String {
    let class = df.frame.objects.get(index).map_or("?", |o| o.class.name());
    let cat = df.extras.get(index).map_or("", |e| e.category.as_str());
    format!("{class} ({cat})")
}

/// LiDAR points in an object's labelled box: all of them, and those in the monitor's obstacle height band.
pub(super) fn box_points(df: &DatasetFrame, index: usize, p: &MonitorParams) -> Option<(u32, u32)> {
    let b = df.box_in_ego(index)?;
    let pts = df.points_in_ego();
    let (lo, hi) = p.obstacle_band_m();
    let band: Vec<[f32; 3]> = pts.iter().copied().filter(|q| q[2] >= lo && q[2] <= hi).collect();
    Some((points_in_box(&pts, &b), points_in_box(&band, &b)))
}

/// The monitor's region `A_o` of an object (its own uncertainty, else the default).
pub(super) fn region_of(o: &ObjectState, p: &MonitorParams) -> Region {
    Region::of(o, &o.uncertainty.unwrap_or(p.default_uncertainty), p)
}

/// The frame's LiDAR points in the monitor's obstacle height band, ego frame.
pub(super) fn band_points(df: &DatasetFrame, p: &MonitorParams) -> Vec<[f32; 3]> {
    let (lo, hi) = p.obstacle_band_m();
    df.points_in_ego().into_iter().filter(|q| q[2] >= lo && q[2] <= hi).collect()
}

/// Whose returns lie in a region: obstacle-band points whose grid cell overlaps the grown region, by the labelled
/// box (2D footprint) they fall in.
pub(super) struct Evidence {
    /// In the object's own (clean) box.
    own: u32,
    /// In other labelled boxes, by object id.
    neighbours: BTreeMap<u64, u32>,
    /// In no labelled box.
    unlabelled: u32,
}

impl Evidence {
    pub(super) fn neighbour_total(&self) -> u32 {
        self.neighbours.values().sum()
    }

    pub(super) fn describe(&self) -> String {
        let ids = self.neighbours.keys().map(u64::to_string).collect::<Vec<_>>().join(" ");
        format!(
            "{} of the object itself, {} of labelled neighbours{}, {} of nothing labelled",
            self.own,
            self.neighbour_total(),
            if ids.is_empty() { String::new() } else { format!(" (ids {ids})") },
            self.unlabelled
        )
    }

    /// The main source of the evidence that keeps a displaced box consistent.
    pub(super) fn dominant(&self) -> &'static str {
        let n = self.neighbour_total();
        if self.own >= n && self.own >= self.unlabelled && self.own > 0 {
            "own returns (box longer than the error)"
        } else if n >= self.unlabelled && n > 0 {
            "a labelled neighbour's returns"
        } else if self.unlabelled > 0 {
            "unlabelled returns"
        } else {
            "no band returns in the region"
        }
    }
}

pub(super) fn evidence_in(
    region: &Region,
    df: &DatasetFrame,
    own: usize,
    band: &[[f32; 3]],
    p: &MonitorParams,
) -> Evidence {
    let g = GridGeometry::new(p.grid_cells_per_side(), p.cell_size_m);
    let half = 0.5 * p.cell_size_m;
    let footprints: Vec<(u64, OrientedRect)> = df
        .frame
        .objects
        .iter()
        .map(|o| (o.id, OrientedRect::new(o.x_m, o.y_m, o.heading_rad, 0.5 * o.length_m, 0.5 * o.width_m)))
        .collect();
    let mut ev = Evidence { own: 0, neighbours: BTreeMap::new(), unlabelled: 0 };
    for q in band {
        let Some(c) = g.point_to_cell(q[0], q[1]) else { continue };
        let (cx, cy) = g.cell_center(c);
        if !region.grown.overlaps_square(cx, cy, half) {
            continue;
        }
        if footprints.get(own).is_some_and(|(_, f)| f.contains(q[0], q[1])) {
            ev.own += 1;
        } else if let Some((id, _)) = footprints.iter().find(|(_, f)| f.contains(q[0], q[1])) {
            *ev.neighbours.entry(*id).or_default() += 1;
        } else {
            ev.unlabelled += 1;
        }
    }
    ev
}

/// Gap between a cluster's cell-centre bounds and an object's grown region (axis-aligned, as the monitor's
/// attribution pre-test), metres.
pub(super) fn cluster_gap(region: &Region, c: &ClusterReport) -> f32 {
    let rb = region.grown.aabb();
    let cb = c.bounds_m;
    let gx = (cb[0] - rb[2]).max(rb[0] - cb[2]).max(0.0);
    let gy = (cb[1] - rb[3]).max(rb[1] - cb[3]).max(0.0);
    gx.hypot(gy)
}

/// What the clean run says about a set, gathered frame by frame (the frames are streamed: nothing of a frame is kept
/// but these counts and the rows of the flagged boxes).
#[derive(Default)]
pub(super) struct CleanSummary {
    counts: BTreeMap<&'static str, u64>,
    not_monitored: BTreeMap<NotMonitoredReason, u64>,
    in_scope: u64,
    zero_points: u64,
    flagged: Vec<Vec<String>>,
    mechanisms: BTreeMap<&'static str, u64>,
    /// Size in cells of every missed-object cluster.
    sizes: Vec<u32>,
    nearest: f32,
    /// Missed-object alarms per frame.
    per_frame: Vec<u64>,
    /// The same frames checked without their ROI: missed-object alarms per frame (`None`: no monitor).
    without_roi: Option<Vec<u64>>,
    /// True when a frame carried a ROI.
    any_roi: bool,
}

impl CleanSummary {
    pub(super) fn new() -> Self {
        Self { nearest: f32::INFINITY, ..Self::default() }
    }

    /// Adds the clean run's records and clusters of one frame.
    pub(super) fn add_frame(
        &mut self,
        key: &str,
        p: &MonitorParams,
        df: &DatasetFrame,
        records: &[StateRecord],
        clusters: &[ClusterReport],
    ) {
        for rec in records {
            let v = rec.report.sensor.verdict;
            if let SensorVerdict::NotMonitored(r) = v {
                *self.not_monitored.entry(r).or_default() += 1;
            }
            if !rec.in_scope {
                continue;
            }
            self.in_scope += 1;
            let ds_points = df.extras.get(rec.index).and_then(|e| e.num_points);
            self.zero_points += u64::from(ds_points == Some(0));
            let name = match v {
                SensorVerdict::Consistent => "consistent",
                SensorVerdict::Ghost => "ghost",
                SensorVerdict::PositionError => "position_error",
                SensorVerdict::NotMonitored(_) => "not_monitored",
            };
            *self.counts.entry(name).or_default() += 1;
            if !matches!(v, SensorVerdict::Ghost | SensorVerdict::PositionError) {
                continue;
            }
            let (mechanism, row) = flagged_row(key, p, df, rec, clusters);
            *self.mechanisms.entry(mechanism).or_default() += 1;
            self.flagged.push(row);
        }
        let mut missed = 0u64;
        for c in clusters.iter().filter(|c| c.is_missed_object()) {
            missed += 1;
            self.sizes.push(c.cells);
            self.nearest = self.nearest.min(c.centroid_m[0].hypot(c.centroid_m[1]));
        }
        self.per_frame.push(missed);
    }

    /// Notes whether a frame carried a ROI (once per frame).
    pub(super) fn add_roi(&mut self, df: &DatasetFrame) {
        self.any_roi |= !df.frame.roi_in_ego.is_empty();
    }

    /// The missed-object alarms per frame of the clean frames checked without their ROI (`None`: not checked).
    pub(super) fn set_without_roi(&mut self, without_roi: Option<Vec<u64>>) {
        self.without_roi = without_roi;
    }

    /// Table rows of the clean run: the verdict counts, every flagged box, and a sentence for the claim.
    /// `frames` and `states`: the set's frames and object states; `missed_alarms`: the clean run's total.
    pub(super) fn finish(
        self,
        key: &str,
        roi: &str,
        frames: usize,
        states: usize,
        missed_alarms: u64,
    ) -> (Vec<String>, Vec<Vec<String>>, String) {
        let Self {
            counts,
            not_monitored,
            in_scope,
            zero_points,
            flagged,
            mechanisms,
            mut sizes,
            nearest,
            per_frame,
            without_roi,
            any_roi,
        } = self;
        sizes.sort_unstable();
        // Missed-object alarms per frame and, when the frames carry a ROI, of the same frames checked without it.
        let without_roi = if any_roi { without_roi } else { None };
        let get = |k: &str| counts.get(k).copied().unwrap_or(0);
        let nm = not_monitored.iter().map(|(r, n)| format!("{r} {n}")).collect::<Vec<_>>().join(", ");
        let row = vec![
            key.to_string(),
            frames.to_string(),
            states.to_string(),
            in_scope.to_string(),
            get("consistent").to_string(),
            get("ghost").to_string(),
            get("position_error").to_string(),
            if nm.is_empty() { "none".into() } else { nm },
            zero_points.to_string(),
            if mechanisms.is_empty() {
                "-".into()
            } else {
                mechanisms.iter().map(|(m, n)| format!("{m}: {n}")).collect::<Vec<_>>().join("; ")
            },
            roi.to_string(),
            missed_alarms.to_string(),
            spread(&per_frame),
            without_roi.map_or_else(|| "same".into(), |w| spread(&w)),
            if sizes.is_empty() {
                "-".into()
            } else {
                format!(
                    "{} / {}, {nearest:.1}",
                    sizes.get(sizes.len() / 2).copied().unwrap_or(0),
                    sizes.last().copied().unwrap_or(0)
                )
            },
        ];
        let fa = get("ghost") + get("position_error");
        let claim = format!(
            "{key}: {fa} of {in_scope} clean boxes in scope flagged ({} ghost, {} position error; {}), {missed_alarms} \
             missed-object alarms (ROI: {roi}; per frame, min / median / max: {})",
            get("ghost"),
            get("position_error"),
            mechanisms.iter().map(|(m, n)| format!("{m}: {n}")).collect::<Vec<_>>().join(", "),
            spread(&per_frame)
        );
        (row, flagged, claim)
    }
}

/// A box the clean run flagged: its mechanism and its table row.
fn flagged_row(
    key: &str,
    p: &MonitorParams,
    df: &DatasetFrame,
    rec: &StateRecord,
    clusters: &[ClusterReport],
) -> (&'static str, Vec<String>) {
    let v = rec.report.sensor.verdict;
    let ds_points = df.extras.get(rec.index).and_then(|e| e.num_points);
    let s = &rec.report.sensor;
    let pts = box_points(df, rec.index, p);
    let range = range_of(df, rec.index);
    let cluster = s.cluster.and_then(|k| clusters.get(usize::from(k)));
    let cells = cluster.map_or(0, |c| c.cells);
    let gap = cluster.map(|c| cluster_gap(&region_of(&rec.object, p), c));
    let (mechanism, mut why) = match v {
        SensorVerdict::PositionError if s.eta >= p.tau_tp => (
            "consistent box, unexplained evidence touching it",
            format!(
                "the box is consistent (eta {:.2}) but a conflict cluster of {cells} cells (centroid {:.1} m from \
                 the box) touches its grown region: evidence spilling over the box edge (label smaller than the \
                 object, or an unlabelled object or structure next to it)",
                s.eta,
                s.offset_m[0].hypot(s.offset_m[1])
            ),
        ),
        SensorVerdict::PositionError if gap.is_some_and(|g| g > p.conflict_association_m) => (
            "evidence-free box in the shadow of unexplained evidence",
            format!(
                "too few returns for an occupied cell (eta {:.2}) and the region is hidden ({:.0} % visible) \
                 behind a conflict cluster of {cells} cells ({:.1} m from the region) that no label explains: the monitor \
                 takes the unexplained occluder for the displaced object. Without a region of interest or a \
                 scenery map, unlabelled structures (walls, poles, vegetation) trigger this",
                s.eta,
                100.0 * s.visible_fraction,
                gap.unwrap_or(f32::NAN)
            ),
        ),
        SensorVerdict::PositionError => (
            "evidence-free box with unexplained evidence beside it",
            format!(
                "no occupied cell in the region (eta {:.2}) and unexplained evidence ({cells} cells) within \
                 {:.1} m: the label is offset from its returns, or an unlabelled object stands next to it",
                s.eta, p.conflict_association_m
            ),
        ),
        _ if ds_points == Some(0) => (
            "ghost: no LiDAR point in the box",
            format!(
                "no LiDAR point in the labelled box (dataset count 0) although {:.0} % of its region is visible: \
                 labelled from other frames or sensors, or hidden by something the 2D visibility test does not \
                 model",
                100.0 * s.visible_fraction
            ),
        ),
        _ => match pts {
            Some((_, band)) if band < 2 => (
                "ghost: fewer than 2 returns in the height band",
                format!(
                    "only {band} of the box's points lie in the obstacle band ({:.2} to {:.2} m above the \
                     ground): an occupied cell needs 2 hits (one hit gives p = {:.2} < tau_tp {:.2}); few \
                     returns, a low object, or the ground is not where ground_z_m says",
                    p.min_obstacle_height_m, p.max_obstacle_height_m, p.hit_probability, p.tau_tp
                ),
            ),
            Some((_, band)) => (
                "ghost: returns spread thin",
                format!(
                    "{band} points in the band, spread so that no cell of the region collects 2 hits (eta \
                     {:.2}): sparse returns at range",
                    s.eta
                ),
            ),
            None => ("ghost", format!("no occupied cell in the region (eta {:.2})", s.eta)),
        },
    };
    if range > 0.5 * p.grid_size_m - 5.0 {
        why.push_str("; near the grid edge");
    }
    let row = vec![
        key.to_string(),
        rec.frame.to_string(),
        rec.report.id.to_string(),
        object_label(df, rec.index),
        format!("{range:.1}"),
        ds_points.map_or("n/a".into(), |n| n.to_string()),
        pts.map_or("n/a".into(), |(a, b)| format!("{a} / {b}")),
        format!("{:.2}", s.eta),
        format!("{v:?}"),
        format!("{:.0} %", 100.0 * s.visible_fraction),
        why,
    ];
    (mechanism, row)
}

/// `min / median / max` of counts.
fn spread(v: &[u64]) -> String {
    let mut s = v.to_vec();
    s.sort_unstable();
    match (s.first(), s.get(s.len() / 2), s.last()) {
        (Some(a), Some(m), Some(b)) => format!("{a} / {m} / {b}"),
        _ => "-".into(),
    }
}
