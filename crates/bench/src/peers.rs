//! The frames of `pmon bench` for the peers of issue #16: a numpy and a PCL implementation of the grid-plus-box-max
//! part of the sensor checks (`crates/bench/peers/`), which read them, time themselves on them and check their
//! results against pmon's.
//!
//! [`export_peers`] writes one folder per case (`synthetic-64/0.5m` -> `synthetic-64_0.5m`) with:
//!
//! - `case.txt`: lines `key value...`; floats as a decimal and the hex bits of the `f32` (`0.5 0x3f000000`),
//!   which the peers read:
//!   `name NAME`, `cell_size_m`, `inv_cell` (`1 / cell_size_m` in `f32`, as the monitor computes it), `origin_m`
//!   (the grid's lower-left corner on both axes), `cells_per_side N`, `band_lo_m`, `band_hi_m` (the obstacle band
//!   in the ego frame), `sweep FILE` (one per sweep, in order) and `frame SWEEP TX TY TZ BOXES EXPECTED` (one per
//!   frame of the cycle: the sweep's index, the extrinsic's translation as hex bits, and two file names);
//! - `sweep_K.xyz`: the sweep's points in the sensor frame, `N x 3` little-endian `f32`;
//! - `boxes_K.f32`: per object, its grown region `A_o` as `cx, cy, cos, sin, half_length, half_width` (`f32`);
//! - `expected_K.u32`: per object, pmon's maximum hit count over the grid cells that overlap that region with
//!   positive area (`GridGeometry::for_each_cell_overlapping` over the range clipped to the grid), read from the
//!   monitor's grid after `Monitor::check` of the frame. Hit counts saturate at 255 in pmon.
//!
//! The peers compute a subset of the sensor checks: the obstacle band, a count per cell and the per-box maxima
//! (the regions stage's `eta` before it becomes a probability), not the visibility map, the clusters or the
//! verdicts. Every benchmark extrinsic is a translation (the peers apply it as one); a case with a rotation is
//! refused.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use pmon_monitor::{GridGeometry, Monitor, MonitorParams};

use crate::{params, real_sequences, BenchError, BenchOptions, RealSequences, Sequence, SyntheticSpec};

/// One exported case.
#[derive(Clone, Debug, PartialEq)]
pub struct PeerCase {
    /// The case's name in `pmon bench`.
    pub name: String,
    /// Its folder.
    pub dir: PathBuf,
    /// Frames of its cycle.
    pub frames: usize,
    /// Boxes over all frames.
    pub boxes: usize,
}

/// The folder name of a case (`/` -> `_`).
#[must_use]
pub fn case_folder(name: &str) -> String {
    name.replace('/', "_")
}

fn hex(v: f32) -> String {
    format!("{v} {:#010x}", v.to_bits())
}

fn io(path: &Path) -> impl Fn(std::io::Error) -> BenchError + '_ {
    move |e| BenchError::Data(format!("{}: cannot write: {e}", path.display()))
}

fn write_f32(path: &Path, values: impl IntoIterator<Item = f32>) -> Result<(), BenchError> {
    let bytes: Vec<u8> = values.into_iter().flat_map(f32::to_le_bytes).collect();
    std::fs::write(path, bytes).map_err(io(path))
}

/// pmon's maximum hit count over the cells of `geometry` that overlap each object's grown region, after the
/// monitor checked the frame (0 for an object without a region or outside the grid).
#[must_use]
pub fn box_maxima(monitor: &Monitor, objects: &[pmon_monitor::ObjectState]) -> Vec<u32> {
    let grid = monitor.grid();
    let geometry: GridGeometry = grid.geometry;
    objects
        .iter()
        .filter_map(|o| monitor.region_of(o))
        .map(|region| {
            let mut max = 0u32;
            if let Some(range) = geometry.cell_range_clipped(region.grown.aabb()) {
                geometry.for_each_cell_overlapping(&region.grown, range, |i, _, _| {
                    max = max.max(u32::from(grid.hits(i)));
                });
            }
            max
        })
        .collect()
}

