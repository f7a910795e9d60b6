//! [`ScenarioConfig`]: the scenario file (TOML), its defaults and its validation.
//!
//! Every key is documented in `docs/simulator.md`. Unknown keys are rejected; a value out of range is reported
//! with its dotted key (`lidar.beams`).

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::ScenarioError;

/// Names of the built-in scenarios, for [`ScenarioConfig::builtin`].
pub const BUILTIN_NAMES: [&str; 2] = ["pedestrians", "intersection"];

const PEDESTRIANS_TOML: &str = include_str!("../../../scenarios/pedestrians.toml");
const INTERSECTION_TOML: &str = include_str!("../../../scenarios/intersection.toml");

/// The road layout of the world.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Layout {
    /// A straight residential street along the world x axis, one lane per direction, parking on both sides.
    Residential,
    /// Two such streets crossing at the origin, with traffic lights and four crosswalks.
    Intersection,
}

/// What the ego vehicle does.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EgoMode {
    /// Drives along its route, following traffic, obeying the lights and yielding to pedestrians.
    #[default]
    Drive,
    /// Stands still at its start for the whole scenario.
    Wait,
}

/// A turn at the intersection.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Turn {
    /// Straight across.
    #[default]
    Straight,
    /// Left turn (yields to oncoming traffic).
    Left,
    /// Right turn.
    Right,
}

/// What the frames' region of interest (`roi_in_ego`) covers.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RoiMode {
    /// The carriageway (lanes and parking lanes) and the crosswalks: where a missed object matters to the ego.
    #[default]
    Carriageway,
    /// The carriageway, the crosswalks and the sidewalks: everywhere road users can be.
    Walkable,
}

/// A LiDAR preset.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LidarPreset {
    /// Velodyne HDL-64E as in KITTI: 64 beams, +2 to -24.8 degrees, 10 Hz, 0.1728 degree azimuth step.
    #[default]
    Hdl64,
    /// 32-beam sensor as in nuScenes: 32 beams, +10 to -30 degrees, 20 Hz, 0.33 degree azimuth step.
    Vlp32,
}

/// `[road]`: street geometry and speed limit.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RoadConfig {
    /// Width of each of the two driving lanes, metres.
    pub lane_width_m: f64,
    /// Width of the parking lane on each side (part of the carriageway), metres.
    pub parking_width_m: f64,
    /// Width of each sidewalk, metres.
    pub sidewalk_width_m: f64,
    /// Length of the street from the centre to each end, metres. Default: 250 (residential), 120 (intersection).
    pub half_length_m: Option<f64>,
    /// Speed limit, m/s. Default: 8.3 (30 km/h, residential), 13.9 (50 km/h, intersection).
    pub speed_limit_mps: Option<f64>,
    /// Marked crosswalks of the residential street, world x of their centres, metres (residential only).
    pub crosswalks_x_m: Vec<f64>,
}

impl Default for RoadConfig {
    fn default() -> Self {
        Self {
            lane_width_m: 3.5,
            parking_width_m: 2.2,
            sidewalk_width_m: 3.5,
            half_length_m: None,
            speed_limit_mps: None,
            crosswalks_x_m: vec![-100.0, 0.0, 100.0],
        }
    }
}

/// `[ego]`: the ego vehicle.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EgoConfig {
    /// `drive` or `wait`.
    pub mode: EgoMode,
    /// Turn at the intersection (intersection only).
    pub route: Turn,
    /// Start distance before the street centre (residential) or the intersection centre, metres, along the
    /// ego's lane. Default: 150 (residential), 45 (intersection).
    pub start_m: Option<f64>,
    /// Highest speed the ego drives, m/s. Default: 7 (residential), 8 (intersection).
    pub max_speed_mps: Option<f64>,
    /// The ego stops for good after driving this far, metres; 0 drives to the end of the road.
    pub stop_after_m: f64,
    /// Ego box length, metres.
    pub length_m: f64,
    /// Ego box width, metres.
    pub width_m: f64,
}

impl Default for EgoConfig {
    fn default() -> Self {
        Self {
            mode: EgoMode::Drive,
            route: Turn::Straight,
            start_m: None,
            max_speed_mps: None,
            stop_after_m: 0.0,
            length_m: 4.7,
            width_m: 1.9,
        }
    }
}

