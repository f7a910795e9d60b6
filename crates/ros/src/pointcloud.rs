//! `sensor_msgs/PointCloud2` -> points: field offsets, datatypes, `point_step`, `row_step` and byte order
//! as the message declares them.

use crate::msg::{PointCloud2, PointField};

/// Why a cloud's layout cannot be read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum CloudError {
    /// A coordinate field is missing.
    #[error("point cloud has no field {0:?}")]
    MissingField(&'static str),
    /// A field's datatype is not 1..=8.
    #[error("field {name:?} has unknown datatype {datatype}")]
    BadDatatype {
        /// Field.
        name: String,
        /// Its datatype.
        datatype: u8,
    },
    /// A field does not fit in `point_step`.
    #[error("field {name:?} (offset {offset}, {size} bytes) does not fit in point_step {point_step}")]
    FieldOutsidePoint {
        /// Field.
        name: String,
        /// Offset.
        offset: u32,
        /// Size in bytes.
        size: u32,
        /// Point step.
        point_step: u32,
    },
    /// `row_step` shorter than `width * point_step`, or a size overflow.
    #[error("row_step {row_step} is shorter than width {width} x point_step {point_step}")]
    BadRowStep {
        /// Row step.
        row_step: u32,
        /// Width.
        width: u32,
        /// Point step.
        point_step: u32,
    },
    /// `data` shorter than `row_step * height`.
    #[error("data has {have} bytes, the layout needs {need}")]
    ShortData {
        /// Bytes present.
        have: usize,
        /// Bytes needed.
        need: u64,
    },
}

/// Size in bytes of a `PointField` datatype.
#[must_use]
pub const fn datatype_size(datatype: u8) -> Option<u32> {
    match datatype {
        1 | 2 => Some(1),
        3 | 4 => Some(2),
        5..=7 => Some(4),
        8 => Some(8),
        _ => None,
    }
}

#[derive(Clone, Copy)]
struct Reader {
    offset: usize,
    datatype: u8,
    big_endian: bool,
}

impl Reader {
    fn read(self, point: &[u8]) -> f32 {
        let Some(bytes) = point.get(self.offset..) else { return f32::NAN };
        macro_rules! num {
            ($t:ty, $n:expr) => {{
                let mut b = [0u8; $n];
                match bytes.get(..$n) {
                    Some(s) => b.copy_from_slice(s),
                    None => return f32::NAN,
                }
                if self.big_endian {
                    <$t>::from_be_bytes(b)
                } else {
                    <$t>::from_le_bytes(b)
                }
            }};
        }
        #[allow(clippy::cast_possible_truncation, clippy::cast_precision_loss)]
        match self.datatype {
            1 => f32::from(num!(i8, 1)),
            2 => f32::from(num!(u8, 1)),
            3 => f32::from(num!(i16, 2)),
            4 => f32::from(num!(u16, 2)),
            5 => num!(i32, 4) as f32,
            6 => num!(u32, 4) as f32,
            7 => num!(f32, 4),
            8 => num!(f64, 8) as f32,
            _ => f32::NAN,
        }
    }
}

fn field(cloud: &PointCloud2, name: &'static str) -> Result<Reader, CloudError> {
    let f: &PointField = cloud.fields.iter().find(|f| f.name == name).ok_or(CloudError::MissingField(name))?;
    let size = datatype_size(f.datatype)
        .ok_or_else(|| CloudError::BadDatatype { name: f.name.clone(), datatype: f.datatype })?;
    if f.offset.checked_add(size).is_none_or(|end| end > cloud.point_step) {
        return Err(CloudError::FieldOutsidePoint {
            name: f.name.clone(),
            offset: f.offset,
            size,
            point_step: cloud.point_step,
        });
    }
    Ok(Reader { offset: f.offset as usize, datatype: f.datatype, big_endian: cloud.is_bigendian })
}

/// Points of a cloud.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Points {
    /// Finite points `[x, y, z]` in the cloud's frame, metres.
    pub points: Vec<[f32; 3]>,
    /// Points left out because a coordinate was NaN or infinite (what `is_dense = false` clouds carry).
    pub non_finite: usize,
}

