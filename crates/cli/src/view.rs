//! `pmon view`: a top view of one frame, and the picture builder the report reuses.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{bail, Context, Result};
use clap::Args;
use pmon_campaign::Injection;
use pmon_monitor::{CellState, ClusterReport, Monitor, MonitorParams, ObjectReport, ObjectState, RoiStatus, Verdict};
use pmon_recording::RecordedFrame;
use pmon_report::{BoxKind, TopView, ViewBox, ViewCell, ViewCluster};

use crate::check::open_input;
use crate::output::{tag_png, tag_svg, OutputFile};

/// Arguments of `pmon view`.
#[derive(Args, Debug)]
pub struct ViewArgs {
    /// A pmon recording directory, a `.jsonl` object list, or a dataset spec (`kitti:DIR`, `av2:LOG_DIR`, ...,
    /// as for `pmon check`).
    pub recording: PathBuf,
    /// Frame number to draw (the monitor runs over the frames before it for the motion history).
    #[arg(long, default_value_t = 0)]
    pub frame: u64,
    /// Output image: `.png` or `.svg`.
    #[arg(long, short, default_value = "frame.png")]
    pub out: PathBuf,
    /// Half width of the drawn area around the centre, metres.
    #[arg(long, default_value_t = 25.0)]
    pub radius_m: f32,
    /// Centre the picture on this object id instead of the ego vehicle.
    #[arg(long)]
    pub object: Option<u64>,
    /// Monitor parameters (TOML, or a profile pmon ships: `profile:recall`); defaults to the paper's Table I (with
    /// a dataset's ground height and ego footprint under the file's keys).
    #[arg(long)]
    pub params: Option<PathBuf>,
    /// Replace `--out` even when it is a file pmon did not write.
    #[arg(long)]
    pub force: bool,
    /// Side of a PNG picture, pixels (small pictures for documents: 500-700).
    #[arg(long, default_value_t = PNG_SIDE_PX, value_parser = clap::value_parser!(u32).range(200..=4000))]
    pub size_px: u32,
}

/// Side of a PNG top view, pixels, unless `--size-px` says otherwise.
pub const PNG_SIDE_PX: u32 = 1400;

fn box_kind(r: &ObjectReport) -> BoxKind {
    match r.verdict {
        Verdict::Consistent => BoxKind::Consistent,
        Verdict::MotionOnlyConsistent(_) => BoxKind::MotionOnly,
        Verdict::Ghost => BoxKind::Ghost,
        Verdict::PositionError => BoxKind::PositionError,
        Verdict::ImplausibleMotion(_) => BoxKind::Implausible,
        Verdict::NotMonitored(_) => BoxKind::NotMonitored,
    }
}

fn short_verdict(r: &ObjectReport) -> String {
    match r.verdict {
        Verdict::NotMonitored(reason) => format!("not monitored: {reason}"),
        Verdict::ImplausibleMotion(c) => format!("implausible {c}"),
        Verdict::MotionOnlyConsistent(reason) => format!("motion only: plausible (sensor: {reason})"),
        Verdict::PositionError => match r.sensor.position_cause {
            Some(c) => format!("position_error: {c} (eta {:.2})", r.sensor.eta),
            None => format!("position_error (eta {:.2})", r.sensor.eta),
        },
        v => format!("{} (eta {:.2})", v.name(), r.sensor.eta),
    }
}

/// A frame and what the monitor said about it.
pub struct Checked<'a> {
    /// The frame as checked.
    pub frame: &'a RecordedFrame,
    /// One report per object.
    pub objects: &'a [ObjectReport],
    /// Conflict clusters.
    pub clusters: &'a [ClusterReport],
    /// Injected errors (may be empty): drawn as arrows from the true position, with the true footprint.
    pub injections: &'a [Injection],
}

