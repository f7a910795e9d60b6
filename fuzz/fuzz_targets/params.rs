//! Parameter TOML: parse, validate, and build a monitor from whatever validates, then check one empty frame.
#![no_main]
use libfuzzer_sys::fuzz_target;
use pmon_monitor::{Frame, Monitor, MonitorParams, Pose2};

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let Ok(params) = toml::from_str::<MonitorParams>(text) else { return };
    if params.validate().is_err() {
        return;
    }
    let Ok(mut m) = Monitor::new(params) else { return };
    let frame = Frame {
        timestamp_s: 0.0,
        world_from_ego: Pose2::default(),
        objects: &[],
        cloud: None,
        roi_in_ego: &[],
        static_in_ego: &[],
    };
    let _ = m.check(&frame);
});
