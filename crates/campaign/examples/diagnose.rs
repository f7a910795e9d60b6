//! Breaks down the monitor's verdicts on injected objects for one fault (a development aid):
//! `cargo run --release -p pmon-campaign --example diagnose -- RECORDING MAGNITUDE_M DIRECTION`
//! where DIRECTION is away, towards or random; `REACH=1.5` sets `conflict_association_m`. Writes the injected
//! frames to /tmp/diagnose-injected for `pmon view`.
use std::collections::BTreeMap;

use pmon_campaign::{Direction, Fault, InjectionConfig, Injector};
use pmon_monitor::{Monitor, MonitorParams};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let path = args.get(1).ok_or("usage: diagnose RECORDING MAGNITUDE_M DIRECTION")?;
    let magnitude_m: f32 = args.get(2).map_or(Ok(1.0), |s| s.parse())?;
    let direction = match args.get(3).map_or("away", String::as_str) {
        "towards" => Direction::Towards,
        "random" => Direction::Random,
        _ => Direction::Away,
    };
    let (_, frames) = pmon_recording::read_recording(std::path::Path::new(path))?;
    let reach: f32 = std::env::var("REACH")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(MonitorParams::default().conflict_association_m);
    let cells: f32 = std::env::var("CELLS").ok().and_then(|v| v.parse().ok()).unwrap_or(0.5);
    let params = MonitorParams { conflict_association_m: reach, cell_size_m: cells, ..MonitorParams::default() };
    let mut monitor = Monitor::new(params)?;
    let mut injector = Injector::new(InjectionConfig::new(Fault::PermanentPosition { magnitude_m, direction }, 7));
    let out = std::path::Path::new("/tmp/diagnose-injected");
    let mut writer =
        pmon_recording::RecordingWriter::create(out, pmon_recording::RecordingMeta::new("injected", path.as_str()))?;
    let mut shown = 0;
    let mut clean_monitor = Monitor::new(params)?;
    let mut misses: BTreeMap<String, u64> = BTreeMap::new();
    let mut by: BTreeMap<String, u64> = BTreeMap::new();
    let mut clean: BTreeMap<String, u64> = BTreeMap::new();
    for (k, f) in frames.iter().enumerate() {
        let mut f = f.clone();
        let inj = injector.apply(k as u64, &mut f.objects);
        let mut roi = Vec::new();
        let view = f.as_frame(&mut roi);
        let confirmed: Vec<bool> = {
            let mut croi = Vec::new();
            let cview = frames[k].as_frame(&mut croi);
            clean_monitor.check(&cview)?.objects.iter().map(|r| r.sensor.eta_own >= 0.8).collect()
        };
        if std::env::var("PMON_DEBUG").is_ok() {
            eprintln!("FRAME {k}");
        }
        let rep = monitor.check(&view)?;
        for (i, r) in rep.objects.iter().enumerate() {
            let injected = inj.iter().any(|x| x.index as usize == i);
            let alarm = matches!(
                r.sensor.verdict,
                pmon_monitor::SensorVerdict::PositionError | pmon_monitor::SensorVerdict::Ghost
            );
            if !injected || !confirmed.get(i).copied().unwrap_or(false) || alarm {
                continue;
            }
            let Some(region) = clean_monitor.region_of(&f.objects[i]) else { continue };
            let mut near: Vec<String> = rep
                .clusters
                .iter()
                .filter(|c| c.in_roi)
                .map(|c| (region.grown.distance(c.centroid_m[0], c.centroid_m[1]), c))
                .filter(|(d, _)| *d < 2.5)
                .map(|(d, c)| {
                    let who = match c.object {
                        None => "free".to_string(),
                        Some(o) => format!(
                            "{}:{}",
                            if inj.iter().any(|x| x.index == o) { "inj" } else { "CLEAN" },
                            format!("{:?}", rep.objects[o as usize].sensor.verdict).chars().take(8).collect::<String>()
                        ),
                    };
                    format!("{:.1}{}", (d * 2.0).round() / 2.0, who)
                })
                .collect();
            near.sort();
            // Is the object's true place (clean state) inside another object's region?
            let truth = &frames[k].objects[i];
            let covered = f.objects.iter().enumerate().any(|(m, o)| {
                m != i && clean_monitor.region_of(o).is_some_and(|r| r.grown.distance(truth.x_m, truth.y_m) < 0.3)
            });
            let key = format!(
                "{:?} truth_covered{} own{} vis{:.1} near[{}]",
                u8::from(covered),
                r.sensor.verdict,
                u8::from(r.sensor.eta_own >= 0.8),
                r.sensor.visible_fraction,
                near.first().cloned().unwrap_or_default()
            );
            if std::env::var("PMON_DEBUG").is_ok() {
                eprintln!("MISS obj {i} {key}");
            }
            *misses.entry(key).or_default() += 1;
        }
        writer.write_frame(&f)?;
        for (i, r) in rep.objects.iter().enumerate() {
            let injected = inj.iter().any(|x| x.index as usize == i);
            let o = &f.objects[i];
            let range = o.x_m.hypot(o.y_m);
            let key = format!(
                "{:<11} {:>2}0 m {:?} {} {}",
                o.class.name(),
                (range / 10.0) as u32,
                r.sensor.verdict,
                if r.sensor.eta >= 0.8 { "eta>=tau" } else { "eta<tau" },
                if r.sensor.eta_own >= 0.8 { "own>=tau" } else { "own<tau" }
            );
            if injected
                && shown < 6
                && range > 8.0
                && range < 25.0
                && matches!(r.sensor.verdict, pmon_monitor::SensorVerdict::NotMonitored(_))
            {
                shown += 1;
                println!(
                    "example: frame {k} object {} at ({:.1}, {:.1}) {:?} eta {:.2} vis {:.2}",
                    o.id, o.x_m, o.y_m, r.sensor.verdict, r.sensor.eta, r.sensor.visible_fraction
                );
            }
            *(if injected { &mut by } else { &mut clean }).entry(key).or_default() += 1;
        }
    }
    writer.finish()?;
    let tot = |m: &BTreeMap<String, u64>, f: &dyn Fn(&str) -> bool| {
        m.iter().filter(|(k, _)| f(k)).map(|(_, v)| v).sum::<u64>()
    };
    let alarm = |k: &str| k.contains("PositionError") || k.contains("Ghost");
    let inj_all = tot(&by, &|k| !k.contains("OutsideGrid"));
    println!(
        "SUMMARY reach {reach}: injected detected {}/{} ; clean alarms {}/{}",
        tot(&by, &alarm),
        inj_all,
        tot(&clean, &alarm),
        tot(&clean, &|k| !k.contains("OutsideGrid"))
    );
    println!("-- injected");
    for (k, v) in &by {
        println!("{v:>6}  {k}");
    }
    println!("-- verifiable misses");
    let mut m: Vec<_> = misses.iter().collect();
    m.sort_by(|a, b| b.1.cmp(a.1));
    for (k, v) in m.iter().take(40) {
        println!("{v:>6}  {k}");
    }
    println!("-- clean");
    for (k, v) in &clean {
        println!("{v:>6}  {k}");
    }
    Ok(())
}
