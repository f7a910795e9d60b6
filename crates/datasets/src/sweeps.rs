//! Reading a dataset's LiDAR sweeps one frame at a time: [`open_deferred`] reads everything but the sweeps (the
//! objects, poses, region of interest and notes, as [`crate::open_with`] gives them) and returns a
//! [`DeferredSweeps`] that reads frame `i`'s sweep when asked, with the bits [`crate::open_with`] would have put in
//! `frame.cloud` (the same file reader, the same extrinsic, the same levelling). A campaign then holds one sweep
//! at a time instead of the whole log's (`pmon evaluate`'s sensor tasks, docs/campaigns.md).

use std::path::PathBuf;

use pmon_monitor::Isometry3;
use pmon_recording::OwnedCloud;

use crate::av2::Av2Sweeps;
use crate::ground::{level_cloud, SectorGroundOptions};
use crate::{av2, commonroad, kitti, nuscenes, Dataset, DatasetError, ReadOptions, Spec};

/// The file format of a sweep read by [`SweepFile::read`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum SweepFormat {
    /// KITTI Velodyne `.bin`: N x 4 little-endian f32.
    KittiVelodyne,
    /// nuScenes `.pcd.bin`: N x 5 little-endian f32.
    NuScenesPcdBin,
}

/// One frame's sweep file and the extrinsic its points are given with.
#[derive(Clone, Debug)]
pub(crate) struct SweepFile {
    pub(crate) path: PathBuf,
    pub(crate) format: SweepFormat,
    pub(crate) ego_from_sensor: Isometry3,
}

impl SweepFile {
    /// Reads the sweep: the code every reader uses for `frame.cloud`, deferred or not.
    pub(crate) fn read(&self) -> Result<OwnedCloud, DatasetError> {
        let points_in_sensor = match self.format {
            SweepFormat::KittiVelodyne => kitti::read_velodyne(&self.path)?,
            SweepFormat::NuScenesPcdBin => nuscenes::read_pcd_bin(&self.path)?,
        };
        Ok(OwnedCloud { points_in_sensor, ego_from_sensor: self.ego_from_sensor })
    }
}

#[derive(Clone, Debug)]
enum Source {
    /// One file (or none) per frame; levelled by the local estimate as read when `Some((ground_z_m, ego))`.
    Files { files: Vec<Option<SweepFile>>, level_local: Option<(f32, [f32; 4])> },
    /// An Argoverse 2 log's sweeps (levelled by its ground raster as read).
    Av2(Box<Av2Sweeps>),
}

/// The sweeps of a dataset opened by [`open_deferred`]: frame `i`'s cloud read when asked, never held.
#[derive(Clone, Debug)]
pub struct DeferredSweeps {
    source: Source,
}

impl DeferredSweeps {
    /// No sweep at all (a reader without clouds, or `load_clouds: false`).
    #[must_use]
    pub fn none() -> Self {
        Self { source: Source::Files { files: Vec::new(), level_local: None } }
    }

    /// True when frame `index` has a sweep.
    #[must_use]
    pub fn has_sweep(&self, index: usize) -> bool {
        match &self.source {
            Source::Files { files, .. } => files.get(index).is_some_and(Option::is_some),
            Source::Av2(s) => s.has_sweep(index),
        }
    }

    /// Reads frame `index`'s sweep as [`crate::open_with`] gives it in `frame.cloud`; `None` when the frame has
    /// none.
    ///
    /// # Errors
    /// A missing, truncated or malformed sweep file.
    pub fn cloud(&self, index: usize) -> Result<Option<OwnedCloud>, DatasetError> {
        match &self.source {
            Source::Files { files, level_local } => {
                let Some(Some(file)) = files.get(index) else { return Ok(None) };
                let mut cloud = file.read()?;
                if let Some((ground_z_m, ego)) = *level_local {
                    level_cloud(&mut cloud, ground_z_m, ego, SectorGroundOptions::default(), &|_| None);
                }
                Ok(Some(cloud))
            }
            Source::Av2(s) => s.cloud(index),
        }
    }
}

/// [`crate::open_with`] without reading the sweeps: the frames with `cloud: None` (objects, poses, region of
/// interest, notes and checks as [`crate::open_with`] gives them), and the [`DeferredSweeps`] that read each
/// frame's sweep when asked. Readers without sweeps (`kitti-tracking`, `commonroad`) give [`DeferredSweeps::none`].
///
/// The difference from [`crate::open_with`]: a malformed sweep file is an error when its frame is read, not when
/// the dataset is opened (so an error in a label file of a later frame is reported before it). The Argoverse 2
/// notes say that the sweeps are levelled by the raster as they are read (the share of returns the raster
/// levelled is not known before; [`av2::open_log_deferred`]).
///
/// # Errors
/// An unknown scheme, or any error of the reader except those of the sweep files.
pub fn open_deferred(spec: &str, opts: &ReadOptions) -> Result<(Dataset, DeferredSweeps), DatasetError> {
    open_deferred_tables(spec, opts, None)
}

/// [`open_deferred`] for a nuScenes v1.0 scene whose tables come from its slice ([`crate::open_with_slice`]).
///
/// # Errors
/// A spec that is not `nuscenes-v1:...#scene`, a malformed slice, or any error of [`open_deferred`].
pub fn open_deferred_with_slice(
    spec: &str,
    opts: &ReadOptions,
    slice: &str,
) -> Result<(Dataset, DeferredSweeps), DatasetError> {
    open_deferred_tables(spec, opts, Some(slice))
}

fn open_deferred_tables(
    spec: &str,
    opts: &ReadOptions,
    slice: Option<&str>,
) -> Result<(Dataset, DeferredSweeps), DatasetError> {
    let parsed = Spec::parse(spec)?;
    parsed.check_slice(spec, slice)?;
    let (mut ds, files) = match parsed {
        Spec::Av2(p) => {
            let (ds, sweeps) = av2::open_log_deferred(p, opts)?;
            return Ok((ds, DeferredSweeps { source: Source::Av2(Box::new(sweeps)) }));
        }
        Spec::Kitti(p) => kitti::open_object_with(p, opts, true)?,
        Spec::KittiTracking(p) => (kitti::open_tracking(p)?, Vec::new()),
        Spec::NuScenes(p) => nuscenes::open_converted_with(p, opts, true)?,
        Spec::NuScenesV1(p, scene) => nuscenes::open_v1_with(p, scene, opts, true, slice)?,
        Spec::CommonRoad(p) => (commonroad::open_scenario(p)?, Vec::new()),
    };
    crate::roi::finish(&mut ds, &opts.roi);
    // What ground::finish does after the reader, per sweep as it is read.
    let mut level_local = None;
    if crate::ground::levels_locally(&ds, opts.ground) {
        crate::ground::push_local_note(&mut ds, files.iter().filter(|f| f.is_some()).count());
        level_local = Some((ds.info.ground_z_m, ds.info.format.ego_footprint_m()));
    }
    crate::check_finite(&ds)?;
    Ok((ds, DeferredSweeps { source: Source::Files { files, level_local } }))
}
