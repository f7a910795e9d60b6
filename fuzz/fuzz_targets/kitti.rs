//! KITTI label lines, calibration files and velodyne point bytes.
#![no_main]
use libfuzzer_sys::fuzz_target;
use pmon_datasets::kitti;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let calib = kitti::parse_calib(&text).ok();
    for line in text.lines().take(1000) {
        for tracking in [false, true] {
            if let (Ok(label), Some(c)) = (kitti::parse_label_line(line, tracking), calib.as_ref()) {
                let _ = kitti::box_in_velodyne(&label, c);
            }
        }
    }
    let _ = pmon_recording::points_from_le_bytes(data, 4);
});
