//! `pmon check bag.mcap` on arbitrary bytes: the MCAP reader (mcap crate), the CDR decoding of every message
//! type pmon reads (object lists, PointCloud2, odometry, tf) and the monitor behind them. A bad bag is an
//! error or a listed problem, never a panic or an allocation out of proportion to the input.
#![no_main]
use libfuzzer_sys::fuzz_target;
use pmon_monitor::MonitorParams;
use pmon_ros::bag::{check_bag, BagConfig};

fuzz_target!(|data: &[u8]| {
    let mut frames = 0usize;
    let _ = check_bag(
        std::path::Path::new("fuzz.mcap"),
        data,
        &BagConfig::default(),
        &MonitorParams::default(),
        &mut |_| {
            frames += 1;
            Ok(())
        },
    );
});
