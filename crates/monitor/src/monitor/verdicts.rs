//! The sensor verdicts (`f(o)` with the evidence attribution and the occlusion test; docs/attribution.md, "The
//! rule, step by step", steps 6-9) and the combined verdicts of the last stage, `finish_reports`: per object the
//! sensor verdict from what the attribution found (a cluster, evidence followed, a jump away from evidence that
//! stayed, seen through, a face in front, own evidence, occluded, hidden within its margin, or a ghost), the
//! offset of a `position_error`, what the evidence memory keeps for the next frame (the evidence, the held offset
//! of "Step 8 held over a gap", and where a confirmed track should stand), and the combination with the
//! plausibility verdict. Part of [`Monitor`]; `monitor.rs` runs the stage, and the tests it asks are in
//! `sight.rs`, `memory_steps.rs`, `face.rs` and `attribution.rs`.

use super::attribution::s_eta;
use super::sight::{Through, OCCLUDERS};
use super::*;
use crate::evidence_memory::{Hold, Motion};
use crate::verdict::PositionCause;

impl Monitor {
    /// Sensor verdicts (f(o) with the evidence attribution and the occlusion test) and the combined verdicts.
    pub(super) fn finish_reports(&mut self, frame: &Frame<'_>, cloud: Option<Cloud<'_>>) {
        let tau_tp = self.params.tau_tp;
        self.memory.begin();
        for j in 0..self.reports.len() {
            let Some(scratch) = self.scratch.get(j).copied() else { continue };
            if let ObjectScratch { region: Some(region), cluster, eta_own, sight, own_sum, .. } = scratch {
                // Hidden behind evidence that no object explains and nobody took: that evidence is likely the
                // object itself, displaced (a ghost otherwise).
                let mut cluster = cluster.map(|(k, _)| usize::from(k));
                let mut occluded = false;
                let mut shared = false;
                let mut followed: Option<[f32; 2]> = None;
                let mut released: Option<[f32; 2]> = None;
                let mut sight = sight;
                if cluster.is_none() && eta_own < tau_tp {
                    // Seen again now that the displaced evidence has its objects, if unexplained evidence shadowed
                    // it: evidence attributed to another object hides this one; it does not contradict it.
                    let seen = match sight {
                        Some(s) if s.unexplained_shadow == 0 => s,
                        Some(s) if s.occluders_len <= OCCLUDERS => self.without_attributed(s),
                        _ => self.footprint_sight(j, &region),
                    };
                    sight = Some(seen);
                    let sight = seen;
                    let open = sight.fraction(sight.visible + sight.unexplained_shadow);
                    if sight.contradicted() < self.params.ghost_visible_fraction {
                        occluded = true;
                        // Hidden, but a track whose evidence stood apart from it last frame finds that evidence
                        // again where its offset puts it, inside a neighbour's margin only: the evidence still
                        // follows it (the neighbour's margin hid it from the clusters).
                        if let Some(at) = self.followed_evidence(j, &region) {
                            followed = Some(at);
                            occluded = false;
                        } else if let Some(at) =
                            self.params.release_flagged_claims.then(|| self.released_evidence(j, &region)).flatten()
                        {
                            // With `release_flagged_claims`: a neighbour with its own evidence elsewhere held the
                            // cells in front of this box only by its reported region; they are this box's.
                            released = Some(at);
                            occluded = false;
                        } else if let Some(k) = self.near_cluster_for_far_shadow(&sight, &region) {
                            // With `shadow_gate`: hidden only because the evidence that shadows it stands beyond
                            // the gate; free evidence within the gate is what it may be, displaced.
                            self.give(k, j);
                            cluster = Some(k);
                            occluded = false;
                        }
                    } else if open < self.params.ghost_visible_fraction && s_eta(&self.reports, j) >= tau_tp {
                        // Its place is taken by evidence another object owns and no displaced evidence came its
                        // way: the two cannot be told apart (objects standing in one place, or one box on its
                        // neighbour's evidence). The paper's f(o) stands: the region holds evidence.
                        shared = true;
                    } else if let Some(k) = Self::cluster_of(&self.cluster_spans, &self.queue, sight.occluder)
                        .filter(|&k| self.clusters.get(k).is_some_and(|c| c.in_roi && c.object.is_none()))
                    {
                        if self.occluder_within_gate(k, &region) {
                            self.give(k, j);
                            cluster = Some(k);
                        } else {
                            // With `memory_gate`: evidence beyond the gate cannot be this object; it hides it.
                            occluded = true;
                        }
                    }
                }
                // Confirmed by evidence of its own (occupied cells it owns): what the rules below judge.
                let confirmed_own = eta_own >= tau_tp && own_sum[2] >= 1.0;
                let through = if cluster.is_none() && confirmed_own { self.seen_through(j, &region) } else { None };
                let seen_through = through.is_some();
                // Confirmed by its own evidence, but that evidence's face stands in front of the box along the
                // rays through it, beyond the margin: displaced away from the sensor by less than the cells show.
                let face = if self.params.face_in_front && cluster.is_none() && !seen_through && confirmed_own {
                    self.face_in_front(j, &region)
                } else {
                    None
                };
                // Confirmed by its own evidence, but own returns stand beyond its grown region in the cells it owns
                // (`returns_beyond_cells`, off by default): displaced by less than the cells show.
                let beyond = if self.params.returns_beyond_cells > 0
                    && cluster.is_none()
                    && !seen_through
                    && face.is_none()
                    && confirmed_own
                {
                    self.returns_beyond(j, &region, cloud)
                } else {
                    None
                };
                // Confirmed by evidence of its own, but more of its shape stands in front of it in cells a flagged
                // neighbour holds only by its reported region (`release_to_confirmed`, off by default). Hidden boxes
                // took released cells above; a confirmed one cannot have.
                if self.params.release_flagged_claims
                    && self.params.release_to_confirmed
                    && cluster.is_none()
                    && !seen_through
                    && face.is_none()
                    && beyond.is_none()
                    && confirmed_own
                {
                    released = self.released_to_confirmed(j, &region);
                }
                // Confirmed only by evidence in its margin, which runs on beyond its grown region into a cluster another
                // box took (`evidence_runs_on`, on by default): displaced from the body whose rest went elsewhere.
                let runs_on = self.params.evidence_runs_on
                    && cluster.is_none()
                    && released.is_none()
                    && !seen_through
                    && face.is_none()
                    && beyond.is_none()
                    && confirmed_own
                    && self.evidence_runs_on(j, &region);
                // Confirmed (or hidden) where it is reported, but its evidence stayed where the previous frame's
                // evidence, moved by the object's stated motion, predicts it, and the box jumped away from it.
                let moved = if cluster.is_none()
                    && followed.is_none()
                    && released.is_none()
                    && !runs_on
                    && !seen_through
                    && face.is_none()
                    && beyond.is_none()
                    && (eta_own >= tau_tp || shared || occluded)
                {
                    self.moved_from_evidence(j, &region)
                } else {
                    None
                };
                // A ghost only when no place within its region hides it.
                let hidden = cluster.is_none()
                    && released.is_none()
                    && eta_own < tau_tp
                    && !occluded
                    && !shared
                    && self.hidden_within_margin(j, &region);
                // The offset of a position error: from the evidence at `c` back to the nearest point of the box.
                let back_to_box = |c: [f32; 2]| {
                    let (nx, ny) = region.footprint.nearest_point(c[0], c[1]);
                    [nx - c[0], ny - c[1]]
                };
                // An offset of `depth` metres along the line of sight, away from the sensor (towards it when negative).
                let along_sight = |depth: f32| {
                    let o = self.visibility.origin();
                    let (dx, dy) = (region.footprint.cx - o[0], region.footprint.cy - o[1]);
                    let r = libm::sqrtf(dx * dx + dy * dy).max(1e-3);
                    [depth * dx / r, depth * dy / r]
                };
                // The centre of the occupied cells it owns (asked only of a box that owns one).
                let own_centre = || [own_sum[0] / own_sum[2], own_sum[1] / own_sum[2]];
                let Some(report) = self.reports.get_mut(j) else { continue };
                let s = &mut report.sensor;
                s.eta_own = eta_own;
                if let Some(sight) = sight {
                    s.visible_fraction = sight.fraction(sight.visible);
                }
                s.position_cause = None;
                s.verdict = if let Some(k) = cluster {
                    s.cluster = u16::try_from(k).ok();
                    if let Some(c) = self.clusters.get(k) {
                        s.offset_m = back_to_box(c.centroid_m);
                    }
                    s.position_cause = Some(PositionCause::DisplacedEvidence);
                    SensorVerdict::PositionError
                } else if let Some(c) = followed {
                    s.offset_m = back_to_box(c);
                    s.position_cause = Some(PositionCause::EvidenceFollowed);
                    SensorVerdict::PositionError
                } else if let Some(c) = released {
                    s.offset_m = back_to_box(c);
                    s.position_cause = Some(PositionCause::EvidenceReleased);
                    SensorVerdict::PositionError
                } else if runs_on {
                    // From its own evidence (in the margin) to the box.
                    s.offset_m = back_to_box(own_centre());
                    s.position_cause = Some(PositionCause::EvidenceRunsOn);
                    SensorVerdict::PositionError
                } else if let Some((_, at)) = moved {
                    // From where the evidence puts the box (its remembered offset back from the evidence) to the box.
                    s.offset_m = [region.footprint.cx - at[0], region.footprint.cy - at[1]];
                    s.position_cause = Some(PositionCause::JumpedFromEvidence);
                    SensorVerdict::PositionError
                } else if let Some(through) = through {
                    // Confirmed by evidence in its margin, but the rays prove its footprint empty: the object
                    // stands in front of its evidence, displaced towards the sensor (beyond the paper, whose
                    // checks cannot see this direction).
                    s.offset_m = match through {
                        Through::Majority => back_to_box(own_centre()),
                        // Its near side seen empty: the evidence stands inside the box, `depth_m` behind where a
                        // box in its place would begin; the offset points from there towards the sensor.
                        Through::NearSide { depth_m } => along_sight(-depth_m),
                    };
                    s.position_cause = Some(PositionCause::SeenThrough);
                    SensorVerdict::PositionError
                } else if let Some(depth) = face {
                    // Its face stands `depth` in front of it along the rays: the box is that far behind its evidence.
                    s.offset_m = along_sight(depth);
                    s.position_cause = Some(PositionCause::FaceInFront);
                    SensorVerdict::PositionError
                } else if let Some(at) = beyond {
                    // From its own returns beyond the region back to the box.
                    s.offset_m = back_to_box(at);
                    s.position_cause = Some(PositionCause::ReturnsBeyond);
                    SensorVerdict::PositionError
                } else if eta_own >= tau_tp || shared {
                    SensorVerdict::Consistent
                } else if occluded || hidden {
                    SensorVerdict::NotMonitored(NotMonitoredReason::Occluded)
                } else {
                    SensorVerdict::Ghost
                };
                // What the next frame recalls of this track's evidence.
                let centre = [region.footprint.cx, region.footprint.cy];
                let evidence = match s.verdict {
                    SensorVerdict::PositionError => match s.cluster.and_then(|k| self.clusters.get(usize::from(k))) {
                        Some(c) => Some((EvidenceKind::Displaced, c.centroid_m)),
                        None if followed.is_some() => followed.map(|at| (EvidenceKind::Displaced, at)),
                        None if released.is_some() => released.map(|at| (EvidenceKind::Displaced, at)),
                        None if moved.is_some() => moved.map(|(c, _)| (EvidenceKind::Displaced, c)),
                        // Evidence that runs on: kept as its own (no displaced offset held for step 8; holding one
                        // let the alarm follow neighbours' evidence in the frames after: docs/attribution.md).
                        None if runs_on => Some((EvidenceKind::Own, own_centre())),
                        // Seen through: its own evidence, behind it, is where it stands apart.
                        None if own_sum[2] >= 1.0 => Some((EvidenceKind::Displaced, own_centre())),
                        None => None,
                    },
                    SensorVerdict::Consistent if own_sum[2] >= 1.0 => Some((EvidenceKind::Own, own_centre())),
                    _ => None,
                };
                // The box's centre in the world frame (where a held offset was found, and whether the box stays there).
                let centre_world = || {
                    let (x, y) = frame.world_from_ego.transform_point(f64::from(centre[0]), f64::from(centre[1]));
                    [x, y]
                };
                // One rule for both holds: the offset this frame's alarm found, or the one kept so far (`kept`) while
                // it is at most `keep_s` old and a run of two or more found it.
                let held = |kept: Option<Hold>, keep_s: f64| match evidence {
                    Some((EvidenceKind::Displaced, at)) if s.verdict == SensorVerdict::PositionError => {
                        let flagged_before = matches!(scratch.recalled, Some((EvidenceKind::Displaced, _)));
                        let run_start_t_s = match kept {
                            Some(h) if flagged_before => h.run_start_t_s,
                            _ => frame.timestamp_s,
                        };
                        Some(Hold {
                            offset_m: [at[0] - centre[0], at[1] - centre[1]],
                            alarm_t_s: frame.timestamp_s,
                            run_start_t_s,
                            anchor_world_m: centre_world(),
                        })
                    }
                    _ => kept.filter(|h| h.alarm_t_s > h.run_start_t_s && frame.timestamp_s - h.alarm_t_s <= keep_s),
                };
                // The displaced offset kept for step 8 (`memory_hold_s`): the one this frame's alarm found (its run
                // of alarms in consecutive frames goes on when the track was flagged in the previous frame), or the
                // one kept so far, until `memory_hold_s` after the alarm that found it, and only when alarms found it
                // in at least two frames in a row (a clean track flagged once by a neighbour's evidence keeps none).
                let hold = held(scratch.hold, self.params.memory_hold_s).filter(|_| self.params.memory_hold_s > 0.0);
                // `parked_hold_s`: the same for a parked vehicle, kept that long after the alarm that found it.
                let parked_vehicle = self.params.parked_hold_s > 0.0
                    && frame.objects.get(j).is_some_and(|o| {
                        o.length_m >= crate::params::PARKED_MIN_LENGTH_M
                            && libm::fabsf(o.speed_mps) < crate::params::PARKED_MAX_SPEED_MPS
                    });
                let parked = parked_vehicle.then(|| held(scratch.parked, self.params.parked_hold_s)).flatten();
                // A parked vehicle no test flagged keeps the alarm its held offset found (a run of two or more, the
                // evidence in front of it on its line of sight, within the gate). Not evidence: the memory records
                // what the frame showed (`evidence` above), so a held verdict starts no run.
                if let (
                    Some(h),
                    SensorVerdict::Consistent | SensorVerdict::NotMonitored(NotMonitoredReason::Occluded),
                ) = (parked.filter(|h| h.alarm_t_s < frame.timestamp_s), s.verdict)
                {
                    let off = back_to_box([centre[0] + h.offset_m[0], centre[1] + h.offset_m[1]]);
                    let [ux, uy] = along_sight(1.0);
                    let size = libm::hypotf(off[0], off[1]);
                    // Still where the alarm found it: a box that moved back to its evidence (an error that ended)
                    // has moved by about the offset.
                    let now = centre_world();
                    let drift = libm::hypot(now[0] - h.anchor_world_m[0], now[1] - h.anchor_world_m[1]);
                    if size <= self.params.conflict_association_m
                        && off[0] * ux + off[1] * uy > 0.3 * size
                        && drift <= 0.5 * f64::from(size)
                    {
                        s.verdict = SensorVerdict::PositionError;
                        s.position_cause = Some(PositionCause::HeldWhileParked);
                        s.offset_m = off;
                    }
                }
                // Where a confirmed track should stand next frame: its centre and stated velocity, world frame.
                let motion =
                    matches!(evidence, Some((EvidenceKind::Own, _))).then(|| frame.objects.get(j)).flatten().map(|o| {
                        let pose = &frame.world_from_ego;
                        let [x, y] = centre_world();
                        let heading = f64::from(o.heading_rad) + pose.yaw_rad;
                        let (s, c) = libm::sincos(heading);
                        let v = f64::from(o.speed_mps);
                        // With `jump_from_returns`: from the centre to its own returns' mean, world axes.
                        let returns = scratch.own_returns;
                        let returns_offset_world_m = (self.grid.has_sums() && returns[2] >= 1.0).then(|| {
                            let at = [returns[0] / returns[2] - centre[0], returns[1] / returns[2] - centre[1]];
                            crate::evidence_memory::rotate(at, pose.yaw_rad)
                        });
                        Motion {
                            centre_world_m: [x, y],
                            velocity_world_mps: [(v * c) as f32, (v * s) as f32],
                            cells: own_sum[2],
                            returns_offset_world_m,
                        }
                    });
                // The evidence and the held offset, either or both (nothing is recorded without either).
                self.memory.record_with_holds(
                    report.id,
                    j,
                    frame.timestamp_s,
                    frame.world_from_ego.yaw_rad,
                    evidence.map(|(kind, at)| (kind, [at[0] - centre[0], at[1] - centre[1]])),
                    motion,
                    [hold, parked],
                );
            }
            let Some(report) = self.reports.get_mut(j) else { continue };
            if let Some(m) = self.motion.get(j) {
                report.motion = *m;
            }
            report.verdict = Verdict::combine(report.sensor.verdict, report.motion.verdict);
        }
        self.memory.commit();
    }
}
