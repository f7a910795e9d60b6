//! Prints behaviour statistics of a scenario (no LiDAR): object states in the grid, speed, acceleration and turn
//! rate extremes per class, ego travel.
//!
//! `cargo run -p pmon-scenario --release --example scenario_stats -- intersection [seed]`

use std::collections::BTreeMap;

use pmon_scenario::{ScenarioConfig, Simulator};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let name = args.next().unwrap_or_else(|| "intersection".into());
    let seed: u64 = args.next().map(|s| s.parse()).transpose()?.unwrap_or(1);
    let mut cfg = match ScenarioConfig::builtin(&name) {
        Some(c) => c,
        None => ScenarioConfig::from_path(std::path::Path::new(&name))?,
    };
    cfg.seed = seed;
    cfg.lidar.enabled = Some(false);
    let mut sim = Simulator::new(&cfg)?;
    let mut in_grid = 0u64;
    let mut moving = 0u64;
    let mut stats: BTreeMap<&str, (f64, f64, f64, f64, u64)> = BTreeMap::new();
    let mut first = None;
    let mut last = None;
    let mut ids = std::collections::BTreeSet::new();
    let mut on_road_peds = 0u64;
    while let Some(f) = sim.step() {
        in_grid += f.frame.objects.len() as u64;
        for o in f.truth.iter().filter(|o| o.in_grid) {
            if o.parked {
                continue;
            }
            moving += 1;
            ids.insert(o.id);
            let e = stats.entry(o.class.name()).or_insert((0.0, 0.0, 0.0, 0.0, 0));
            e.0 = e.0.max(o.speed_mps);
            e.1 = e.1.max(o.accel_mps2.abs());
            e.2 = e.2.max(o.turn_rate_radps.abs());
            e.3 += o.speed_mps;
            e.4 += 1;
            if o.class.name() == "pedestrian" && o.y_m.abs() < 5.7 && o.x_m.abs() > 12.0 {
                on_road_peds += 1;
            }
        }
        if first.is_none() {
            first = Some(f.ego.clone());
        }
        last = Some(f.ego.clone());
    }
    println!("{name} seed {seed}: object states in grid {in_grid}, moving {moving}, distinct moving ids {}", ids.len());
    for (c, (vmax, amax, wmax, vsum, n)) in &stats {
        println!(
            "  {c:10} n {n:6} mean v {:5.2} max v {vmax:5.2} max |a| {amax:5.2} max |w| {:6.1} deg/s",
            vsum / *n as f64,
            wmax.to_degrees()
        );
    }
    println!("  pedestrian states on the x-road carriageway (mid-block): {on_road_peds}");
    if let (Some(a), Some(b)) = (first, last) {
        println!(
            "  ego from ({:.1}, {:.1}) to ({:.1}, {:.1}), final speed {:.2}",
            a.x_m, a.y_m, b.x_m, b.y_m, b.speed_mps
        );
    }
    Ok(())
}