/// `[agents]`: number and mix of road users.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AgentsConfig {
    /// Pedestrians on the sidewalks.
    pub pedestrians: u32,
    /// Moving passenger cars.
    pub cars: u32,
    /// Vans (class `truck`, 5-6.5 m long).
    pub vans: u32,
    /// Trucks (class `truck`, 7-10 m long).
    pub trucks: u32,
    /// Cyclists (ride near the right edge of the lane).
    pub cyclists: u32,
    /// Fraction of the parking lanes' length taken by parked cars, in [0, 1].
    pub parked_fill: f64,
    /// Parked cars are part of the map (their footprints in the frame's static scenery) rather than objects of
    /// the object list: the way a simulator's ground truth lists only its actors, not the cars that are part of
    /// the town's static geometry (the paper's CARLA set-up).
    pub parked_as_scenery: bool,
    /// Probability that a pedestrian, choosing its next goal, crosses the street, in [0, 1].
    pub crossing_probability: f64,
    /// Probability that a pedestrian, choosing its next goal, stops for 1-6 s instead, in [0, 1].
    pub stop_probability: f64,
}

impl Default for AgentsConfig {
    fn default() -> Self {
        Self {
            pedestrians: 40,
            cars: 8,
            vans: 2,
            trucks: 1,
            cyclists: 3,
            parked_fill: 0.5,
            parked_as_scenery: false,
            crossing_probability: 0.3,
            stop_probability: 0.15,
        }
    }
}

/// `[signals]`: the intersection's two-phase traffic lights (intersection only).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SignalConfig {
    /// Green time of each phase (east-west, then north-south), seconds.
    pub green_s: f64,
    /// Pedestrians start crossing (on the crosswalks parallel to the green road) only during the first `walk_s`
    /// of the green, seconds; turning vehicles yield to them.
    pub walk_s: f64,
    /// All-red clearance time after each green, seconds.
    pub clearance_s: f64,
    /// Offset into the cycle at time 0, seconds.
    pub offset_s: f64,
}

impl Default for SignalConfig {
    fn default() -> Self {
        Self { green_s: 18.0, walk_s: 7.0, clearance_s: 5.0, offset_s: 0.0 }
    }
}

/// `[lidar]`: the sensor. A preset plus optional overrides of each of its values.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LidarConfig {
    /// `false`: no point clouds (object lists and ground truth only). Default `true`.
    pub enabled: Option<bool>,
    /// `hdl64` (KITTI-like) or `vlp32` (nuScenes-like).
    pub preset: LidarPreset,
    /// Sensor height above the ground, metres. Preset: 1.73 (hdl64), 1.84 (vlp32).
    pub mount_height_m: Option<f64>,
    /// Sensor position ahead of the ego reference point (footprint centre), metres. Preset: 0.
    pub forward_offset_m: Option<f64>,
    /// Number of beams; overriding it (or an elevation limit) spaces the beams evenly.
    pub beams: Option<u32>,
    /// Elevation of the highest beam, degrees.
    pub elevation_max_deg: Option<f64>,
    /// Elevation of the lowest beam, degrees.
    pub elevation_min_deg: Option<f64>,
    /// Azimuth step between columns, degrees.
    pub azimuth_step_deg: Option<f64>,
    /// Sweep rate, Hz; a frame carries a cloud when a new sweep has started since the last cloud.
    pub rate_hz: Option<f64>,
    /// Longest range that returns a point, metres. Preset: 120 (hdl64), 70 (vlp32).
    pub max_range_m: Option<f64>,
    /// Shortest range that returns a point, metres. Preset: 1.0.
    pub min_range_m: Option<f64>,
    /// Standard deviation of the Gaussian range noise, metres. Preset: 0.02.
    pub range_noise_m: Option<f64>,
    /// Probability that a ray returns nothing, in [0, 1). Preset: 0.07 (hdl64), 0.01 (vlp32).
    pub dropout: Option<f64>,
}

