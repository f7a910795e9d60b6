//! What the monitor is given each frame: the primary channel's object list, the LiDAR cloud, the ego pose.
//!
//! Frames are named explicitly: `*_in_ego` is the ego-vehicle frame (x forward, y left, z up, origin on the
//! ground-projected reference point of the ego vehicle, metres), `*_in_sensor` the LiDAR's own frame, and
//! `world` a fixed frame (map, city, odometry) in which the plausibility checks integrate motion.

/// A 2D rigid transform `world_from_ego`: a position and a yaw (counter-clockwise, radians).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Pose2 {
    /// Translation x, metres.
    pub x_m: f64,
    /// Translation y, metres.
    pub y_m: f64,
    /// Rotation about z, radians.
    pub yaw_rad: f64,
}

impl Pose2 {
    /// Applies the transform to a point: `world_from_ego * p_in_ego`.
    #[must_use]
    pub fn transform_point(&self, x: f64, y: f64) -> (f64, f64) {
        let (s, c) = libm::sincos(self.yaw_rad);
        (self.x_m + c * x - s * y, self.y_m + s * x + c * y)
    }

    /// True when every field is finite.
    #[must_use]
    pub fn is_finite(&self) -> bool {
        self.x_m.is_finite() && self.y_m.is_finite() && self.yaw_rad.is_finite()
    }
}

/// A 3D rigid transform `ego_from_sensor`: row-major rotation matrix and translation (metres).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Isometry3 {
    /// Row-major 3x3 rotation.
    pub rotation: [[f32; 3]; 3],
    /// Translation, metres.
    pub translation_m: [f32; 3],
}

impl Default for Isometry3 {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl Isometry3 {
    /// The identity transform.
    pub const IDENTITY: Self =
        Self { rotation: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], translation_m: [0.0, 0.0, 0.0] };

    /// A pure translation (sensor mounted upright, axes aligned with the ego frame).
    #[must_use]
    pub const fn from_translation(x_m: f32, y_m: f32, z_m: f32) -> Self {
        Self { rotation: Self::IDENTITY.rotation, translation_m: [x_m, y_m, z_m] }
    }

    /// A rotation about z by `yaw_rad` followed by a translation.
    #[must_use]
    pub fn from_yaw_translation(yaw_rad: f32, translation_m: [f32; 3]) -> Self {
        let (s, c) = libm::sincosf(yaw_rad);
        Self { rotation: [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]], translation_m }
    }

    /// Applies the transform: `ego_from_sensor * p_in_sensor`.
    #[must_use]
    #[inline]
    pub fn transform(&self, p: [f32; 3]) -> [f32; 3] {
        let r = &self.rotation;
        let t = &self.translation_m;
        [
            r[0][0] * p[0] + r[0][1] * p[1] + r[0][2] * p[2] + t[0],
            r[1][0] * p[0] + r[1][1] * p[1] + r[1][2] * p[2] + t[1],
            r[2][0] * p[0] + r[2][1] * p[1] + r[2][2] * p[2] + t[2],
        ]
    }

    /// True when every entry is finite.
    #[must_use]
    pub fn is_finite(&self) -> bool {
        self.rotation.iter().flatten().all(|v| v.is_finite()) && self.translation_m.iter().all(|v| v.is_finite())
    }
}

/// Object class as reported by the primary channel. Used for per-class motion limits and for reports.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(rename_all = "snake_case"))]
pub enum ObjectClass {
    /// Not known or not one of the others.
    #[default]
    Unknown,
    /// Passenger car.
    Car,
    /// Van, truck, bus, trailer or other large vehicle.
    Truck,
    /// Pedestrian.
    Pedestrian,
    /// Bicycle with rider.
    Cyclist,
    /// Motorcycle or moped with rider.
    Motorcyclist,
    /// Static or other object (barrier, cone, animal, ...).
    Other,
}

impl ObjectClass {
    /// All classes, in declaration order.
    pub const ALL: [Self; 7] =
        [Self::Unknown, Self::Car, Self::Truck, Self::Pedestrian, Self::Cyclist, Self::Motorcyclist, Self::Other];

    /// Lower-case name as used in files and reports.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::Unknown => "unknown",
            Self::Car => "car",
            Self::Truck => "truck",
            Self::Pedestrian => "pedestrian",
            Self::Cyclist => "cyclist",
            Self::Motorcyclist => "motorcyclist",
            Self::Other => "other",
        }
    }

    /// Parses [`ObjectClass::name`]; `None` for an unknown name.
    #[must_use]
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.iter().copied().find(|c| c.name() == name)
    }

    /// Index into per-class tables, `0..ALL.len()`.
    #[must_use]
    pub const fn index(self) -> usize {
        self as usize
    }
}

/// One-sigma uncertainties of an object state, the diagonal of `Sigma(o)` as standard deviations.
///
/// The paper's margins `Delta x, Delta y, Delta L, Delta W, Delta v, Delta theta` are these values.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(deny_unknown_fields))]
pub struct Uncertainty {
    /// Position standard deviation along x of the ego frame, metres.
    pub x_m: f32,
    /// Position standard deviation along y of the ego frame, metres.
    pub y_m: f32,
    /// Heading standard deviation, radians.
    pub heading_rad: f32,
    /// Speed standard deviation, m/s.
    pub speed_mps: f32,
    /// Length standard deviation, metres.
    pub length_m: f32,
    /// Width standard deviation, metres.
    pub width_m: f32,
}

impl Uncertainty {
    /// True when every field is finite and not negative.
    #[must_use]
    pub fn is_valid(&self) -> bool {
        [self.x_m, self.y_m, self.heading_rad, self.speed_mps, self.length_m, self.width_m]
            .iter()
            .all(|v| v.is_finite() && *v >= 0.0)
    }
}

