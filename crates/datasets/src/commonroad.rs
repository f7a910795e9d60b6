//! CommonRoad XML scenarios (formats 2018b and 2020a): dynamic obstacles as object tracks.
//!
//! Frames: CommonRoad has no ego vehicle and gives obstacles in the scenario (world) frame. The reader keeps
//! them there: `world_from_ego` is the identity and each frame's objects are in the scenario frame, so the
//! monitor's plausibility checks run in the world frame. There are no LiDAR clouds. Speed is the state's
//! `velocity` (absolute value), heading its `orientation`, the recorded `acceleration` goes to
//! [`crate::ObjectExtra::accel_mps2`].

use std::collections::BTreeMap;
use std::path::Path;

use pmon_monitor::{ObjectClass, ObjectState, Pose2};
use pmon_recording::RecordedFrame;
use quick_xml::events::Event;
use quick_xml::Reader;

use crate::util::{f32_of, parse_f64, read_text};
use crate::{Dataset, DatasetError, DatasetFormat, DatasetFrame, DatasetInfo, ObjectExtra, SpeedSource};

/// Deepest element nesting accepted (CommonRoad needs about 8).
const MAX_DEPTH: usize = 64;
/// Largest time step accepted (a frame is made for every step from the first to the last).
const MAX_TIME_STEP: i64 = 1_000_000;

/// A minimal XML element tree.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Element {
    /// Local name.
    pub name: String,
    /// Attributes `(local name, unescaped value)`.
    pub attrs: Vec<(String, String)>,
    /// Child elements in document order.
    pub children: Vec<Element>,
    /// Concatenated text content (trimmed).
    pub text: String,
}

impl Element {
    /// The first child named `name`.
    #[must_use]
    pub fn child(&self, name: &str) -> Option<&Element> {
        self.children.iter().find(|c| c.name == name)
    }

    /// All children named `name`.
    pub fn children_named<'a>(&'a self, name: &'a str) -> impl Iterator<Item = &'a Element> + 'a {
        self.children.iter().filter(move |c| c.name == name)
    }

    /// The value of attribute `name`.
    #[must_use]
    pub fn attr(&self, name: &str) -> Option<&str> {
        self.attrs.iter().find(|(k, _)| k == name).map(|(_, v)| v.as_str())
    }
}

/// Parses an XML document into its root element.
///
/// # Errors
/// Malformed XML (quick-xml errors, mismatched or unclosed tags), nesting deeper than 64, no root element.
pub fn parse_xml(text: &str) -> Result<Element, String> {
    let mut reader = Reader::from_str(text);
    reader.config_mut().trim_text(true);
    let mut stack: Vec<Element> = Vec::new();
    let mut root: Option<Element> = None;
    let start = |e: &quick_xml::events::BytesStart<'_>| -> Result<Element, String> {
        let mut el = Element { name: e.local_name().as_ref().to_string(), ..Element::default() };
        for a in e.attributes() {
            let a = a.map_err(|err| format!("bad attribute in <{}>: {err}", el.name))?;
            let v = a
                .normalized_value(quick_xml::XmlVersion::Implicit1_0)
                .map_err(|err| format!("bad attribute value in <{}>: {err}", el.name))?;
            el.attrs.push((a.key.local_name().as_ref().to_string(), v.into_owned()));
        }
        Ok(el)
    };
    loop {
        let pos = reader.buffer_position();
        let ev = reader.read_event().map_err(|e| format!("XML error at byte {pos}: {e}"))?;
        match ev {
            Event::Start(e) => {
                if stack.len() >= MAX_DEPTH {
                    return Err(format!("elements nested deeper than {MAX_DEPTH} at byte {pos}"));
                }
                if root.is_some() && stack.is_empty() {
                    return Err(format!("second root element at byte {pos}"));
                }
                stack.push(start(&e)?);
            }
            Event::Empty(e) => {
                let el = start(&e)?;
                match stack.last_mut() {
                    Some(parent) => parent.children.push(el),
                    None if root.is_none() => root = Some(el),
                    None => return Err(format!("second root element at byte {pos}")),
                }
            }
            Event::End(_) => {
                let el = stack.pop().ok_or_else(|| format!("unexpected closing tag at byte {pos}"))?;
                match stack.last_mut() {
                    Some(parent) => parent.children.push(el),
                    None => root = Some(el),
                }
            }
            Event::Text(t) => {
                if let Some(cur) = stack.last_mut() {
                    cur.text.push_str(t.xml10_content().trim());
                } else if !t.xml10_content().trim().is_empty() {
                    return Err(format!("text outside the root element at byte {pos}"));
                }
            }
            Event::CData(t) => {
                if let Some(cur) = stack.last_mut() {
                    cur.text.push_str(t.xml10_content().trim());
                }
            }
            Event::GeneralRef(r) => {
                let name = r.xml10_content();
                let ch = resolve_entity(&name)
                    .ok_or_else(|| format!("unknown entity reference `&{name};` at byte {pos}"))?;
                if let Some(cur) = stack.last_mut() {
                    cur.text.push(ch);
                }
            }
            Event::Eof => break,
            Event::Comment(_) | Event::Decl(_) | Event::PI(_) | Event::DocType(_) => {}
        }
    }
    if let Some(open) = stack.last() {
        return Err(format!("unexpected end of file inside <{}>: truncated?", open.name));
    }
    root.ok_or_else(|| "no root element".to_string())
}

