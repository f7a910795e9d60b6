//! The C API, called as C would call it, gives the core's answers on a simulated recording, frame by frame.
#![allow(unsafe_code, clippy::unwrap_used, clippy::indexing_slicing, clippy::expect_used)]

use std::ffi::CString;

use pmon_capi::ffi::*;
use pmon_monitor::{Monitor, MonitorParams, PositionCause};
use pmon_recording::RecordingReader;

fn text(b: &[u8]) -> String {
    let end = b.iter().position(|c| *c == 0).unwrap_or(b.len());
    String::from_utf8(b[..end].to_vec()).unwrap()
}

#[test]
fn c_api_matches_the_core_on_a_simulated_recording() {
    let dir = tempfile::tempdir().unwrap();
    let mut cfg = pmon_scenario::ScenarioConfig::builtin("pedestrians").unwrap();
    cfg.seed = 7;
    cfg.duration_s = 3.0; // long enough for clusters outside the street's region of interest
    let clean = dir.path().join("clean");
    pmon_scenario::simulate_to_dir(&cfg, &clean, &mut |_, _| {}).unwrap();
    // The first object of every frame from the fifth on displaced 1.5 m along x: position errors, with their causes.
    let reader = RecordingReader::open(&clean).unwrap();
    let displaced = dir.path().join("displaced");
    let meta = pmon_recording::RecordingMeta { frames: 0, ..reader.meta.clone() };
    let mut writer = pmon_recording::RecordingWriter::create(&displaced, meta).unwrap();
    for frame in reader {
        let mut frame = frame.unwrap();
        if frame.index >= 4 {
            if let Some(o) = frame.objects.first_mut() {
                o.x_m += 1.5;
            }
        }
        writer.write_frame(&frame).unwrap();
    }
    writer.finish().unwrap();
    let dir_path = std::env::var_os("PMON_CAPI_RECORDING").map_or_else(|| displaced.clone(), Into::into);
    let path = CString::new(dir_path.to_str().unwrap()).unwrap();
    let mut rec = std::ptr::null_mut();
    let mut mon = std::ptr::null_mut();
    unsafe {
        assert_eq!(pmon_recording_open(path.as_ptr(), &mut rec), PMON_OK);
        assert_eq!(pmon_monitor_new(std::ptr::null(), &mut mon), PMON_OK);
    }
    let mut core = Monitor::new(MonitorParams::default()).unwrap();
    let mut results = vec![unsafe { std::mem::zeroed::<PmonObjectResult>() }; 1024];
    let mut clusters = vec![PmonCluster::default(); 512];
    let (mut frames, mut objects, mut alarms, mut excused, mut causes) = (0, 0, 0, 0, 0);
    for expected in RecordingReader::open(&dir_path).unwrap() {
        let expected = expected.unwrap();
        let mut frame = unsafe { std::mem::zeroed::<PmonFrame>() };
        let mut index = u64::MAX;
        let mut summary = PmonFrameSummary::default();
        unsafe {
            assert_eq!(pmon_recording_next(rec, &mut frame, &mut index), PMON_OK);
            let rc = pmon_monitor_check(
                mon,
                &frame,
                results.as_mut_ptr(),
                results.len(),
                clusters.as_mut_ptr(),
                clusters.len(),
                &mut summary,
            );
            assert_eq!(rc, PMON_OK);
        }
        assert_eq!(index, expected.index);
        let mut polygons = Vec::new();
        let report = core.check(&expected.as_frame(&mut polygons)).unwrap();
        assert_eq!(summary.object_count, report.objects.len());
        for (r, want) in results.iter().zip(report.objects) {
            assert_eq!(r.id, want.id);
            assert_eq!(text(&r.verdict_name), want.verdict.name(), "frame {index} object {}", want.id);
            assert_eq!(text(&r.sensor_text), want.sensor.verdict.to_string(), "frame {index} object {}", want.id);
            assert_eq!(text(&r.motion_text), want.motion.verdict.to_string());
            assert_eq!(r.eta.to_bits(), want.sensor.eta.to_bits());
            assert_eq!(r.position_residual_m.to_bits(), want.motion.position_residual_m.to_bits());
            let cause = want.sensor.position_cause;
            assert_eq!(
                text(&r.position_cause_name),
                cause.map_or("", |c| c.name()),
                "frame {index} object {}",
                want.id
            );
            let code = cause.map_or(0, |c| 1 + PositionCause::ALL.iter().position(|a| *a == c).unwrap() as u32);
            assert_eq!(
                r.position_cause, code,
                "frame {index} object {}: PMON_POSITION_CAUSE_* is 1 + its index",
                want.id
            );
            causes += usize::from(cause.is_some());
            alarms += usize::from(want.verdict.is_alarm());
        }
        assert_eq!(summary.clusters_available, report.clusters.len());
        for (c, want) in clusters.iter().zip(report.clusters).take(summary.cluster_count) {
            assert_eq!((c.in_roi, c.roi_status), (u32::from(want.in_roi), want.roi.code()), "frame {index}");
            assert_eq!(text(&c.roi_name), want.roi.name(), "frame {index}");
            assert_eq!(c.is_outside_roi, u32::from(want.is_outside_roi()), "frame {index}");
            excused += usize::from(want.is_outside_roi());
        }
        assert_eq!(summary.missed_objects, report.missed_objects());
        frames += 1;
        objects += report.objects.len();
    }
    let mut frame = unsafe { std::mem::zeroed::<PmonFrame>() };
    unsafe {
        assert_eq!(pmon_recording_next(rec, &mut frame, std::ptr::null_mut()), PMON_END);
        pmon_recording_free(rec);
        pmon_monitor_free(mon);
    }
    assert!(frames >= 10 && objects > 100, "{frames} frames, {objects} objects");
    assert!(alarms < objects, "every object raised an alarm: the comparison would prove little");
    // The simulated street has a region of interest: some clusters lie outside it.
    assert!(excused > 0, "no cluster outside the region of interest: the reasons were not compared");
    assert!(causes > 0, "no position error: the causes were not compared");
}

#[test]
fn a_parameter_profile_by_name_from_c() {
    let mut mon = std::ptr::null_mut();
    let recall = CString::new("profile:recall").unwrap();
    unsafe {
        assert_eq!(pmon_monitor_new_from_file(recall.as_ptr(), &mut mon), PMON_OK);
        assert!(!mon.is_null());
        pmon_monitor_free(mon);
    }
    let fast = CString::new("profile:fast").unwrap();
    let mut mon = std::ptr::null_mut();
    let mut buf = [0u8; 512];
    unsafe {
        assert_eq!(pmon_monitor_new_from_file(fast.as_ptr(), &mut mon), PMON_ERR_PARAMS);
        assert!(mon.is_null());
        pmon_last_error(buf.as_mut_ptr().cast(), buf.len());
    }
    let message = text(&buf);
    assert!(message.contains("unknown parameter profile `fast`") && message.contains("profile:recall"), "{message}");
}