/// Writes the peers' frames under `dir` (created): the 0.5 m cases of `pmon bench` that have a cloud
/// (synthetic 64- and 32-beam, and the KITTI, nuScenes and Argoverse 2 sweeps when present), filtered by
/// `opts.only`. Returns the cases written.
///
/// # Errors
/// I/O errors, a real sweep that cannot be read, or an extrinsic with a rotation.
pub fn export_peers(dir: &Path, opts: &BenchOptions) -> Result<Vec<PeerCase>, BenchError> {
    let mut notes = Vec::new();
    let real = if opts.real_data { real_sequences(opts, &mut notes)? } else { RealSequences::default() };
    let syn64 = Sequence::synthetic(&SyntheticSpec::BEAMS_64);
    let syn32 = Sequence::synthetic(&SyntheticSpec::BEAMS_32);
    let mut cases: Vec<(&str, &Sequence)> = vec![("synthetic-64/0.5m", &syn64), ("synthetic-32/0.5m", &syn32)];
    for (name, seq) in [("kitti/0.5m", &real.kitti), ("nuscenes/0.5m", &real.nuscenes), ("av2/0.5m", &real.av2)] {
        if let Some(seq) = seq {
            cases.push((name, seq));
        }
    }
    cases.retain(|(name, _)| opts.only.is_empty() || opts.only.iter().any(|o| name.contains(o.as_str())));
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    let mut out = Vec::new();
    for (name, seq) in cases {
        out.push(export_case(dir, name, seq, opts)?);
    }
    Ok(out)
}

fn export_case(root: &Path, name: &str, seq: &Sequence, opts: &BenchOptions) -> Result<PeerCase, BenchError> {
    let p: MonitorParams = params(0.5, 100.0);
    let mut monitor = Monitor::new(p).map_err(|source| BenchError::Params { case: name.to_string(), source })?;
    monitor.set_rasterizer(opts.rasterizer);
    let dir = root.join(case_folder(name));
    std::fs::create_dir_all(&dir).map_err(io(&dir))?;
    let geometry = GridGeometry::new(p.grid_cells_per_side(), p.cell_size_m);
    let (lo, hi) = p.obstacle_band_m();
    let mut text = String::new();
    let _ = writeln!(text, "name {name}");
    let _ = writeln!(text, "cell_size_m {}", hex(geometry.cell_size_m));
    let _ = writeln!(text, "inv_cell {}", hex(1.0 / geometry.cell_size_m));
    let _ = writeln!(text, "origin_m {}", hex(geometry.origin_m));
    let _ = writeln!(text, "cells_per_side {}", geometry.cells_per_side);
    let _ = writeln!(text, "band_lo_m {}", hex(lo));
    let _ = writeln!(text, "band_hi_m {}", hex(hi));
    for (k, sweep) in seq.sweeps.iter().enumerate() {
        let file = format!("sweep_{k}.xyz");
        write_f32(&dir.join(&file), sweep.points_in_sensor.iter().flatten().copied())?;
        let _ = writeln!(text, "sweep {file}");
    }
    let mut boxes = 0;
    for k in 0..seq.frames.len() {
        let mut roi = Vec::new();
        let Some(frame) = seq.frame_with_roi(k, Sequence::timestamp_s(k), &mut roi) else { continue };
        let Some((cloud, sweep)) = frame.cloud.zip(seq.frames.get(k).and_then(|f| f.sweep)) else { continue };
        let t = cloud.ego_from_sensor;
        if t.rotation != pmon_monitor::Isometry3::IDENTITY.rotation {
            return Err(BenchError::Data(format!("{name}: the peers take translation-only extrinsics")));
        }
        monitor.check(&frame).map_err(|source| BenchError::Frame { case: name.to_string(), source })?;
        let expected = box_maxima(&monitor, frame.objects);
        let regions: Vec<_> = frame.objects.iter().filter_map(|o| monitor.region_of(o)).collect();
        boxes += regions.len();
        let (bfile, efile) = (format!("boxes_{k}.f32"), format!("expected_{k}.u32"));
        write_f32(
            &dir.join(&bfile),
            regions.iter().flat_map(|r| {
                let g = r.grown;
                [g.cx, g.cy, g.cos, g.sin, g.half_length, g.half_width]
            }),
        )?;
        let path = dir.join(&efile);
        std::fs::write(&path, expected.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>()).map_err(io(&path))?;
        let [tx, ty, tz] = t.translation_m.map(|v| format!("{:#010x}", v.to_bits()));
        let _ = writeln!(text, "frame {sweep} {tx} {ty} {tz} {bfile} {efile}");
    }
    let path = dir.join("case.txt");
    std::fs::write(&path, text).map_err(io(&path))?;
    Ok(PeerCase { name: name.to_string(), dir, frames: seq.frames.len(), boxes })
}