/// The character of a predefined XML entity (`amp`, `lt`, ...) or a character reference (`#65`, `#x41`).
fn resolve_entity(name: &str) -> Option<char> {
    match name {
        "amp" => Some('&'),
        "lt" => Some('<'),
        "gt" => Some('>'),
        "quot" => Some('"'),
        "apos" => Some('\''),
        _ => {
            let num = name.strip_prefix('#')?;
            let code = match num.strip_prefix('x') {
                Some(hex) => u32::from_str_radix(hex, 16).ok()?,
                None => num.parse().ok()?,
            };
            char::from_u32(code)
        }
    }
}

/// One state of an obstacle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct State {
    /// Time step (integer multiple of the scenario's `timeStepSize`).
    pub time_step: i64,
    /// Position, scenario frame, metres.
    pub x_m: f64,
    /// Position, scenario frame, metres.
    pub y_m: f64,
    /// Orientation, radians.
    pub orientation_rad: f64,
    /// Velocity along the orientation, m/s (may be negative when reversing).
    pub velocity_mps: Option<f64>,
    /// Acceleration along the orientation, m/s^2.
    pub acceleration_mps2: Option<f64>,
}

/// A dynamic obstacle.
#[derive(Clone, Debug, PartialEq)]
pub struct Obstacle {
    /// Obstacle id.
    pub id: u64,
    /// Obstacle type (`car`, `truck`, `pedestrian`, ...).
    pub kind: String,
    /// Rectangle length (or circle diameter), metres.
    pub length_m: f64,
    /// Rectangle width (or circle diameter), metres.
    pub width_m: f64,
    /// Initial state and trajectory, sorted by time step.
    pub states: Vec<State>,
}

/// A parsed scenario.
#[derive(Clone, Debug, PartialEq)]
pub struct Scenario {
    /// `benchmarkID`.
    pub benchmark_id: String,
    /// `commonRoadVersion`.
    pub version: String,
    /// `timeStepSize`, seconds.
    pub time_step_s: f64,
    /// Dynamic obstacles, sorted by id.
    pub obstacles: Vec<Obstacle>,
    /// Static obstacles skipped.
    pub static_obstacles: usize,
}

/// A value that is `<exact>v</exact>` or `<intervalStart>a</intervalStart><intervalEnd>b</intervalEnd>` (mid).
fn value(el: &Element, what: &str) -> Result<f64, String> {
    if let Some(e) = el.child("exact") {
        return parse_f64(&e.text, what);
    }
    match (el.child("intervalStart"), el.child("intervalEnd")) {
        (Some(a), Some(b)) => Ok((parse_f64(&a.text, what)? + parse_f64(&b.text, what)?) / 2.0),
        _ => Err(format!("{what}: neither <exact> nor <intervalStart>/<intervalEnd>")),
    }
}

fn parse_state(st: &Element, ctx: &str) -> Result<State, String> {
    let need = |name: &str| st.child(name).ok_or_else(|| format!("{ctx}: state without <{name}>"));
    let pos = need("position")?;
    let point = pos.child("point").ok_or_else(|| format!("{ctx}: only <position><point> positions are supported"))?;
    let coord = |n: &str| -> Result<f64, String> {
        let c = point.child(n).ok_or_else(|| format!("{ctx}: point without <{n}>"))?;
        parse_f64(&c.text, &format!("{ctx}: {n}"))
    };
    let time = value(need("time")?, &format!("{ctx}: time"))?;
    if time.fract().abs() > 1e-9 || !(0.0..=MAX_TIME_STEP as f64).contains(&time) {
        return Err(format!("{ctx}: time step {time} is not an integer in 0..={MAX_TIME_STEP}"));
    }
    #[allow(clippy::cast_possible_truncation)] // integral and range-checked above
    let time_step = time.round() as i64;
    let opt = |n: &str| st.child(n).map(|e| value(e, &format!("{ctx}: {n}"))).transpose();
    Ok(State {
        time_step,
        x_m: coord("x")?,
        y_m: coord("y")?,
        orientation_rad: value(need("orientation")?, &format!("{ctx}: orientation"))?,
        velocity_mps: opt("velocity")?,
        acceleration_mps2: opt("acceleration")?,
    })
}