/// `[noise]`: the object list's measurement noise model.
///
/// Each reported object carries these standard deviations as its `Uncertainty` (when `report_sigma`), and when
/// `add_noise` is set, Gaussian noise with these standard deviations is drawn onto the reported position, heading,
/// speed and size (seeded; the ground truth in `truth.jsonl` stays exact).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NoiseConfig {
    /// Position standard deviation (each of x and y), metres.
    pub position_sigma_m: f64,
    /// Heading standard deviation, degrees.
    pub heading_sigma_deg: f64,
    /// Speed standard deviation, m/s.
    pub speed_sigma_mps: f64,
    /// Length and width standard deviation, metres.
    pub size_sigma_m: f64,
    /// Draw the noise onto the reported object states.
    pub add_noise: bool,
    /// Attach the standard deviations to every reported object (`false`: no `sigma`, the monitor's default).
    pub report_sigma: bool,
}

impl Default for NoiseConfig {
    fn default() -> Self {
        Self {
            position_sigma_m: 0.1,
            heading_sigma_deg: 10.0,
            speed_sigma_mps: 1.0,
            size_sigma_m: 0.0,
            add_noise: false,
            report_sigma: true,
        }
    }
}

fn default_name() -> String {
    "custom".into()
}
fn default_duration() -> f64 {
    40.0
}
fn default_dt() -> f64 {
    0.1
}
fn default_warmup() -> f64 {
    10.0
}
fn default_grid() -> f64 {
    100.0
}
fn default_true() -> bool {
    true
}

/// A scenario: world layout, agents, ego, LiDAR and noise. Read from TOML ([`ScenarioConfig::from_toml_str`])
/// or taken from the built-ins ([`ScenarioConfig::builtin`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScenarioConfig {
    /// Free-form name (goes into the recording's metadata).
    #[serde(default = "default_name")]
    pub name: String,
    /// `residential` or `intersection`.
    pub layout: Layout,
    /// Recorded length, seconds, in (0, 3600].
    #[serde(default = "default_duration")]
    pub duration_s: f64,
    /// Frame period, seconds, in [0.05, 0.1].
    #[serde(default = "default_dt")]
    pub dt_s: f64,
    /// Seed of every random choice (scenery, agents, LiDAR noise, object noise).
    #[serde(default)]
    pub seed: u64,
    /// Simulated time before the first frame (traffic settles), seconds, in [0, 600]. The ego waits meanwhile.
    #[serde(default = "default_warmup")]
    pub warmup_s: f64,
    /// Side of the ego-centred square whose objects go into the object list, metres (the monitor's grid).
    #[serde(default = "default_grid")]
    pub grid_size_m: f64,
    /// Region of interest written into each frame: `carriageway` (default) or `walkable` (with sidewalks).
    #[serde(default)]
    pub roi: RoiMode,
    /// Write the footprints of buildings, walls, poles and tree trunks in the grid as each frame's
    /// `static_in_ego` (a map of known static scenery). Default `true`.
    #[serde(default = "default_true")]
    pub static_scenery: bool,
    /// `[road]`.
    #[serde(default)]
    pub road: RoadConfig,
    /// `[ego]`.
    #[serde(default)]
    pub ego: EgoConfig,
    /// `[agents]`.
    #[serde(default)]
    pub agents: AgentsConfig,
    /// `[signals]`.
    #[serde(default)]
    pub signals: SignalConfig,
    /// `[lidar]`.
    #[serde(default)]
    pub lidar: LidarConfig,
    /// `[noise]`.
    #[serde(default)]
    pub noise: NoiseConfig,
}

/// A LiDAR with every value resolved from its preset and overrides.
#[derive(Clone, Debug, PartialEq)]
pub struct LidarModel {
    /// Beam elevations, radians, highest first.
    pub elevations_rad: Vec<f64>,
    /// Azimuth step between columns, radians.
    pub azimuth_step_rad: f64,
    /// Sweep rate, Hz.
    pub rate_hz: f64,
    /// Sensor height above the ground, metres.
    pub mount_height_m: f64,
    /// Sensor position ahead of the ego reference point, metres.
    pub forward_offset_m: f64,
    /// Longest returned range, metres.
    pub max_range_m: f64,
    /// Shortest returned range, metres.
    pub min_range_m: f64,
    /// Gaussian range noise, metres (standard deviation).
    pub range_noise_m: f64,
    /// Probability that a ray returns nothing.
    pub dropout: f64,
}

