//! Where each track's LiDAR evidence stood in the previous frame, relative to the object: its own evidence
//! (inside its region), or evidence displaced outside it (a position error). The sensor checks use it so that
//! evidence follows its object from frame to frame (beyond the paper, whose checks look at one frame):
//!
//! - a track whose evidence stood apart from it keeps that offset while the error persists, so its evidence is
//!   found again where the offset predicts it, before any neighbour can claim it;
//! - a track whose own evidence is where it was (relative to the object) is not blamed for evidence next to it.
//!
//! Offsets are kept in world-frame axes, so that the ego vehicle turning does not turn them. Fixed capacity, two
//! buffers swapped each frame, sorted by id in place: no allocation per frame.

use alloc::vec::Vec;

use crate::frame::Pose2;

/// What a track's evidence was in the previous frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum EvidenceKind {
    /// Its own evidence, inside its region (the object was confirmed).
    Own,
    /// Evidence outside its region attributed to it (a position error).
    Displaced,
}

#[derive(Clone, Copy, Debug)]
struct Entry {
    id: u64,
    /// Input order within its frame: makes the sort by id deterministic when ids repeat.
    seq: u32,
    t_s: f64,
    offset_world_m: [f32; 2],
    /// `None` for an entry that keeps a held offset only.
    kind: Option<EvidenceKind>,
    /// The object's reported centre (world frame, metres), its velocity over ground as the object list stated it
    /// (world axes, m/s), and the number of occupied cells of its own evidence: where the evidence of an object
    /// that moves as it says should stand in the next frame, and how much of it there was.
    motion: Option<Motion>,
    /// The id appeared more than once in its frame: its entry is not used.
    duplicate: bool,
    /// A displaced offset found by alarms (world axes), kept beside the evidence (params key `memory_hold_s`).
    hold: Option<Hold>,
    /// The same, kept for a parked vehicle (params key `parked_hold_s`).
    parked: Option<Hold>,
}

/// The displaced offsets a track keeps: for step 8 (`memory_hold_s`) and for a parked vehicle (`parked_hold_s`).
pub(crate) type Holds = [Option<Hold>; 2];

/// A displaced offset found by alarms, and when: kept over frames without an alarm (the params key
/// `memory_hold_s`) so that step 8 can still find the track's evidence where it puts it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Hold {
    /// From the object's centre to its displaced evidence, metres: world axes in the memory, the current ego frame's
    /// axes once recalled.
    pub(crate) offset_m: [f32; 2],
    /// The time of the last alarm that found the offset.
    pub(crate) alarm_t_s: f64,
    /// When the run of alarms in consecutive frames that ended at `alarm_t_s` began.
    pub(crate) run_start_t_s: f64,
    /// The box's centre (world frame, metres) at `alarm_t_s`: `parked_hold_s` holds only a box still standing there.
    pub(crate) anchor_world_m: [f64; 2],
}

impl Hold {
    fn is_finite(&self) -> bool {
        self.offset_m.iter().all(|v| v.is_finite())
            && self.alarm_t_s.is_finite()
            && self.run_start_t_s.is_finite()
            && self.anchor_world_m.iter().all(|v| v.is_finite())
    }
}

/// A track's reported centre and velocity (world frame) and how many occupied cells its own evidence held, in the
/// frame it was recorded in.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Motion {
    pub(crate) centre_world_m: [f64; 2],
    pub(crate) velocity_world_mps: [f32; 2],
    pub(crate) cells: f32,
    /// With the params key `jump_from_returns`: the offset from the reported centre to the mean of the returns
    /// in its own evidence's cells (world axes, metres).
    pub(crate) returns_offset_world_m: Option<[f32; 2]>,
}

/// The evidence offsets of the previous frame's tracks.
#[derive(Debug)]
pub(crate) struct EvidenceMemory {
    prev: Vec<Entry>,
    next: Vec<Entry>,
}

/// `R(yaw) v`.
pub(crate) fn rotate(v: [f32; 2], yaw_rad: f64) -> [f32; 2] {
    let (s, c) = libm::sincos(yaw_rad);
    let (x, y) = (f64::from(v[0]), f64::from(v[1]));
    [(c * x - s * y) as f32, (s * x + c * y) as f32]
}

impl EvidenceMemory {
    /// Room for `capacity` tracks per frame.
    pub(crate) fn new(capacity: usize) -> Self {
        Self { prev: Vec::with_capacity(capacity), next: Vec::with_capacity(capacity) }
    }

