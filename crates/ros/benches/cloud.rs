//! What a 120,000-point `sensor_msgs/PointCloud2` costs before the monitor sees it: CDR decoding (through
//! `cdr-encoding`) and the field walk to points. Run: `cargo bench -p pmon-ros`.

use pmon_ros::cdr::{decode, encode};
use pmon_ros::msg::{Header, PointCloud2};
use pmon_ros::pointcloud::{from_points, to_points};

fn main() {
    divan::main();
}

fn cloud_bytes(n: usize) -> Vec<u8> {
    let pts: Vec<[f32; 3]> = (0..n)
        .map(|i| {
            let a = i as f32 * 0.001;
            [20.0 * a.cos(), 20.0 * a.sin(), (i % 32) as f32 * 0.1 - 1.5]
        })
        .collect();
    encode(&from_points(Header::default(), &pts)).unwrap_or_default()
}

#[divan::bench]
fn decode_cdr_120k(b: divan::Bencher<'_, '_>) {
    let bytes = cloud_bytes(120_000);
    b.bench(|| decode::<PointCloud2>(divan::black_box(&bytes)).map(|c| c.data.len()).unwrap_or(0));
}

#[divan::bench]
fn to_points_120k(b: divan::Bencher<'_, '_>) {
    let Ok(cloud) = decode::<PointCloud2>(&cloud_bytes(120_000)) else { return };
    b.bench(|| to_points(divan::black_box(&cloud)).map(|p| p.points.len()).unwrap_or(0));
}
