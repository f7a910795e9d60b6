//! Helpers shared by the crate's unit tests.

/// A seeded xorshift stream (shifts 13, 7, 17) of 64-bit numbers: the state after each step. A zero seed stays
/// zero; callers seed it with an odd number or a constant.
pub(crate) fn xorshift_draws(mut state: u64) -> impl FnMut() -> u64 {
    move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    }
}

/// The same stream as numbers in `[0, 1)` (its top 24 bits each), for the tests' random maps, clusters and legs.
pub(crate) fn unit_draws(state: u64) -> impl FnMut() -> f32 {
    let mut next = xorshift_draws(state);
    move || (next() >> 40) as f32 / (1u64 << 24) as f32
}

/// A monitor with `params` that has checked one frame of `objects` and `points` (sensor frame, extrinsic `t`) at
/// 0.1 s, without a region of interest: the set-up of the tests that then call one stage's scan by hand.
pub(crate) fn monitor_after_one_check(
    params: crate::MonitorParams,
    t: crate::Isometry3,
    points: &[[f32; 3]],
    objects: &[crate::ObjectState],
) -> crate::Monitor {
    let mut m = crate::Monitor::new(params).unwrap();
    let frame = crate::Frame {
        timestamp_s: 0.1,
        world_from_ego: crate::Pose2::default(),
        objects,
        cloud: Some(crate::PointCloud { points_in_sensor: points, ego_from_sensor: t }),
        roi_in_ego: &[],
        static_in_ego: &[],
    };
    m.check(&frame).unwrap();
    m
}