    /// Forgets everything.
    pub(crate) fn clear(&mut self) {
        self.prev.clear();
        self.next.clear();
    }

    /// The previous frame's evidence of track `id`, as `(kind, offset from the object's centre in the current ego
    /// frame)`, if that frame was `0 < t_s - t_prev <= max_dt_s` ago and the id was unique in it.
    #[cfg(test)]
    pub(crate) fn recall(&self, id: u64, t_s: f64, yaw_rad: f64, max_dt_s: f64) -> Option<(EvidenceKind, [f32; 2])> {
        self.recall_with_hold(id, t_s, yaw_rad, max_dt_s).0
    }

    /// [`EvidenceMemory::recall`], and the displaced offsets track `id` keeps (current ego frame's axes) under the same
    /// conditions: for step 8 (found by an alarm in the previous frame, or held since: `memory_hold_s`) and for a
    /// parked vehicle (`parked_hold_s`). One look-up for all three.
    pub(crate) fn recall_with_hold(
        &self,
        id: u64,
        t_s: f64,
        yaw_rad: f64,
        max_dt_s: f64,
    ) -> (Option<(EvidenceKind, [f32; 2])>, Holds) {
        let Some(e) = self.recallable(id, t_s, yaw_rad, max_dt_s) else { return (None, [None, None]) };
        let to_ego = |h: Option<Hold>| h.map(|h| Hold { offset_m: rotate(h.offset_m, -yaw_rad), ..h });
        (e.kind.map(|k| (k, rotate(e.offset_world_m, -yaw_rad))), [to_ego(e.hold), to_ego(e.parked)])
    }

    /// The held offset alone ([`EvidenceMemory::recall_with_hold`]).
    #[cfg(test)]
    pub(crate) fn recall_hold(&self, id: u64, t_s: f64, yaw_rad: f64, max_dt_s: f64) -> Option<Hold> {
        self.recall_with_hold(id, t_s, yaw_rad, max_dt_s).1[0]
    }

    /// The previous frame's entry of track `id`, if that frame was `0 < t_s - t_prev <= max_dt_s` ago, the id was
    /// unique in it and the ego yaw is finite.
    fn recallable(&self, id: u64, t_s: f64, yaw_rad: f64, max_dt_s: f64) -> Option<&Entry> {
        let i = self.prev.binary_search_by_key(&id, |e| e.id).ok()?;
        let e = self.prev.get(i)?;
        let dt = t_s - e.t_s;
        (!e.duplicate && dt > 0.0 && dt <= max_dt_s && yaw_rad.is_finite()).then_some(e)
    }

    /// Where track `id`'s centre should stand now (current ego frame, metres) if it moved as the previous frame's
    /// object list said (its centre then, plus its velocity times the time step), how many occupied cells its
    /// own evidence held then, and (when recorded) the offset from its centre to its returns' mean then, in the
    /// current ego frame's axes; `None` under the same conditions as [`EvidenceMemory::recall`], or when the previous
    /// frame recorded no motion for it (its evidence was not its own).
    pub(crate) fn predicted_centre(
        &self,
        id: u64,
        t_s: f64,
        world_from_ego: &Pose2,
        max_dt_s: f64,
    ) -> Option<([f32; 2], f32, Option<[f32; 2]>)> {
        let i = self.prev.binary_search_by_key(&id, |e| e.id).ok()?;
        let e = self.prev.get(i)?;
        let m = e.motion?;
        let dt = t_s - e.t_s;
        if e.duplicate || !(dt > 0.0 && dt <= max_dt_s) || !world_from_ego.is_finite() {
            return None;
        }
        let w = [
            m.centre_world_m[0] + f64::from(m.velocity_world_mps[0]) * dt - world_from_ego.x_m,
            m.centre_world_m[1] + f64::from(m.velocity_world_mps[1]) * dt - world_from_ego.y_m,
        ];
        let (s, c) = libm::sincos(world_from_ego.yaw_rad);
        let p = [(c * w[0] + s * w[1]) as f32, (-s * w[0] + c * w[1]) as f32];
        let returns = m.returns_offset_world_m.map(|r| rotate(r, -world_from_ego.yaw_rad));
        p.iter().all(|v| v.is_finite()).then_some((p, m.cells, returns))
    }