fn parse_obstacle(el: &Element) -> Result<Obstacle, String> {
    let id_text = el.attr("id").ok_or_else(|| format!("<{}> without id", el.name))?;
    let id: u64 = id_text.parse().map_err(|_| format!("obstacle id `{id_text}` is not a non-negative integer"))?;
    let ctx = format!("obstacle {id}");
    let kind = el.child("type").map(|t| t.text.clone()).unwrap_or_default();
    let shape = el.child("shape").ok_or_else(|| format!("{ctx}: no <shape>"))?;
    let (length_m, width_m) = if let Some(r) = shape.child("rectangle") {
        let dim = |n: &str| -> Result<f64, String> {
            let d = r.child(n).ok_or_else(|| format!("{ctx}: rectangle without <{n}>"))?;
            parse_f64(&d.text, &format!("{ctx}: {n}"))
        };
        (dim("length")?, dim("width")?)
    } else if let Some(c) = shape.child("circle") {
        let r = c.child("radius").ok_or_else(|| format!("{ctx}: circle without <radius>"))?;
        let d = 2.0 * parse_f64(&r.text, &format!("{ctx}: radius"))?;
        (d, d)
    } else {
        return Err(format!("{ctx}: unsupported shape (rectangle or circle expected)"));
    };
    if !(length_m > 0.0 && width_m > 0.0) {
        return Err(format!("{ctx}: non-positive size {length_m} x {width_m}"));
    }
    let mut states = Vec::new();
    if let Some(init) = el.child("initialState") {
        states.push(parse_state(init, &ctx)?);
    }
    if let Some(tr) = el.child("trajectory") {
        for st in tr.children_named("state") {
            states.push(parse_state(st, &ctx)?);
        }
    }
    states.sort_by_key(|s| s.time_step);
    if let Some(w) = states.windows(2).find(|w| w.first().map(|s| s.time_step) == w.get(1).map(|s| s.time_step)) {
        let step = w.first().map_or(0, |s| s.time_step);
        return Err(format!("{ctx}: two states at time step {step}"));
    }
    Ok(Obstacle { id, kind, length_m, width_m, states })
}

/// Parses a CommonRoad scenario (2018b `<obstacle><role>dynamic</role>` or 2020a `<dynamicObstacle>`).
///
/// # Errors
/// Malformed XML, a root that is not `<commonRoad>`, bad `timeStepSize`, obstacles with missing fields,
/// duplicate obstacle ids.
pub fn parse_scenario(text: &str) -> Result<Scenario, String> {
    let root = parse_xml(text)?;
    if root.name != "commonRoad" {
        return Err(format!("root element is <{}>, expected <commonRoad>", root.name));
    }
    let dt_text = root.attr("timeStepSize").ok_or("<commonRoad> has no timeStepSize")?;
    let time_step_s = parse_f64(dt_text, "timeStepSize")?;
    if !(MIN_TIME_STEP_SIZE_S..=MAX_TIME_STEP_SIZE_S).contains(&time_step_s) {
        // A subnormal step made the motion check's acceleration infinite (issue 15, found by fuzzing).
        return Err(format!(
            "timeStepSize {time_step_s} must be in [{MIN_TIME_STEP_SIZE_S}, {MAX_TIME_STEP_SIZE_S}] s"
        ));
    }
    let mut obstacles = Vec::new();
    let mut static_obstacles = 0usize;
    for el in &root.children {
        let dynamic = match el.name.as_str() {
            "dynamicObstacle" => true,
            "obstacle" => el.child("role").is_some_and(|r| r.text == "dynamic"),
            "staticObstacle" | "environmentObstacle" | "phantomObstacle" => false,
            _ => continue,
        };
        if dynamic {
            obstacles.push(parse_obstacle(el)?);
        } else {
            static_obstacles += 1;
        }
    }
    obstacles.sort_by_key(|o| o.id);
    if let Some(w) = obstacles.windows(2).find(|w| w.first().map(|o| o.id) == w.get(1).map(|o| o.id)) {
        return Err(format!("obstacle id {} appears twice", w.first().map_or(0, |o| o.id)));
    }
    Ok(Scenario {
        benchmark_id: root.attr("benchmarkID").unwrap_or_default().to_string(),
        version: root.attr("commonRoadVersion").unwrap_or_default().to_string(),
        time_step_s,
        obstacles,
        static_obstacles,
    })
}