/// Builds the top view of a checked frame around `centre` (ego frame), `radius_m` each way.
pub fn top_view(title: &str, monitor: &Monitor, checked: &Checked<'_>, centre: (f32, f32), radius_m: f32) -> TopView {
    let Checked { frame, objects, clusters, injections } = *checked;
    let extent = (centre.0 - radius_m, centre.1 - radius_m, centre.0 + radius_m, centre.1 + radius_m);
    let inside = |x: f32, y: f32| x >= extent.0 && x <= extent.2 && y >= extent.1 && y <= extent.3;
    let params = monitor.params();
    let grid = monitor.grid();
    let mut view = TopView::new(title, extent, grid.geometry.cell_size_m);
    // Every grid cell in the picture: occupied or conflict from the grid; otherwise free where the sensor saw
    // through the cell (rays passed it), unknown where it did not (shadowed, beyond the reach, no sweep): this is
    // what explains an `occluded` verdict.
    let has_sweep = frame.cloud.is_some();
    let visibility = monitor.visibility();
    if let Some((i0, j0, i1, j1)) = grid.geometry.cell_range_clipped([extent.0, extent.1, extent.2, extent.3]) {
        let n = grid.geometry.cells_per_side;
        for j in j0..=j1 {
            for i in i0..=i1 {
                let idx = j * n + i;
                let (x, y) = grid.geometry.cell_center(idx);
                if !inside(x, y) {
                    continue;
                }
                let state = match grid.state(idx, params.tau_fn) {
                    CellState::Occupied => pmon_report::CellState::Occupied,
                    CellState::Conflict => pmon_report::CellState::Conflict,
                    CellState::Unknown | CellState::Weak if has_sweep && visibility.is_visible(x, y) => {
                        pmon_report::CellState::Free
                    }
                    CellState::Unknown | CellState::Weak => pmon_report::CellState::Unknown,
                };
                view.cells.push(ViewCell { x_m: x, y_m: y, state });
            }
        }
    }
    if let Some(cloud) = &frame.cloud {
        let (lo, hi) = params.obstacle_band_m();
        for p in &cloud.points_in_sensor {
            let q = cloud.ego_from_sensor.transform(*p);
            if q[2] >= lo && q[2] <= hi && inside(q[0], q[1]) {
                view.points.push([q[0], q[1]]);
            }
        }
    }
    for (o, r) in frame.objects.iter().zip(objects) {
        if !inside(o.x_m, o.y_m) {
            continue;
        }
        view.boxes.push(ViewBox {
            x_m: o.x_m,
            y_m: o.y_m,
            heading_rad: o.heading_rad,
            length_m: o.length_m,
            width_m: o.width_m,
            grown_length_m: o.length_m + 2.0 * r.sensor.margin_length_m,
            grown_width_m: o.width_m + 2.0 * r.sensor.margin_width_m,
            label: format!("{} {}: {}", o.class.name(), o.id, short_verdict(r)),
            kind: box_kind(r),
        });
    }
    for inj in injections {
        let Some(o) = frame.objects.get(inj.index as usize) else { continue };
        if inj.offset_m == [0.0, 0.0] {
            continue;
        }
        let truth = [o.x_m - inj.offset_m[0], o.y_m - inj.offset_m[1]];
        view.arrows.push((truth, [o.x_m, o.y_m]));
        view.boxes.push(ViewBox {
            x_m: truth[0],
            y_m: truth[1],
            heading_rad: o.heading_rad,
            length_m: o.length_m,
            width_m: o.width_m,
            grown_length_m: o.length_m,
            grown_width_m: o.width_m,
            label: format!("true position of {}", o.id),
            kind: BoxKind::InjectedTruth,
        });
    }
    // The frame's region of interest, clipped to the drawn square.
    for poly in &frame.roi_in_ego {
        let local: Vec<[f64; 2]> =
            poly.iter().map(|p| [f64::from(p[0] - centre.0), f64::from(p[1] - centre.1)]).collect();
        let clipped = pmon_datasets::geometry::clip_to_square(&local, f64::from(radius_m));
        if clipped.len() >= 3 {
            view.regions.push(clipped.iter().map(|p| [p[0] as f32 + centre.0, p[1] as f32 + centre.1]).collect());
        }
    }
    for c in clusters {
        let [x0, y0, x1, y1] = c.bounds_m;
        if !(inside(x0, y0) || inside(x1, y1)) {
            continue;
        }
        let label = match c.object {
            Some(j) => format!("evidence of {}", frame.objects.get(j as usize).map_or(0, |o: &ObjectState| o.id)),
            None if c.in_roi => "missed object".to_string(),
            None if c.roi == RoiStatus::Grazing => "unexplained (outside ROI: grazing)".to_string(),
            None => "unexplained (outside ROI)".to_string(),
        };
        let h = 0.5 * grid.geometry.cell_size_m;
        view.clusters.push(ViewCluster { bounds_m: [x0 - h, y0 - h, x1 + h, y1 + h], label });
    }
    view
}