/// Reads the `x`, `y`, `z` fields of every point (any datatype, either byte order, padding between rows).
///
/// # Errors
/// [`CloudError`] when the layout is inconsistent: a missing or unknown field, a field outside the point, a
/// `row_step` shorter than a row, or `data` shorter than `row_step * height`.
pub fn to_points(cloud: &PointCloud2) -> Result<Points, CloudError> {
    let (fx, fy, fz) = (field(cloud, "x")?, field(cloud, "y")?, field(cloud, "z")?);
    let row_bytes = u64::from(cloud.width) * u64::from(cloud.point_step);
    if u64::from(cloud.row_step) < row_bytes {
        return Err(CloudError::BadRowStep {
            row_step: cloud.row_step,
            width: cloud.width,
            point_step: cloud.point_step,
        });
    }
    let need = u64::from(cloud.row_step) * u64::from(cloud.height);
    if (cloud.data.len() as u64) < need {
        return Err(CloudError::ShortData { have: cloud.data.len(), need });
    }
    let mut out = Points { points: Vec::with_capacity(cloud.width as usize * cloud.height as usize), non_finite: 0 };
    let step = cloud.point_step as usize;
    for row in 0..cloud.height as usize {
        let start = row * cloud.row_step as usize;
        let Some(row_data) = cloud.data.get(start..start + row_bytes as usize) else { break };
        if step == 0 {
            break;
        }
        for point in row_data.chunks_exact(step) {
            let p = [fx.read(point), fy.read(point), fz.read(point)];
            if p.iter().all(|v| v.is_finite()) {
                out.points.push(p);
            } else {
                out.non_finite += 1;
            }
        }
    }
    Ok(out)
}

/// Builds a cloud of `FLOAT32` `x, y, z` (and a `FLOAT32` `intensity`), 16 bytes per point, little endian:
/// the layout Autoware's concatenated cloud uses. For tests, tools and the live node's replay.
#[must_use]
pub fn from_points(header: crate::msg::Header, points: &[[f32; 3]]) -> PointCloud2 {
    let mut data = Vec::with_capacity(points.len() * 16);
    for p in points {
        for v in p {
            data.extend_from_slice(&v.to_le_bytes());
        }
        data.extend_from_slice(&0f32.to_le_bytes());
    }
    let field = |name: &str, offset| PointField { name: name.into(), offset, datatype: 7, count: 1 };
    let width = u32::try_from(points.len()).unwrap_or(u32::MAX);
    PointCloud2 {
        header,
        height: 1,
        width,
        fields: vec![field("x", 0), field("y", 4), field("z", 8), field("intensity", 12)],
        is_bigendian: false,
        point_step: 16,
        row_step: width.saturating_mul(16),
        data,
        is_dense: true,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msg::Header;

    #[test]
    fn float32_cloud_round_trips() {
        let pts = [[1.0, 2.0, 3.0], [-4.5, 0.25, 1e3]];
        let c = from_points(Header::default(), &pts);
        assert_eq!(to_points(&c).unwrap().points, pts);
    }

    #[test]
    fn offsets_datatypes_padding_and_big_endian() {
        // Two rows of one point each; point_step 24 with z first as float64, x as int16, y as uint8;
        // big-endian; 8 bytes of padding after each row.
        let mut data = Vec::new();
        for (x, y, z) in [(-3i16, 7u8, 1.5f64), (300, 255, -2.25)] {
            let mut p = vec![0u8; 24];
            p[0..8].copy_from_slice(&z.to_be_bytes());
            p[10..12].copy_from_slice(&x.to_be_bytes());
            p[20] = y;
            data.extend_from_slice(&p);
            data.extend_from_slice(&[0xAA; 8]);
        }
        let c = PointCloud2 {
            height: 2,
            width: 1,
            fields: vec![
                PointField { name: "z".into(), offset: 0, datatype: 8, count: 1 },
                PointField { name: "x".into(), offset: 10, datatype: 3, count: 1 },
                PointField { name: "y".into(), offset: 20, datatype: 2, count: 1 },
            ],
            is_bigendian: true,
            point_step: 24,
            row_step: 32,
            data,
            ..PointCloud2::default()
        };
        assert_eq!(to_points(&c).unwrap().points, vec![[-3.0, 7.0, 1.5], [300.0, 255.0, -2.25]]);
    }

    #[test]
    fn non_finite_points_are_counted_not_kept() {
        let c = from_points(Header::default(), &[[f32::NAN, 0.0, 0.0], [1.0, 1.0, 1.0]]);
        let p = to_points(&c).unwrap();
        assert_eq!((p.points.len(), p.non_finite), (1, 1));
    }

    #[test]
    fn malformed_layouts_are_errors() {
        let good = from_points(Header::default(), &[[1.0, 2.0, 3.0]; 4]);
        let mut c = good.clone();
        c.fields.retain(|f| f.name != "y");
        assert_eq!(to_points(&c), Err(CloudError::MissingField("y")));
        let mut c = good.clone();
        c.fields[2].datatype = 9;
        assert!(matches!(to_points(&c), Err(CloudError::BadDatatype { .. })));
        let mut c = good.clone();
        c.fields[2].offset = 14;
        assert!(matches!(to_points(&c), Err(CloudError::FieldOutsidePoint { .. })));
        let mut c = good.clone();
        c.row_step = 10;
        assert!(matches!(to_points(&c), Err(CloudError::BadRowStep { .. })));
        let mut c = good.clone();
        c.data.truncate(20);
        assert!(matches!(to_points(&c), Err(CloudError::ShortData { .. })));
        let mut c = good;
        c.width = u32::MAX;
        c.row_step = u32::MAX;
        c.height = u32::MAX;
        assert!(to_points(&c).is_err());
    }
}