/// The monitor's class for a CommonRoad obstacle type.
#[must_use]
pub fn class_of(kind: &str) -> ObjectClass {
    match kind {
        "car" | "priorityVehicle" | "parkedVehicle" | "taxi" => ObjectClass::Car,
        "truck" | "bus" | "train" => ObjectClass::Truck,
        "pedestrian" => ObjectClass::Pedestrian,
        "bicycle" => ObjectClass::Cyclist,
        "motorcycle" => ObjectClass::Motorcyclist,
        "constructionZone" | "roadBoundary" | "building" | "pillar" | "median_strip" => ObjectClass::Other,
        _ => ObjectClass::Unknown,
    }
}

/// Reads a CommonRoad XML scenario: one frame per time step from the first to the last state of any dynamic
/// obstacle, timestamp `step * timeStepSize`, objects in the scenario frame, ego pose identity, no clouds.
///
/// Smallest accepted `timeStepSize`, seconds.
pub const MIN_TIME_STEP_SIZE_S: f64 = 1e-4;
/// Largest accepted `timeStepSize`, seconds.
pub const MAX_TIME_STEP_SIZE_S: f64 = 10.0;
/// Most consecutive time steps without any obstacle state (each one becomes an empty frame).
pub const MAX_EMPTY_STEPS: i64 = 1000;