/// Writes a view as PNG or SVG by the file's extension, tagged as pmon's output (see [`crate::output`]).
pub fn write_view(view: &TopView, path: &std::path::Path) -> Result<()> {
    write_view_sized(view, path, PNG_SIDE_PX)
}

/// [`write_view`] with the side of a PNG in pixels.
pub fn write_view_sized(view: &TopView, path: &std::path::Path, side_px: u32) -> Result<()> {
    let read = |p: &std::path::Path| std::fs::read(p).with_context(|| format!("cannot read back {}", p.display()));
    match path.extension().and_then(|e| e.to_str()) {
        Some("svg") => {
            view.render_svg(path)?;
            let text = String::from_utf8_lossy(&read(path)?).into_owned();
            std::fs::write(path, tag_svg(&text)).with_context(|| format!("cannot write {}", path.display()))?;
        }
        Some("png") | None => {
            view.render_png(path, side_px, side_px)?;
            let bytes = tag_png(&read(path)?);
            std::fs::write(path, bytes).with_context(|| format!("cannot write {}", path.display()))?;
        }
        Some(other) => bail!("{}: unknown image type `.{other}` (use .png or .svg)", path.display()),
    }
    Ok(())
}

/// `pmon view`.
pub fn run(args: &ViewArgs) -> Result<ExitCode> {
    // A dataset spec brings its map as for `pmon check` (the default region of interest).
    let grid_size_m = crate::config::load_params_over(MonitorParams::default(), args.params.as_deref())?.grid_size_m;
    let opts = crate::check::read_options(
        pmon_datasets::roi::RoiMode::Auto,
        pmon_datasets::av2_map::DEFAULT_SIDEWALK_WIDTH_M,
        grid_size_m,
    );
    let (_, input) = open_input(&args.recording, &opts)?;
    let params = input.params(args.params.as_deref())?;
    let mut monitor = Monitor::new(params).map_err(|e| anyhow::anyhow!("{e}"))?;
    let out = OutputFile::prepare(&args.out, "view", args.force)?;
    for frame in input.iter {
        let frame = frame?;
        let mut roi = Vec::new();
        let view = frame.as_frame(&mut roi);
        let report = monitor.check(&view).map_err(|e| anyhow::anyhow!("frame {}: {e}", frame.index))?;
        if frame.index != args.frame {
            continue;
        }
        let (objects, clusters) = (report.objects.to_vec(), report.clusters.to_vec());
        let centre = match args.object {
            None => (0.0, 0.0),
            Some(id) => frame
                .objects
                .iter()
                .find(|o| o.id == id)
                .map(|o| (o.x_m, o.y_m))
                .with_context(|| format!("frame {} has no object {id}", frame.index))?,
        };
        let title = format!("{} frame {} (t = {:.2} s)", args.recording.display(), frame.index, frame.timestamp_s);
        let checked = Checked { frame: &frame, objects: &objects, clusters: &clusters, injections: &[] };
        let picture = top_view(&title, &monitor, &checked, centre, args.radius_m);
        write_view_sized(&picture, out.path(), args.size_px)?;
        out.commit()?;
        eprintln!("wrote {}", args.out.display());
        return Ok(ExitCode::SUCCESS);
    }
    bail!("{}: no frame {}", args.recording.display(), args.frame)
}