impl LidarModel {
    /// The preset's values.
    #[must_use]
    pub fn preset(preset: LidarPreset) -> Self {
        match preset {
            LidarPreset::Hdl64 => {
                // HDL-64E: an upper block of 32 lasers from +2 to -8.33 degrees (1/3 degree apart) and a lower block
                // of 32 from -8.83 to -24.8 degrees (about 1/2 degree apart).
                let mut e = Vec::with_capacity(64);
                for i in 0..32 {
                    e.push((2.0 - f64::from(i) * (10.33 / 31.0)).to_radians());
                }
                for i in 0..32 {
                    e.push((-8.83 - f64::from(i) * ((24.8 - 8.83) / 31.0)).to_radians());
                }
                Self {
                    elevations_rad: e,
                    azimuth_step_rad: 0.1728f64.to_radians(),
                    rate_hz: 10.0,
                    mount_height_m: 1.73,
                    forward_offset_m: 0.0,
                    max_range_m: 120.0,
                    min_range_m: 1.0,
                    range_noise_m: 0.02,
                    // Real HDL-64E sweeps lose about 7 % of the rays (dark or specular surfaces, sky); KITTI
                    // sweeps have 113k-127k points of about 133k rays.
                    dropout: 0.07,
                }
            }
            LidarPreset::Vlp32 => Self {
                elevations_rad: even_elevations(32, 10.0, -30.0),
                azimuth_step_rad: 0.33f64.to_radians(),
                rate_hz: 20.0,
                mount_height_m: 1.84,
                forward_offset_m: 0.0,
                max_range_m: 70.0,
                min_range_m: 1.0,
                range_noise_m: 0.02,
                dropout: 0.01,
            },
        }
    }

    /// Number of azimuth columns per sweep.
    #[must_use]
    pub fn columns(&self) -> usize {
        // Validated: the step is in [0.01, 10] degrees.
        (std::f64::consts::TAU / self.azimuth_step_rad).round().max(1.0) as usize
    }
}

fn even_elevations(beams: u32, max_deg: f64, min_deg: f64) -> Vec<f64> {
    if beams <= 1 {
        return vec![max_deg.to_radians()];
    }
    let step = (max_deg - min_deg) / f64::from(beams - 1);
    (0..beams).map(|i| (max_deg - f64::from(i) * step).to_radians()).collect()
}

impl LidarConfig {
    /// Whether clouds are produced.
    #[must_use]
    pub fn is_enabled(&self) -> bool {
        self.enabled.unwrap_or(true)
    }

    /// The preset with the overrides applied.
    #[must_use]
    pub fn resolve(&self) -> LidarModel {
        let mut m = LidarModel::preset(self.preset);
        if self.beams.is_some() || self.elevation_max_deg.is_some() || self.elevation_min_deg.is_some() {
            let first = m.elevations_rad.first().copied().unwrap_or(0.0).to_degrees();
            let last = m.elevations_rad.last().copied().unwrap_or(0.0).to_degrees();
            let n = self.beams.unwrap_or(m.elevations_rad.len() as u32);
            m.elevations_rad =
                even_elevations(n, self.elevation_max_deg.unwrap_or(first), self.elevation_min_deg.unwrap_or(last));
        }
        let set = |dst: &mut f64, v: Option<f64>| {
            if let Some(v) = v {
                *dst = v;
            }
        };
        if let Some(step) = self.azimuth_step_deg {
            m.azimuth_step_rad = step.to_radians();
        }
        set(&mut m.rate_hz, self.rate_hz);
        set(&mut m.mount_height_m, self.mount_height_m);
        set(&mut m.forward_offset_m, self.forward_offset_m);
        set(&mut m.max_range_m, self.max_range_m);
        set(&mut m.min_range_m, self.min_range_m);
        set(&mut m.range_noise_m, self.range_noise_m);
        set(&mut m.dropout, self.dropout);
        m
    }
}