/// # Errors
/// I/O errors, everything [`parse_scenario`] rejects, and gaps of more than [`MAX_EMPTY_STEPS`] time steps,
/// named by file.
pub fn open_scenario(path: &Path) -> Result<Dataset, DatasetError> {
    let text = read_text(path)?;
    let sc = parse_scenario(&text).map_err(|m| DatasetError::malformed(path, m))?;
    let mut per_step: BTreeMap<i64, Vec<(&Obstacle, &State)>> = BTreeMap::new();
    let mut missing_velocity = 0usize;
    for o in &sc.obstacles {
        for s in &o.states {
            per_step.entry(s.time_step).or_default().push((o, s));
        }
    }
    let first = per_step.keys().next().copied().unwrap_or(0);
    let last = per_step.keys().next_back().copied().unwrap_or(-1);
    // Every step between the first and the last becomes a frame: a gap of a million steps in a 515-byte file made
    // a million empty frames (issue 15, found by fuzzing). Gaps are bounded instead.
    let steps: Vec<i64> = per_step.keys().copied().collect();
    if let Some(&[a, b]) = steps.windows(2).find(|w| matches!(w, [a, b] if b - a > MAX_EMPTY_STEPS)) {
        return Err(DatasetError::malformed(
            path,
            format!("time steps jump from {a} to {b}: more than {MAX_EMPTY_STEPS} steps without any obstacle state"),
        ));
    }
    let mut frames = Vec::new();
    for step in first..=last {
        let index = u64::try_from(frames.len()).unwrap_or(u64::MAX);
        #[allow(clippy::cast_precision_loss)] // steps <= MAX_TIME_STEP
        let mut frame = RecordedFrame::empty(index, step as f64 * sc.time_step_s, Pose2::default());
        let mut extras = Vec::new();
        for (o, s) in per_step.get(&step).map(Vec::as_slice).unwrap_or_default() {
            if s.velocity_mps.is_none() {
                missing_velocity += 1;
            }
            frame.objects.push(ObjectState {
                id: o.id,
                class: class_of(&o.kind),
                x_m: f32_of(s.x_m),
                y_m: f32_of(s.y_m),
                heading_rad: f32_of(s.orientation_rad),
                speed_mps: f32_of(s.velocity_mps.unwrap_or(0.0).abs()),
                length_m: f32_of(o.length_m),
                width_m: f32_of(o.width_m),
                uncertainty: None,
            });
            extras.push(ObjectExtra {
                track_key: o.id.to_string(),
                category: o.kind.clone(),
                height_m: None,
                z_center_m: None,
                num_points: None,
                accel_mps2: s.acceleration_mps2.map(f32_of),
            });
        }
        frames.push(DatasetFrame { frame, extras });
    }
    let mut notes = vec![
        format!("CommonRoad {} scenario, timeStepSize {} s", sc.version, sc.time_step_s),
        "no ego vehicle: world_from_ego = identity and objects are given in the scenario (world) frame; no \
         clouds; speed = |state velocity|, heading = state orientation"
            .to_string(),
    ];
    if sc.static_obstacles > 0 {
        notes.push(format!("{} static obstacles skipped", sc.static_obstacles));
    }
    if missing_velocity > 0 {
        notes.push(format!("{missing_velocity} states without velocity get speed 0"));
    }
    let name = if sc.benchmark_id.is_empty() {
        path.file_stem().and_then(|s| s.to_str()).unwrap_or("commonroad").to_string()
    } else {
        sc.benchmark_id.clone()
    };
    Ok(Dataset {
        info: DatasetInfo {
            name,
            format: DatasetFormat::CommonRoad,
            source: path.to_path_buf(),
            ground_z_m: 0.0,
            ego_pose_known: false,
            speed_source: SpeedSource::Dataset,
            frame_period_s: Some(sc.time_step_s),
            notes,
        },
        frames,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const MINI: &str = r#"<?xml version="1.0"?>
<commonRoad benchmarkID="T-1" commonRoadVersion="2020a" timeStepSize="0.1">
  <dynamicObstacle id="7"><type>car</type>
    <shape><rectangle><length>4.5</length><width>1.8</width></rectangle></shape>
    <initialState><position><point><x>1</x><y>2</y></point></position><orientation><exact>0.5</exact></orientation>
      <time><exact>0</exact></time><velocity><exact>-3</exact></velocity><acceleration><exact>0.2</exact></acceleration>
    </initialState>
    <trajectory><state><position><point><x>1.3</x><y>2</y></point></position>
      <orientation><intervalStart>0.4</intervalStart><intervalEnd>0.6</intervalEnd></orientation>
      <time><exact>2</exact></time><velocity><exact>3</exact></velocity></state></trajectory>
  </dynamicObstacle>
  <staticObstacle id="8"/>
</commonRoad>"#;

    #[test]
    fn mini_scenario() {
        let sc = parse_scenario(MINI).unwrap();
        assert_eq!(sc.obstacles.len(), 1);
        assert_eq!(sc.static_obstacles, 1);
        let o = &sc.obstacles[0];
        assert_eq!(o.states.len(), 2);
        assert!((o.states[1].orientation_rad - 0.5).abs() < 1e-12);
        assert_eq!(o.states[1].time_step, 2);
    }

    /// Issue 15 (found by fuzzing): time steps 0 and 1,000,000 in a 515-byte file became 1,000,001 frames.
    #[test]
    fn issue_15_time_step_gap_is_bounded() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("gap.xml");
        std::fs::write(&p, MINI.replace("<exact>2</exact>", "<exact>1000000</exact>")).unwrap();
        let e = open_scenario(&p).map(|_| ()).unwrap_err().to_string();
        assert!(e.contains("gap.xml") && e.contains("jump from 0 to 1000000"), "{e}");
        std::fs::write(&p, MINI.replace("<exact>2</exact>", "<exact>1000</exact>")).unwrap();
        assert_eq!(open_scenario(&p).unwrap().frames.len(), 1001);
    }

    /// Issue 15 (found by fuzzing): a subnormal `timeStepSize` made the motion check's acceleration infinite.
    #[test]
    fn issue_15_subnormal_time_step_size_is_an_error() {
        for dt in ["1e-310", "0", "-0.1", "1e6"] {
            let e =
                parse_scenario(&MINI.replace("timeStepSize=\"0.1\"", &format!("timeStepSize=\"{dt}\""))).unwrap_err();
            assert!(e.contains("timeStepSize"), "{dt}: {e}");
        }
    }

    #[test]
    fn broken_xml_is_an_error() {
        assert!(parse_xml("<a><b></a>").is_err());
        assert!(parse_xml("<a><b>").unwrap_err().contains("truncated"));
        assert!(parse_xml("").is_err());
        assert!(parse_scenario("<other timeStepSize=\"0.1\"/>").is_err());
        assert!(parse_scenario(&MINI.replace("<exact>2</exact>", "<exact>2.5</exact>")).is_err());
        assert!(parse_scenario(&MINI.replace("<x>1.3</x>", "<x>abc</x>")).is_err());
        let deep = "<a>".repeat(100) + &"</a>".repeat(100);
        assert!(parse_xml(&deep).unwrap_err().contains("deeper"));
    }
}
