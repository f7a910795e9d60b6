//! `--out results.mcap`: the input bag's messages, then per checked frame the verdicts
//! (`/pmon/verdicts`, `pmon_msgs/msg/FrameVerdicts`, CDR), `/diagnostics` (`diagnostic_msgs/DiagnosticArray`,
//! CDR), `/pmon/scene` (`foxglove.SceneUpdate`, JSON) and `/pmon/grid` (`foxglove.Grid`, JSON), logged at
//! the object list's stamp.

use std::collections::BTreeMap;
use std::fs::{File, OpenOptions};
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use mcap::records::MessageHeader;
use mcap::Writer;
use pmon_monitor::MonitorParams;

use crate::bag::CheckedFrame;
use crate::cdr::encode;
use crate::msg::schema;
use crate::scene;
use crate::verdicts::diagnostics;

/// Output topics.
pub mod topics {
    /// `pmon_msgs/msg/FrameVerdicts`.
    pub const VERDICTS: &str = "/pmon/verdicts";
    /// `diagnostic_msgs/msg/DiagnosticArray`.
    pub const DIAGNOSTICS: &str = "/diagnostics";
    /// `foxglove.SceneUpdate`.
    pub const SCENE: &str = "/pmon/scene";
    /// `foxglove.Grid`.
    pub const GRID: &str = "/pmon/grid";
}

/// Writing the results failed.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// The file exists (results never overwrite data) or cannot be created.
    #[error("{path}: {message}")]
    Create {
        /// The file.
        path: PathBuf,
        /// Why.
        message: String,
    },
    /// The input bag is not readable MCAP (a length beyond its record, file or chunk: [`crate::mcap_check`]).
    #[error("input bag: not a readable MCAP file: {0}")]
    Input(String),
    /// The MCAP writer failed.
    #[error("writing MCAP: {0}")]
    Mcap(#[from] mcap::McapError),
    /// Encoding failed.
    #[error("encoding: {0}")]
    Encode(String),
}

/// The channel ids of pmon's own topics.
struct Channels {
    verdicts: u16,
    diagnostics: u16,
    scene: u16,
    grid: u16,
}

/// An open results file.
pub struct ResultWriter {
    writer: Writer<BufWriter<File>>,
    channels: Channels,
    sequence: u32,
    tau_fn: f32,
    ego_frame: String,
}

/// Adds pmon's output channels to a writer.
fn add_channels(w: &mut Writer<BufWriter<File>>) -> Result<Channels, OutputError> {
    let none = BTreeMap::new();
    let v = w.add_schema(schema::FRAME_VERDICTS, "ros2msg", schema::frame_verdicts().as_bytes())?;
    let d = w.add_schema(schema::DIAGNOSTIC_ARRAY, "ros2msg", schema::diagnostic_array().as_bytes())?;
    let s = w.add_schema(scene::SCENE_UPDATE, "jsonschema", &scene::json_schema(scene::SCENE_UPDATE))?;
    let g = w.add_schema(scene::GRID, "jsonschema", &scene::json_schema(scene::GRID))?;
    Ok(Channels {
        verdicts: w.add_channel(v, topics::VERDICTS, "cdr", &none)?,
        diagnostics: w.add_channel(d, topics::DIAGNOSTICS, "cdr", &none)?,
        scene: w.add_channel(s, topics::SCENE, "json", &none)?,
        grid: w.add_channel(g, topics::GRID, "json", &none)?,
    })
}

/// Creates a new MCAP file (an existing file is an error: results never overwrite data).
///
/// # Errors
/// [`OutputError::Create`].
pub fn create_new(path: &Path) -> Result<Writer<BufWriter<File>>, OutputError> {
    let file = OpenOptions::new().write(true).create_new(true).open(path).map_err(|e| OutputError::Create {
        path: path.into(),
        message: if e.kind() == std::io::ErrorKind::AlreadyExists {
            "already exists; pmon does not overwrite files, remove it or choose another name".into()
        } else {
            e.to_string()
        },
    })?;
    let opts = mcap::WriteOptions::new().profile("ros2").library(concat!("pmon ", env!("CARGO_PKG_VERSION")));
    Ok(opts.create(BufWriter::new(file))?)
}

impl ResultWriter {
    /// Creates `out` and copies every message of the input bag into it.
    ///
    /// # Errors
    /// [`OutputError`] when the file exists or cannot be written, or the input is not MCAP (its lengths are
    /// checked before anything is created: [`crate::mcap_check`]).
    pub fn create(out: &Path, input_bytes: &[u8], params: &MonitorParams) -> Result<Self, OutputError> {
        crate::mcap_check::check_lengths(input_bytes).map_err(|e| OutputError::Input(e.to_string()))?;
        let mut writer = create_new(out)?;
        let stream = mcap::MessageStream::new(input_bytes)?;
        for msg in stream {
            writer.write(&msg?)?;
        }
        let channels = add_channels(&mut writer)?;
        Ok(Self { writer, channels, sequence: 0, tau_fn: params.tau_fn, ego_frame: "base_link".into() })
    }

    /// Sets the frame the scene and grid are drawn in (default `base_link`).
    pub fn set_ego_frame(&mut self, frame: &str) {
        frame.clone_into(&mut self.ego_frame);
    }

    fn put(&mut self, channel_id: u16, t_ns: u64, data: &[u8]) -> Result<(), OutputError> {
        self.sequence = self.sequence.wrapping_add(1);
        let header = MessageHeader { channel_id, sequence: self.sequence, log_time: t_ns, publish_time: t_ns };
        Ok(self.writer.write_to_known_channel(&header, data)?)
    }

    /// Writes one checked frame's verdicts, diagnostics, scene and grid.
    ///
    /// # Errors
    /// [`OutputError`].
    pub fn frame(&mut self, f: &CheckedFrame<'_>) -> Result<(), OutputError> {
        let v = f.verdicts;
        let t = v.header.stamp.as_nanos();
        let enc = |e: crate::cdr::CdrError| OutputError::Encode(e.to_string());
        let verdicts = encode(v).map_err(enc)?;
        let diag = encode(&diagnostics(v)).map_err(enc)?;
        let scene = scene::scene_update(v, &f.frame.objects, &self.ego_frame).to_string();
        let grid = scene::grid(v.header.stamp, f.monitor.grid(), self.tau_fn, &self.ego_frame).to_string();
        let c = (self.channels.verdicts, self.channels.diagnostics, self.channels.scene, self.channels.grid);
        self.put(c.0, t, &verdicts)?;
        self.put(c.1, t, &diag)?;
        self.put(c.2, t, scene.as_bytes())?;
        self.put(c.3, t, grid.as_bytes())
    }

    /// Writes the summary and closes the file.
    ///
    /// # Errors
    /// [`OutputError::Mcap`].
    pub fn finish(mut self) -> Result<(), OutputError> {
        self.writer.finish()?;
        Ok(())
    }
}
