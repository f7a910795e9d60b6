//! One simulated frame (agents + 64-beam ray-cast sweep + object list) on one core.
//!
//! `cargo bench -p pmon-scenario --bench lidar` (add `--features parallel` to use all cores).

use divan::Bencher;
use pmon_scenario::{LidarPreset, ScenarioConfig, Simulator};

fn main() {
    divan::main();
}

fn simulator(name: &str, preset: LidarPreset) -> Simulator {
    let Some(mut cfg) = ScenarioConfig::builtin(name) else { panic!("no built-in {name}") };
    cfg.duration_s = 3600.0;
    cfg.lidar.preset = preset;
    match Simulator::new(&cfg) {
        Ok(sim) => sim,
        Err(e) => panic!("{e}"),
    }
}

#[divan::bench(args = ["intersection", "pedestrians"], sample_count = 60, sample_size = 1)]
fn frame_hdl64(bencher: Bencher<'_, '_>, name: &str) {
    let mut sim = simulator(name, LidarPreset::Hdl64);
    bencher.bench_local(|| sim.step());
}

#[divan::bench(args = ["intersection"], sample_count = 60, sample_size = 1)]
fn frame_vlp32(bencher: Bencher<'_, '_>, name: &str) {
    let mut sim = simulator(name, LidarPreset::Vlp32);
    bencher.bench_local(|| sim.step());
}

#[divan::bench(args = ["intersection"], sample_count = 60, sample_size = 1)]
fn frame_without_lidar(bencher: Bencher<'_, '_>, name: &str) {
    let Some(mut cfg) = ScenarioConfig::builtin(name) else { panic!("no built-in {name}") };
    cfg.duration_s = 3600.0;
    cfg.lidar.enabled = Some(false);
    let mut sim = match Simulator::new(&cfg) {
        Ok(sim) => sim,
        Err(e) => panic!("{e}"),
    };
    bencher.bench_local(|| sim.step());
}
