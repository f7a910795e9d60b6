//! The frames exported for the numpy and PCL peers (`pmon bench --export-peers`) hold what the peers need, and
//! pmon's per-box maxima equal those of the peers' algorithm (band, count per cell, maximum over the cells that
//! overlap each box, every cell of the grid tested), done here in Rust from the exported files alone.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::Path;

use pmon_bench::peers::{case_folder, export_peers};
use pmon_bench::BenchOptions;
use pmon_monitor::geometry::OrientedRect;

fn bits(hex: &str) -> f32 {
    f32::from_bits(u32::from_str_radix(hex.trim_start_matches("0x"), 16).unwrap())
}

fn f32s(path: &Path) -> Vec<f32> {
    std::fs::read(path).unwrap().chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect()
}

#[test]
fn exported_frames_reproduce_pmons_box_maxima() {
    let dir = tempfile::tempdir().unwrap();
    let opts = BenchOptions { real_data: false, only: vec!["synthetic-32".into()], ..BenchOptions::default() };
    let cases = export_peers(dir.path(), &opts).unwrap();
    assert_eq!(cases.len(), 1);
    assert_eq!((cases[0].name.as_str(), cases[0].frames, cases[0].boxes), ("synthetic-32/0.5m", 6, 180));
    let case = dir.path().join(case_folder("synthetic-32/0.5m"));
    assert_eq!(cases[0].dir, case);

    let text = std::fs::read_to_string(case.join("case.txt")).unwrap();
    let value = |key: &str| {
        let line = text.lines().find(|l| l.starts_with(&format!("{key} "))).unwrap();
        bits(line.split_whitespace().nth(2).unwrap())
    };
    let (cell, inv, origin, lo, hi) =
        (value("cell_size_m"), value("inv_cell"), value("origin_m"), value("band_lo_m"), value("band_hi_m"));
    let n: u32 = text.lines().find_map(|l| l.strip_prefix("cells_per_side ")).unwrap().parse().unwrap();
    assert_eq!((cell, n, origin), (0.5, 200, -50.0));
    let sweeps: Vec<Vec<f32>> =
        text.lines().filter_map(|l| l.strip_prefix("sweep ")).map(|f| f32s(&case.join(f))).collect();
    assert_eq!(sweeps.len(), 6);
    assert!(sweeps.iter().all(|s| s.len() == 3 * 34_720));

    let mut frames = 0;
    let mut nonzero = 0;
    for line in text.lines().filter_map(|l| l.strip_prefix("frame ")) {
        let f: Vec<&str> = line.split_whitespace().collect();
        let sweep = &sweeps[f[0].parse::<usize>().unwrap()];
        let t = [bits(f[1]), bits(f[2]), bits(f[3])];
        let mut counts = vec![0u32; (n * n) as usize];
        for p in sweep.chunks_exact(3) {
            let q = [p[0] + t[0], p[1] + t[1], p[2] + t[2]];
            if !(q.iter().all(|v| v.is_finite()) && q[2] >= lo && q[2] <= hi) {
                continue;
            }
            let (fx, fy) = ((q[0] - origin) * inv, (q[1] - origin) * inv);
            if fx >= 0.0 && fx < n as f32 && fy >= 0.0 && fy < n as f32 {
                counts[(fy as u32 * n + fx as u32) as usize] += 1;
            }
        }
        let boxes = f32s(&case.join(f[4]));
        let expected: Vec<u32> = std::fs::read(case.join(f[5]))
            .unwrap()
            .chunks_exact(4)
            .map(|c| u32::from_le_bytes(c.try_into().unwrap()))
            .collect();
        assert_eq!(boxes.len(), 6 * expected.len());
        for (b, &want) in boxes.chunks_exact(6).zip(&expected) {
            let rect = OrientedRect { cx: b[0], cy: b[1], cos: b[2], sin: b[3], half_length: b[4], half_width: b[5] };
            let mut max = 0;
            for iy in 0..n {
                let cy = origin + (iy as f32 + 0.5) * cell;
                for ix in 0..n {
                    let cx = origin + (ix as f32 + 0.5) * cell;
                    if rect.overlaps_square(cx, cy, 0.5 * cell) {
                        max = max.max(counts[(iy * n + ix) as usize].min(255));
                    }
                }
            }
            assert_eq!(max, want, "frame {line}: box {b:?}");
            nonzero += usize::from(want > 0);
        }
        frames += 1;
    }
    assert_eq!(frames, 6);
    assert!(nonzero > 100, "most boxes hold evidence: {nonzero}");
}