    /// Starts recording a frame.
    pub(crate) fn begin(&mut self) {
        self.next.clear();
    }

    /// Records track `id`'s evidence offset (ego frame) in the frame being recorded. Non-finite values and
    /// entries beyond the capacity are not recorded.
    #[cfg(test)]
    pub(crate) fn record(
        &mut self,
        id: u64,
        seq: usize,
        t_s: f64,
        yaw_rad: f64,
        (kind, offset_ego_m): (EvidenceKind, [f32; 2]),
        motion: Option<Motion>,
    ) {
        self.record_with_holds(id, seq, t_s, yaw_rad, Some((kind, offset_ego_m)), motion, [None, None]);
    }

    /// [`EvidenceMemory::record`] of the evidence, if any, and of the displaced offsets found by alarms, if any
    /// (`[hold, parked]`, ego frame: for step 8, `memory_hold_s`, and for a parked vehicle, `parked_hold_s`). Nothing
    /// is recorded without evidence or a held offset.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn record_with_holds(
        &mut self,
        id: u64,
        seq: usize,
        t_s: f64,
        yaw_rad: f64,
        evidence: Option<(EvidenceKind, [f32; 2])>,
        motion: Option<Motion>,
        [hold, parked]: Holds,
    ) {
        let to_world =
            |h: Option<Hold>| h.map(|h| Hold { offset_m: rotate(h.offset_m, yaw_rad), ..h }).filter(Hold::is_finite);
        let (hold, parked) = (to_world(hold), to_world(parked));
        let (kind, offset_world_m) = match evidence {
            Some((kind, offset_ego_m)) => (Some(kind), rotate(offset_ego_m, yaw_rad)),
            None => (None, [0.0; 2]),
        };
        if !(t_s.is_finite() && offset_world_m.iter().all(|v| v.is_finite()))
            || (kind.is_none() && hold.is_none() && parked.is_none())
            || self.next.len() >= self.next.capacity()
        {
            return;
        }
        let seq = u32::try_from(seq).unwrap_or(u32::MAX);
        let motion = motion.filter(|m| {
            m.centre_world_m.iter().all(|v| v.is_finite())
                && m.velocity_world_mps.iter().all(|v| v.is_finite())
                && m.cells.is_finite()
        });
        let motion = motion.map(|m| Motion {
            returns_offset_world_m: m.returns_offset_world_m.filter(|r| r.iter().all(|v| v.is_finite())),
            ..m
        });
        self.next.push(Entry { id, seq, t_s, offset_world_m, kind, motion, duplicate: false, hold, parked });
    }

    /// Ends the frame: its records become the memory the next frame recalls.
    pub(crate) fn commit(&mut self) {
        self.next.sort_unstable_by_key(|e| (e.id, e.seq));
        let mut i = 1;
        while i < self.next.len() {
            let same = self.next.get(i - 1).map(|e| e.id) == self.next.get(i).map(|e| e.id);
            if same {
                for k in [i - 1, i] {
                    if let Some(e) = self.next.get_mut(k) {
                        e.duplicate = true;
                    }
                }
            }
            i += 1;
        }
        core::mem::swap(&mut self.prev, &mut self.next);
        self.next.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offsets_turn_with_the_ego_and_expire() {
        let mut m = EvidenceMemory::new(4);
        m.begin();
        m.record(7, 0, 1.0, core::f64::consts::FRAC_PI_2, (EvidenceKind::Displaced, [1.0, 0.0]), None);
        m.commit();
        // The ego turned back to yaw 0: the offset, along ego y before, is along world y, so ego y now.
        let (kind, o) = m.recall(7, 1.1, 0.0, 0.5).unwrap();
        assert_eq!(kind, EvidenceKind::Displaced);
        assert!(o[0].abs() < 1e-6 && (o[1] - 1.0).abs() < 1e-6, "{o:?}");
        assert!(m.recall(7, 1.0, 0.0, 0.5).is_none(), "zero time step");
        assert!(m.recall(7, 1.6, 0.0, 0.5).is_none(), "too old");
        assert!(m.recall(8, 1.1, 0.0, 0.5).is_none(), "unknown id");
    }

    #[test]
    fn a_held_offset_is_kept_beside_the_evidence_and_alone() {
        let mut m = EvidenceMemory::new(4);
        let hold = Hold { offset_m: [2.0, 0.0], alarm_t_s: 1.0, run_start_t_s: 0.9, anchor_world_m: [5.0, 0.0] };
        m.begin();
        // Beside own evidence, and alone (no evidence this frame), the ego turned by 90 degrees.
        m.record_with_holds(7, 0, 1.1, 0.0, Some((EvidenceKind::Own, [0.1, 0.0])), None, [Some(hold), None]);
        m.record_with_holds(8, 1, 1.1, core::f64::consts::FRAC_PI_2, None, None, [Some(hold), None]);
        m.record_with_holds(9, 2, 1.1, 0.0, None, None, [None, None]);
        m.record_with_holds(10, 3, 1.1, 0.0, None, None, [Some(Hold { alarm_t_s: f64::NAN, ..hold }), None]);
        m.commit();
        assert_eq!(m.recall(7, 1.2, 0.0, 0.5), Some((EvidenceKind::Own, [0.1, 0.0])));
        assert_eq!(m.recall_hold(7, 1.2, 0.0, 0.5), Some(hold));
        assert_eq!(m.recall(8, 1.2, 0.0, 0.5), None, "a held offset alone is no evidence");
        let h = m.recall_hold(8, 1.2, 0.0, 0.5).unwrap();
        assert!(h.offset_m[0].abs() < 1e-6 && (h.offset_m[1] - 2.0).abs() < 1e-6, "turned with the ego: {h:?}");
        assert!(m.recall_hold(9, 1.2, 0.0, 0.5).is_none() && m.recall(9, 1.2, 0.0, 0.5).is_none(), "nothing kept");
        assert!(m.recall_hold(10, 1.2, 0.0, 0.5).is_none(), "a NaN time is never recorded");
        assert!(m.recall_hold(7, 1.8, 0.0, 0.5).is_none(), "too old");
    }

    #[test]
    fn duplicate_ids_are_not_recalled() {
        let mut m = EvidenceMemory::new(4);
        m.begin();
        m.record(3, 0, 0.0, 0.0, (EvidenceKind::Own, [1.0, 0.0]), None);
        m.record(3, 1, 0.0, 0.0, (EvidenceKind::Own, [2.0, 0.0]), None);
        m.record(4, 2, 0.0, 0.0, (EvidenceKind::Own, [f32::NAN, 0.0]), None);
        m.commit();
        assert!(m.recall(3, 0.1, 0.0, 0.5).is_none());
        assert!(m.recall(4, 0.1, 0.0, 0.5).is_none(), "a NaN offset is never recorded");
    }

    #[test]
    fn the_predicted_centre_moves_with_the_object_and_the_ego() {
        let mut m = EvidenceMemory::new(4);
        m.begin();
        let motion = Motion {
            centre_world_m: [110.0, 50.0],
            velocity_world_mps: [10.0, 0.0],
            cells: 6.0,
            returns_offset_world_m: Some([-0.4, 0.1]),
        };
        m.record(5, 0, 2.0, 0.0, (EvidenceKind::Own, [0.5, 0.0]), Some(motion));
        m.record(6, 1, 2.0, 0.0, (EvidenceKind::Own, [0.5, 0.0]), None);
        m.commit();
        // 0.1 s later the object is at (111, 50) in the world; the ego stands at (100, 50), turned by 90 degrees.
        let pose = Pose2 { x_m: 100.0, y_m: 50.0, yaw_rad: core::f64::consts::FRAC_PI_2 };
        let (p, cells, returns) = m.predicted_centre(5, 2.1, &pose, 0.5).unwrap();
        assert!((p[0] - 0.0).abs() < 1e-4 && (p[1] + 11.0).abs() < 1e-4, "{p:?}");
        assert!((cells - 6.0).abs() < 1e-6);
        // The returns' offset turns with the ego like the centre: world (-0.4, 0.1) is ego (0.1, 0.4).
        let r = returns.unwrap();
        assert!((r[0] - 0.1).abs() < 1e-5 && (r[1] - 0.4).abs() < 1e-5, "{r:?}");
        assert!(m.predicted_centre(6, 2.1, &pose, 0.5).is_none(), "no motion recorded");
        assert!(m.predicted_centre(5, 2.7, &pose, 0.5).is_none(), "too old");
        let bad = Pose2 { x_m: f64::NAN, ..pose };
        assert!(m.predicted_centre(5, 2.1, &bad, 0.5).is_none(), "no pose, no prediction");
    }
}