/// One object of the primary channel's object list, in the ego frame of its frame.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct ObjectState {
    /// Track id, stable across frames for the same object.
    pub id: u64,
    /// Class.
    pub class: ObjectClass,
    /// Centre of the footprint, ego frame, metres.
    pub x_m: f32,
    /// Centre of the footprint, ego frame, metres.
    pub y_m: f32,
    /// Heading of the box and of the motion, ego frame, radians.
    pub heading_rad: f32,
    /// Speed over ground (absolute value of the velocity, not relative to the ego vehicle), m/s, `>= 0`.
    pub speed_mps: f32,
    /// Box length along the heading, metres, `> 0`.
    pub length_m: f32,
    /// Box width across the heading, metres, `> 0`.
    pub width_m: f32,
    /// One-sigma uncertainties; `None` uses [`crate::MonitorParams::default_uncertainty`].
    pub uncertainty: Option<Uncertainty>,
}

/// A LiDAR sweep: points in the sensor frame and the sensor's extrinsic.
#[derive(Clone, Copy, Debug)]
pub struct PointCloud<'a> {
    /// Points `[x, y, z]` in the sensor frame, metres.
    pub points_in_sensor: &'a [[f32; 3]],
    /// Extrinsic `ego_from_sensor`.
    pub ego_from_sensor: Isometry3,
}

/// A sweep's points as three columns of equal length (structure of arrays): point `i` is `[x[i], y[i], z[i]]`
/// in the sensor frame, metres. Borrowed, so a caller that holds its points this way (a columnar file, a
/// numpy array per axis, a driver's buffers) hands them over without copying them into `[x, y, z]` records;
/// [`crate::Monitor::check_columns`] checks a frame with them and gives the reports [`crate::Monitor::check`]
/// gives for the same points as a [`PointCloud`], bit for bit.
#[derive(Clone, Copy, Debug)]
pub struct PointColumns<'a> {
    x: &'a [f32],
    y: &'a [f32],
    z: &'a [f32],
}

impl<'a> PointColumns<'a> {
    /// No points.
    pub const EMPTY: PointColumns<'static> = PointColumns { x: &[], y: &[], z: &[] };

    /// The columns of one sweep.
    ///
    /// # Errors
    /// [`ColumnLengthError`] when the three columns differ in length.
    pub fn new(x: &'a [f32], y: &'a [f32], z: &'a [f32]) -> Result<Self, ColumnLengthError> {
        if x.len() == y.len() && y.len() == z.len() {
            Ok(Self { x, y, z })
        } else {
            Err(ColumnLengthError { x: x.len(), y: y.len(), z: z.len() })
        }
    }

    /// The `x` column.
    #[must_use]
    pub fn x(&self) -> &'a [f32] {
        self.x
    }

    /// The `y` column.
    #[must_use]
    pub fn y(&self) -> &'a [f32] {
        self.y
    }

    /// The `z` column.
    #[must_use]
    pub fn z(&self) -> &'a [f32] {
        self.z
    }

    /// The number of points.
    #[must_use]
    pub fn len(&self) -> usize {
        self.x.len()
    }

    /// True when there are no points.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }

    /// Point `i`, `None` past the end.
    #[must_use]
    #[inline]
    pub fn get(&self, i: usize) -> Option<[f32; 3]> {
        Some([*self.x.get(i)?, *self.y.get(i)?, *self.z.get(i)?])
    }
}

/// [`PointColumns::new`] was given columns of different lengths.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ColumnLengthError {
    /// Length of the `x` column.
    pub x: usize,
    /// Length of the `y` column.
    pub y: usize,
    /// Length of the `z` column.
    pub z: usize,
}

impl core::fmt::Display for ColumnLengthError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(
            f,
            "point columns differ in length: x has {}, y has {}, z has {} values (one value per point in each)",
            self.x, self.y, self.z
        )
    }
}

impl core::error::Error for ColumnLengthError {}

/// A LiDAR sweep given as columns ([`PointColumns`]) and the sensor's extrinsic: [`PointCloud`]'s counterpart
/// for [`crate::Monitor::check_columns`].
#[derive(Clone, Copy, Debug)]
pub struct ColumnCloud<'a> {
    /// Points in the sensor frame, metres, as three columns.
    pub points_in_sensor: PointColumns<'a>,
    /// Extrinsic `ego_from_sensor`.
    pub ego_from_sensor: Isometry3,
}

/// Everything the monitor looks at in one frame. Borrowed: the monitor copies nothing it does not need.
#[derive(Clone, Copy, Debug)]
pub struct Frame<'a> {
    /// Timestamp, seconds, strictly increasing from frame to frame.
    pub timestamp_s: f64,
    /// Ego pose in the world frame; the identity when unknown (plausibility then runs ego-relative).
    pub world_from_ego: Pose2,
    /// The object list to check.
    pub objects: &'a [ObjectState],
    /// The LiDAR sweep, or `None` when there is none this frame (only the plausibility checks run).
    pub cloud: Option<PointCloud<'a>>,
    /// Optional region of interest in the ego frame: polygons (each at least 3 vertices) where road users
    /// can be (roads, sidewalks, crosswalks). Only evidence inside it can be a missed object or be
    /// attributed to a displaced object. Empty: the whole grid.
    pub roi_in_ego: &'a [&'a [[f32; 2]]],
    /// Optional known static scenery in the ego frame (poles, tree trunks, walls, buildings from a map):
    /// evidence inside these polygons is scenery, never a missed object nor a displaced object's evidence.
    pub static_in_ego: &'a [&'a [[f32; 2]]],
}