impl ScenarioConfig {
    /// A built-in scenario by name (see [`BUILTIN_NAMES`]); `None` for an unknown name.
    #[must_use]
    pub fn builtin(name: &str) -> Option<Self> {
        let text = match name {
            "pedestrians" => PEDESTRIANS_TOML,
            "intersection" => INTERSECTION_TOML,
            _ => return None,
        };
        // The built-in files are tested to parse and validate (tests::builtins_parse).
        Self::from_toml_named(text, name).ok()
    }

    /// The TOML text of a built-in scenario (a starting point for a custom file).
    #[must_use]
    pub fn builtin_toml(name: &str) -> Option<&'static str> {
        match name {
            "pedestrians" => Some(PEDESTRIANS_TOML),
            "intersection" => Some(INTERSECTION_TOML),
            _ => None,
        }
    }

    /// Parses and validates a scenario from TOML text.
    ///
    /// # Errors
    /// [`ScenarioError::Parse`] for malformed TOML, unknown keys or wrong types; [`ScenarioError::Invalid`] for a
    /// value out of range, naming the key.
    pub fn from_toml_str(text: &str) -> Result<Self, ScenarioError> {
        Self::from_toml_named(text, "<string>")
    }

    /// Reads, parses and validates a scenario file.
    ///
    /// # Errors
    /// As [`ScenarioConfig::from_toml_str`], naming the file; [`ScenarioError::Io`] if it cannot be read.
    pub fn from_path(path: &Path) -> Result<Self, ScenarioError> {
        let text =
            std::fs::read_to_string(path).map_err(|source| ScenarioError::Io { path: path.to_path_buf(), source })?;
        Self::from_toml_named(&text, &path.display().to_string())
    }

    fn from_toml_named(text: &str, source_name: &str) -> Result<Self, ScenarioError> {
        let cfg: Self = toml::from_str(text).map_err(|e| ScenarioError::Parse {
            source_name: source_name.to_string(),
            message: e.to_string().trim_end().to_string(),
        })?;
        cfg.validate().map_err(|e| e.with_source(source_name))?;
        Ok(cfg)
    }

    /// The scenario as TOML text (round-trips through [`ScenarioConfig::from_toml_str`]).
    ///
    /// # Errors
    /// [`ScenarioError::Parse`] if serialisation fails (it does not for validated configs).
    pub fn to_toml_string(&self) -> Result<String, ScenarioError> {
        toml::to_string_pretty(self)
            .map_err(|e| ScenarioError::Parse { source_name: self.name.clone(), message: e.to_string() })
    }

    /// Half length of the street(s), metres, with the layout's default.
    #[must_use]
    pub fn half_length_m(&self) -> f64 {
        self.road.half_length_m.unwrap_or(match self.layout {
            Layout::Residential => 250.0,
            Layout::Intersection => 120.0,
        })
    }

    /// Speed limit, m/s, with the layout's default.
    #[must_use]
    pub fn speed_limit_mps(&self) -> f64 {
        self.road.speed_limit_mps.unwrap_or(match self.layout {
            Layout::Residential => 8.3,
            Layout::Intersection => 13.9,
        })
    }

    /// Ego start distance, metres, with the layout's default.
    #[must_use]
    pub fn ego_start_m(&self) -> f64 {
        self.ego.start_m.unwrap_or(match self.layout {
            Layout::Residential => 150.0,
            Layout::Intersection => 45.0,
        })
    }

    /// Ego top speed, m/s, with the layout's default.
    #[must_use]
    pub fn ego_max_speed_mps(&self) -> f64 {
        self.ego.max_speed_mps.unwrap_or(match self.layout {
            Layout::Residential => 7.0,
            Layout::Intersection => 8.0,
        })
    }

    /// Number of frames the scenario yields.
    #[must_use]
    pub fn frame_count(&self) -> u64 {
        // Validated: duration <= 3600 s, dt >= 0.05 s.
        (self.duration_s / self.dt_s).round().max(1.0) as u64
    }

    /// Checks every value against its range.
    ///
    /// # Errors
    /// [`ScenarioError::Invalid`] naming the first key out of range.
    pub fn validate(&self) -> Result<(), ScenarioError> {
        let src = format!("scenario `{}`", self.name);
        let check = |ok: bool, key: &str, reason: &str| -> Result<(), ScenarioError> {
            if ok {
                Ok(())
            } else {
                Err(ScenarioError::invalid(&src, key, reason))
            }
        };
        let range = |v: f64, lo: f64, hi: f64, key: &str| -> Result<(), ScenarioError> {
            check(v.is_finite() && v >= lo && v <= hi, key, &format!("= {v} must be in [{lo}, {hi}]"))
        };
        let opt = |v: Option<f64>, lo: f64, hi: f64, key: &str| -> Result<(), ScenarioError> {
            v.map_or(Ok(()), |v| range(v, lo, hi, key))
        };
        check(self.duration_s.is_finite() && self.duration_s > 0.0, "duration_s", "must be > 0")?;
        range(self.duration_s, 0.0, 3600.0, "duration_s")?;
        range(self.dt_s, 0.05, 0.1, "dt_s")?;
        range(self.warmup_s, 0.0, 600.0, "warmup_s")?;
        range(self.grid_size_m, 1.0, 1000.0, "grid_size_m")?;

        let r = &self.road;
        range(r.lane_width_m, 2.5, 5.0, "road.lane_width_m")?;
        range(r.parking_width_m, 1.8, 3.5, "road.parking_width_m")?;
        range(r.sidewalk_width_m, 2.0, 8.0, "road.sidewalk_width_m")?;
        opt(r.half_length_m, 60.0, 2000.0, "road.half_length_m")?;
        opt(r.speed_limit_mps, 2.0, 30.0, "road.speed_limit_mps")?;
        for (i, x) in r.crosswalks_x_m.iter().enumerate() {
            let hl = self.half_length_m() - 10.0;
            range(*x, -hl, hl, &format!("road.crosswalks_x_m[{i}]"))?;
        }

        let e = &self.ego;
        let max_start = match self.layout {
            Layout::Residential => self.half_length_m() - 5.0,
            Layout::Intersection => self.half_length_m() - 5.0,
        };
        opt(e.start_m, 15.0_f64.min(max_start), max_start, "ego.start_m")?;
        opt(e.max_speed_mps, 0.5, 30.0, "ego.max_speed_mps")?;
        range(e.stop_after_m, 0.0, 10_000.0, "ego.stop_after_m")?;
        range(e.length_m, 2.0, 12.0, "ego.length_m")?;
        range(e.width_m, 1.0, 3.0, "ego.width_m")?;

        let a = &self.agents;
        check(a.pedestrians <= 2000, "agents.pedestrians", "must be <= 2000")?;
        for (n, key) in [
            (a.cars, "agents.cars"),
            (a.vans, "agents.vans"),
            (a.trucks, "agents.trucks"),
            (a.cyclists, "agents.cyclists"),
        ] {
            check(n <= 500, key, "must be <= 500")?;
        }
        range(a.parked_fill, 0.0, 1.0, "agents.parked_fill")?;
        range(a.crossing_probability, 0.0, 1.0, "agents.crossing_probability")?;
        range(a.stop_probability, 0.0, 1.0, "agents.stop_probability")?;

        range(self.signals.green_s, 5.0, 300.0, "signals.green_s")?;
        range(self.signals.clearance_s, 2.0, 60.0, "signals.clearance_s")?;
        range(self.signals.walk_s, 0.0, self.signals.green_s, "signals.walk_s")?;
        range(self.signals.offset_s, 0.0, 1000.0, "signals.offset_s")?;

        let l = &self.lidar;
        opt(l.mount_height_m, 0.3, 5.0, "lidar.mount_height_m")?;
        opt(l.forward_offset_m, -5.0, 5.0, "lidar.forward_offset_m")?;
        if let Some(b) = l.beams {
            check((1..=256).contains(&b), "lidar.beams", "must be in [1, 256]")?;
        }
        opt(l.elevation_max_deg, -89.0, 89.0, "lidar.elevation_max_deg")?;
        opt(l.elevation_min_deg, -89.0, 89.0, "lidar.elevation_min_deg")?;
        opt(l.azimuth_step_deg, 0.01, 10.0, "lidar.azimuth_step_deg")?;
        opt(l.rate_hz, 1.0, 100.0, "lidar.rate_hz")?;
        opt(l.max_range_m, 5.0, 500.0, "lidar.max_range_m")?;
        opt(l.min_range_m, 0.0, 10.0, "lidar.min_range_m")?;
        opt(l.range_noise_m, 0.0, 1.0, "lidar.range_noise_m")?;
        opt(l.dropout, 0.0, 0.99, "lidar.dropout")?;
        let m = l.resolve();
        let (top, bottom) =
            (m.elevations_rad.first().copied().unwrap_or(0.0), m.elevations_rad.last().copied().unwrap_or(0.0));
        check(top >= bottom, "lidar.elevation_min_deg", "must not be above lidar.elevation_max_deg")?;
        check(m.min_range_m < m.max_range_m, "lidar.min_range_m", "must be below lidar.max_range_m")?;

        let n = &self.noise;
        range(n.position_sigma_m, 0.0, 10.0, "noise.position_sigma_m")?;
        range(n.heading_sigma_deg, 0.0, 180.0, "noise.heading_sigma_deg")?;
        range(n.speed_sigma_mps, 0.0, 20.0, "noise.speed_sigma_mps")?;
        range(n.size_sigma_m, 0.0, 5.0, "noise.size_sigma_m")?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builtins_parse() {
        for name in BUILTIN_NAMES {
            let text = ScenarioConfig::builtin_toml(name).unwrap();
            let cfg = ScenarioConfig::from_toml_named(text, name).unwrap();
            assert_eq!(cfg.name, name);
            assert_eq!(ScenarioConfig::builtin(name), Some(cfg.clone()));
            // Round trip through TOML.
            let back = ScenarioConfig::from_toml_str(&cfg.to_toml_string().unwrap()).unwrap();
            assert_eq!(back, cfg);
        }
        assert!(ScenarioConfig::builtin("nope").is_none());
    }

    #[test]
    fn unknown_key_is_named() {
        let err = ScenarioConfig::from_toml_str("layout = \"residential\"\n[lidar]\nbeamz = 3\n").unwrap_err();
        let msg = err.to_string();
        assert!(msg.contains("beamz"), "{msg}");
        assert!(matches!(err, ScenarioError::Parse { .. }));
    }

    #[test]
    fn out_of_range_names_the_key() {
        let err = ScenarioConfig::from_toml_str("layout = \"residential\"\ndt_s = 0.2\n").unwrap_err();
        assert!(err.to_string().contains("`dt_s`"), "{err}");
        let err = ScenarioConfig::from_toml_str("layout = \"intersection\"\n[lidar]\nbeams = 0\n").unwrap_err();
        assert!(err.to_string().contains("`lidar.beams`"), "{err}");
        let err =
            ScenarioConfig::from_toml_str("layout = \"intersection\"\n[noise]\nspeed_sigma_mps = -1\n").unwrap_err();
        assert!(err.to_string().contains("`noise.speed_sigma_mps`"), "{err}");
    }

    #[test]
    fn minimal_file_gets_defaults() {
        let cfg = ScenarioConfig::from_toml_str("layout = \"intersection\"").unwrap();
        assert!((cfg.dt_s - 0.1).abs() < 1e-12);
        assert_eq!(cfg.frame_count(), 400);
        let m = cfg.lidar.resolve();
        assert_eq!(m.elevations_rad.len(), 64);
        assert!((m.elevations_rad[0].to_degrees() - 2.0).abs() < 1e-9);
        assert!((m.elevations_rad[63].to_degrees() + 24.8).abs() < 1e-9);
        assert_eq!(m.columns(), 2083);
    }

    #[test]
    fn overrides_apply() {
        let cfg = ScenarioConfig::from_toml_str(
            "layout = \"residential\"\n[lidar]\npreset = \"vlp32\"\nbeams = 16\nmount_height_m = 2.0\n",
        )
        .unwrap();
        let m = cfg.lidar.resolve();
        assert_eq!(m.elevations_rad.len(), 16);
        assert!((m.elevations_rad[0].to_degrees() - 10.0).abs() < 1e-9);
        assert!((m.elevations_rad[15].to_degrees() + 30.0).abs() < 1e-9);
        assert!((m.mount_height_m - 2.0).abs() < 1e-12);
    }
}
