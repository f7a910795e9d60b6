//! Moving road users: vehicles (cars, vans, trucks, cyclists, the ego) on lane routes with the intelligent driver
//! model, traffic lights and left-turn yielding; pedestrians walking the sidewalks, stopping and crossing.
//!
//! Every agent decides on the previous step's snapshot of all agents (a synchronous update), in index order, with
//! one seeded random stream: the evolution is deterministic.

use std::f64::consts::{FRAC_PI_2, PI};

use pmon_monitor::ObjectClass;
use rand::RngExt;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

use crate::config::{EgoMode, Layout, ScenarioConfig, Turn};
use crate::geom::{wrap_angle, Box3};
use crate::world::{Route, World};

/// Hardest braking any agent does, m/s^2 (the paper's physical limit is 7).
pub(crate) const MAX_BRAKE: f64 = 6.5;

/// Kind of vehicle (sizes and driving parameters).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum VehicleKind {
    Car,
    Van,
    Truck,
    Bike,
    Ego,
}

impl VehicleKind {
    fn class(self) -> ObjectClass {
        match self {
            Self::Car | Self::Ego => ObjectClass::Car,
            Self::Van | Self::Truck => ObjectClass::Truck,
            Self::Bike => ObjectClass::Cyclist,
        }
    }
}

/// A vehicle's driving state.
#[derive(Clone, Debug)]
pub(crate) struct Vehicle {
    pub kind: VehicleKind,
    pub route: Route,
    /// Arc length of the box centre along the route, metres.
    pub s: f64,
    /// Desired speed, m/s.
    v0: f64,
    /// Comfortable acceleration and braking, m/s^2.
    a_max: f64,
    b_comf: f64,
    /// Time headway, seconds.
    headway: f64,
    /// Ego: stop for good at this arc length.
    stop_at: Option<f64>,
    /// Ego waiting (warm-up, or `mode = "wait"`).
    pub frozen: bool,
}

#[derive(Clone, Copy, Debug)]
struct Crossing {
    to_strip: usize,
    u_from: f64,
    u_to: f64,
    at_crosswalk: bool,
}

#[derive(Clone, Copy, Debug)]
enum PedMode {
    Walk,
    Stop { until_s: f64 },
    WaitCross(Crossing),
    Cross(Crossing),
}

/// A pedestrian's walking state.
#[derive(Clone, Debug)]
pub(crate) struct Pedestrian {
    strip: usize,
    v_pref: f64,
    /// Preferred distance from the kerb on sidewalks, metres.
    lane_v: f64,
    mode: PedMode,
    /// Waypoints, next last.
    waypoints: Vec<[f64; 2]>,
    pending: Option<Crossing>,
    wander: f64,
}

/// How an agent moves.
#[derive(Clone, Debug)]
pub(crate) enum Behaviour {
    Parked,
    Vehicle(Vehicle),
    Pedestrian(Pedestrian),
}

/// A road user (or parked car).
#[derive(Clone, Debug)]
pub(crate) struct Agent {
    pub id: u64,
    pub class: ObjectClass,
    /// Length, width, height, metres.
    pub size: [f64; 3],
    pub x: f64,
    pub y: f64,
    /// Direction of motion = box yaw, radians (wrapped).
    pub heading: f64,
    /// Ground speed, m/s, >= 0.
    pub speed: f64,
    /// Longitudinal acceleration over the last step, m/s^2.
    pub accel: f64,
    /// Turn rate over the last step, rad/s.
    pub turn_rate: f64,
    pub active: bool,
    pub behaviour: Behaviour,
}

impl Agent {
    /// The agent's 3D box.
    pub(crate) fn box3(&self) -> Box3 {
        Box3 {
            cx: self.x,
            cy: self.y,
            yaw: self.heading,
            half_l: self.size[0] / 2.0,
            half_w: self.size[1] / 2.0,
            z0: 0.0,
            z1: self.size[2],
        }
    }
}

/// What other agents see of an agent.
#[derive(Clone, Copy, Debug)]
struct Snap {
    active: bool,
    kind: SnapKind,
    x: f64,
    y: f64,
    heading: f64,
    speed: f64,
    half_l: f64,
    half_w: f64,
    /// Pedestrians: crossing the road now.
    crossing: bool,
    /// Vehicles: entry arm, turn, s, stop_s, box_exit_s.
    route: Option<(usize, Turn, f64, Option<f64>, f64)>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum SnapKind {
    Vehicle,
    Pedestrian,
    Parked,
}

fn snap(a: &Agent) -> Snap {
    let (kind, route) = match &a.behaviour {
        Behaviour::Parked => (SnapKind::Parked, None),
        Behaviour::Pedestrian(_) => (SnapKind::Pedestrian, None),
        Behaviour::Vehicle(v) => {
            (SnapKind::Vehicle, Some((v.route.entry, v.route.turn, v.s, v.route.stop_s, v.route.box_exit_s)))
        }
    };
    Snap {
        active: a.active,
        kind,
        x: a.x,
        y: a.y,
        heading: a.heading,
        speed: a.speed,
        half_l: a.size[0] / 2.0,
        half_w: a.size[1] / 2.0,
        crossing: matches!(&a.behaviour, Behaviour::Pedestrian(p) if matches!(p.mode, PedMode::Cross(_))),
        route,
    }
}

/// All agents and their shared state.
pub(crate) struct Traffic {
    pub ego: Agent,
    pub agents: Vec<Agent>,
    next_id: u64,
    rng: ChaCha8Rng,
    crossing_probability: f64,
    stop_probability: f64,
    speed_limit: f64,
    /// Pedestrians keep within this band of u on residential strips (near the ego's drive).
    ped_u_range: (f64, f64),
    snaps: Vec<Snap>,
}

fn draw_vehicle(kind: VehicleKind, rng: &mut ChaCha8Rng) -> [f64; 3] {
    match kind {
        VehicleKind::Car | VehicleKind::Ego => {
            [rng.random_range(3.8..5.0), rng.random_range(1.7..2.0), rng.random_range(1.4..1.7)]
        }
        VehicleKind::Van => [rng.random_range(5.0..6.5), rng.random_range(1.9..2.2), rng.random_range(2.0..2.7)],
        VehicleKind::Truck => [rng.random_range(7.0..10.0), rng.random_range(2.4..2.55), rng.random_range(3.0..3.8)],
        VehicleKind::Bike => [rng.random_range(1.6..1.9), rng.random_range(0.6..0.8), rng.random_range(1.6..1.9)],
    }
}

fn draw_pedestrian(rng: &mut ChaCha8Rng) -> [f64; 3] {
    let h: f64 = 1.72 + 0.09 * rng.sample::<f64, _>(StandardNormal);
    [rng.random_range(0.5..0.9), rng.random_range(0.55..0.8), h.clamp(1.4, 2.0)]
}

impl Traffic {
    /// Spawns the parked cars, the ego, the vehicles and the pedestrians of a validated scenario.
    pub(crate) fn new(cfg: &ScenarioConfig, world: &World, mut rng: ChaCha8Rng) -> Self {
        let speed_limit = cfg.speed_limit_mps();
        // Ego on the eastbound lane (entry 0).
        let ego_route = world.route(0, cfg.ego.route, false);
        let ego_s = (world.half_length - cfg.ego_start_m()).max(0.0);
        let stop_at = (cfg.ego.stop_after_m > 0.0).then_some(ego_s + cfg.ego.stop_after_m);
        let ego_v = Vehicle {
            kind: VehicleKind::Ego,
            s: ego_s,
            v0: cfg.ego_max_speed_mps(),
            a_max: 1.5,
            b_comf: 2.5,
            headway: 1.5,
            stop_at,
            frozen: true,
            route: ego_route,
        };
        let mut ego = Agent {
            id: 0,
            class: ObjectClass::Car,
            size: [cfg.ego.length_m, cfg.ego.width_m, 1.6],
            x: 0.0,
            y: 0.0,
            heading: 0.0,
            speed: 0.0,
            accel: 0.0,
            turn_rate: 0.0,
            active: true,
            behaviour: Behaviour::Vehicle(ego_v),
        };
        place_vehicle(&mut ego);

        let mut agents = Vec::new();
        let mut next_id = 1;
        for b in &world.parked {
            agents.push(Agent {
                id: next_id,
                class: ObjectClass::Car,
                size: [2.0 * b.half_l, 2.0 * b.half_w, b.z1],
                x: b.cx,
                y: b.cy,
                heading: wrap_angle(b.yaw),
                speed: 0.0,
                accel: 0.0,
                turn_rate: 0.0,
                active: true,
                behaviour: Behaviour::Parked,
            });
            next_id += 1;
        }

        let ped_u_range = match cfg.layout {
            Layout::Residential => {
                let x0 = -cfg.ego_start_m() - 40.0;
                let drive = if cfg.ego.mode == EgoMode::Wait { 0.0 } else { cfg.ego_max_speed_mps() * cfg.duration_s };
                let x1 = -cfg.ego_start_m() + drive + 50.0;
                let l = world.half_length;
                ((x0 + l).clamp(2.0, 2.0 * l - 2.0), (x1 + l).clamp(2.0, 2.0 * l - 2.0))
            }
            Layout::Intersection => (2.0, (world.half_length - world.hw - 2.0).min(50.0)),
        };

        let mut t = Self {
            ego,
            agents,
            next_id,
            rng: ChaCha8Rng::seed_from_u64(0),
            crossing_probability: cfg.agents.crossing_probability,
            stop_probability: cfg.agents.stop_probability,
            speed_limit,
            ped_u_range,
            snaps: Vec::new(),
        };
        let a = &cfg.agents;
        let kinds = std::iter::repeat_n(VehicleKind::Car, a.cars as usize)
            .chain(std::iter::repeat_n(VehicleKind::Van, a.vans as usize))
            .chain(std::iter::repeat_n(VehicleKind::Truck, a.trucks as usize))
            .chain(std::iter::repeat_n(VehicleKind::Bike, a.cyclists as usize));
        for kind in kinds {
            let agent = t.new_vehicle(kind, world, &mut rng, true);
            t.agents.push(agent);
        }
        for _ in 0..cfg.agents.pedestrians {
            let agent = t.new_pedestrian(world, &mut rng);
            t.agents.push(agent);
        }
        t.rng = rng;
        t
    }

    fn take_id(&mut self) -> u64 {
        let id = self.next_id;
        self.next_id += 1;
        id
    }

    fn random_turn(kind: VehicleKind, world: &World, rng: &mut ChaCha8Rng) -> Turn {
        if world.layout == Layout::Residential {
            return Turn::Straight;
        }
        let r: f64 = rng.random();
        // Single-lane approaches: a left turner waiting for a gap blocks its lane, as on real two-lane streets.
        let (p_left, p_right) = if kind == VehicleKind::Truck { (0.08, 0.15) } else { (0.12, 0.22) };
        if r < p_left {
            Turn::Left
        } else if r < p_left + p_right {
            Turn::Right
        } else {
            Turn::Straight
        }
    }

    /// A vehicle on a random route: anywhere before the stop line (`initial`) or at the route's start.
    /// Inactive when no free spot was found.
    fn new_vehicle(&mut self, kind: VehicleKind, world: &World, rng: &mut ChaCha8Rng, initial: bool) -> Agent {
        let size = draw_vehicle(kind, rng);
        let entries = world.entries();
        let entry = entries[rng.random_range(0..entries.len())];
        let turn = Self::random_turn(kind, world, rng);
        let route = world.route(entry, turn, kind == VehicleKind::Bike);
        let v0 = match kind {
            VehicleKind::Bike => rng.random_range(4.0..6.5),
            VehicleKind::Truck => self.speed_limit * rng.random_range(0.8..0.95),
            _ => self.speed_limit * rng.random_range(0.85..1.05),
        };
        let (a_max, b_comf, headway) = match kind {
            VehicleKind::Truck => (1.0, 2.0, 1.8),
            VehicleKind::Van => (1.5, 2.5, 1.5),
            VehicleKind::Bike => (1.0, 2.0, 1.0),
            _ => (rng.random_range(1.5..2.5), rng.random_range(2.5..3.5), rng.random_range(1.0..1.6)),
        };
        let mut s = 0.0;
        let mut active = false;
        if initial {
            let last = route.stop_s.unwrap_or(route.path.length) - 10.0;
            for _ in 0..20 {
                let cand = rng.random_range(size[0]..last.max(size[0] + 1.0));
                let (x, y, _, _) = route.path.pose(cand);
                if self.spot_free(x, y, size[0] / 2.0 + 6.0) {
                    s = cand;
                    active = true;
                    break;
                }
            }
        } else {
            let (x, y, _, _) = route.path.pose(0.0);
            active = self.spot_free(x, y, size[0] / 2.0 + 15.0);
        }
        let vehicle = Vehicle { kind, route, s, v0, a_max, b_comf, headway, stop_at: None, frozen: false };
        let mut agent = Agent {
            id: self.take_id(),
            class: kind.class(),
            size,
            x: 0.0,
            y: 0.0,
            heading: 0.0,
            speed: 0.0,
            accel: 0.0,
            turn_rate: 0.0,
            active,
            behaviour: Behaviour::Vehicle(vehicle),
        };
        place_vehicle(&mut agent);
        if active {
            agent.speed = (v0 * 0.6).min(if initial { 5.0 } else { v0 });
        }
        agent
    }

    /// True when no moving agent (or the ego) is within `r` metres of `(x, y)`.
    fn spot_free(&self, x: f64, y: f64, r: f64) -> bool {
        std::iter::once(&self.ego)
            .chain(self.agents.iter())
            .filter(|a| a.active && matches!(a.behaviour, Behaviour::Vehicle(_)))
            .all(|a| (a.x - x).hypot(a.y - y) > r + a.size[0] / 2.0)
    }

    fn new_pedestrian(&mut self, world: &World, rng: &mut ChaCha8Rng) -> Agent {
        let size = draw_pedestrian(rng);
        let strip_i = rng.random_range(0..world.strips.len());
        let strip = &world.strips[strip_i];
        let (u0, u1) = self.ped_u_range;
        let u = rng.random_range(u0.min(strip.length - 1.0)..u1.min(strip.length - 0.5).max(u0 + 0.5));
        let lane_v = rng.random_range(1.3..(world.sidewalk_w - 0.5).max(1.4));
        let p = strip.point(u, lane_v);
        let dir = if rng.random_bool(0.5) { 0.0 } else { PI };
        let heading = wrap_angle(strip.dir[1].atan2(strip.dir[0]) + dir);
        let v_pref: f64 = (1.3 + 0.25 * rng.sample::<f64, _>(StandardNormal)).clamp(0.6, 1.9);
        let ped = Pedestrian {
            strip: strip_i,
            v_pref,
            lane_v,
            mode: PedMode::Walk,
            waypoints: Vec::new(),
            pending: None,
            wander: 0.0,
        };
        Agent {
            id: self.take_id(),
            class: ObjectClass::Pedestrian,
            size,
            x: p[0],
            y: p[1],
            heading,
            speed: if rng.random_bool(0.7) { v_pref } else { 0.0 },
            accel: 0.0,
            turn_rate: 0.0,
            active: true,
            behaviour: Behaviour::Pedestrian(ped),
        }
    }

    /// Advances every agent by `dt` seconds; `t` is the time at the end of the step.
    pub(crate) fn step(&mut self, world: &World, t: f64, dt: f64) {
        self.snaps.clear();
        self.snaps.push(snap(&self.ego));
        let snaps_agents: Vec<Snap> = self.agents.iter().map(snap).collect();
        self.snaps.extend(snaps_agents);
        let signal = world.signal(t);

        let snaps = std::mem::take(&mut self.snaps);
        step_vehicle_agent(&mut self.ego, 0, &snaps, signal, dt);
        let mut respawn = Vec::new();
        for (i, agent) in self.agents.iter_mut().enumerate() {
            if !agent.active {
                if matches!(agent.behaviour, Behaviour::Vehicle(_)) {
                    respawn.push(i);
                }
                continue;
            }
            match agent.behaviour {
                Behaviour::Parked => {}
                Behaviour::Vehicle(_) => {
                    step_vehicle_agent(agent, i + 1, &snaps, signal, dt);
                    if let Behaviour::Vehicle(v) = &agent.behaviour {
                        if v.s >= v.route.path.length - 0.5 {
                            agent.active = false;
                        }
                    }
                }
                Behaviour::Pedestrian(_) => {
                    let ctx = PedCtx {
                        world,
                        snaps: &snaps,
                        signal,
                        t,
                        dt,
                        p_cross: self.crossing_probability,
                        p_stop: self.stop_probability,
                        u_range: self.ped_u_range,
                    };
                    step_pedestrian(agent, &ctx, &mut self.rng);
                }
            }
        }
        self.snaps = snaps;
        // Vehicles that left the world come back at a random entry, with a new id, when the entry is clear.
        for i in respawn {
            let Some(Behaviour::Vehicle(v)) = self.agents.get(i).map(|a| &a.behaviour) else { continue };
            let kind = v.kind;
            let mut rng = std::mem::replace(&mut self.rng, ChaCha8Rng::seed_from_u64(0));
            let fresh = self.new_vehicle(kind, world, &mut rng, false);
            self.rng = rng;
            if fresh.active {
                if let Some(slot) = self.agents.get_mut(i) {
                    *slot = fresh;
                }
            } else {
                // Not placed: give the id back so ids stay dense and deterministic.
                self.next_id -= 1;
            }
        }
    }

    /// Releases the ego (end of warm-up) unless it is told to wait.
    pub(crate) fn release_ego(&mut self, mode: EgoMode) {
        if let Behaviour::Vehicle(v) = &mut self.ego.behaviour {
            v.frozen = mode == EgoMode::Wait;
        }
    }
}

use rand::SeedableRng;

/// Sets position and heading of a vehicle from its route and arc length.
fn place_vehicle(a: &mut Agent) {
    if let Behaviour::Vehicle(v) = &a.behaviour {
        let (x, y, h, _) = v.route.path.pose(v.s);
        a.x = x;
        a.y = y;
        a.heading = wrap_angle(h);
    }
}

/// IDM acceleration towards an obstacle `gap` metres ahead moving at `v_lead` (or free road without one).
fn idm(v: f64, v0: f64, a_max: f64, b: f64, headway: f64, obstacle: Option<(f64, f64)>) -> f64 {
    let free = if v0 > 0.05 { 1.0 - (v / v0).powi(4) } else { -1.0 };
    let inter = match obstacle {
        Some((gap, v_lead)) => {
            let s_star = 2.0 + (v * headway + v * (v - v_lead) / (2.0 * (a_max * b).sqrt())).max(0.0);
            (s_star / gap.max(0.05)).powi(2)
        }
        None => 0.0,
    };
    a_max * (free - inter)
}

fn step_vehicle_agent(agent: &mut Agent, self_index: usize, snaps: &[Snap], signal: (Option<usize>, f64), dt: f64) {
    let (half_l, half_w) = (agent.size[0] / 2.0, agent.size[1] / 2.0);
    let (speed, heading) = (agent.speed, agent.heading);
    let Behaviour::Vehicle(veh) = &mut agent.behaviour else { return };
    if veh.frozen {
        agent.accel = 0.0;
        agent.turn_rate = 0.0;
        agent.speed = 0.0;
        return;
    }
    let v = speed;
    let s = veh.s;
    let path = &veh.route.path;
    let v0 = veh.v0.min(path.vmax_at(s)).min(path.vmax_at(s + half_l));
    let mut obstacles: Vec<(f64, f64)> = Vec::new();

    // Other road users ahead in the corridor.
    let look = (v * v / (2.0 * veh.b_comf) + 25.0).max(35.0);
    for (j, o) in snaps.iter().enumerate() {
        if j == self_index || !o.active || o.kind == SnapKind::Parked {
            continue;
        }
        if (o.x - agent.x).hypot(o.y - agent.y) > look + 15.0 {
            continue;
        }
        if o.kind == SnapKind::Vehicle && wrap_angle(o.heading - heading).abs() > 75f64.to_radians() {
            continue;
        }
        // Pedestrians: where they are, and (crossing ones) where they will be in 1.5, 3 and 4.5 s.
        let mut candidates = [(o.x, o.y, o.speed); 4];
        let horizon = if o.crossing { 4 } else { 2 };
        if o.kind == SnapKind::Pedestrian {
            let (sn, cs) = o.heading.sin_cos();
            for (k, c) in candidates.iter_mut().enumerate().skip(1) {
                let t = 1.5 * k as f64;
                *c = (o.x + cs * o.speed * t, o.y + sn * o.speed * t, 0.0);
            }
        }
        let n_cand = if o.kind == SnapKind::Pedestrian { horizon } else { 1 };
        for (k, &(px, py, ov)) in candidates.iter().enumerate().take(n_cand) {
            if px.is_nan() {
                continue;
            }
            let Some((sj, lat, ph)) = path.project(px, py, s, s + look) else { continue };
            if sj <= s {
                continue;
            }
            let d = wrap_angle(o.heading - ph);
            let ext_lat = o.half_l * d.sin().abs() + o.half_w * d.cos().abs();
            let ext_long = o.half_l * d.cos().abs() + o.half_w * d.sin().abs();
            let margin = if k >= 1 { 0.5 } else { 0.3 };
            if lat.abs() > half_w + ext_lat + margin {
                continue;
            }
            let v_lead = if k >= 1 { 0.0 } else { (ov * d.cos()).max(0.0) };
            obstacles.push((sj - s - half_l - ext_long, v_lead));
        }
    }

    // Traffic light, box blocking, left-turn yielding.
    let front = s + half_l;
    if let Some(stop) = veh.route.stop_s {
        let phase = veh.route.phase();
        if front < stop + 0.3 {
            let green = signal.0 == Some(phase);
            let box_busy = snaps.iter().enumerate().any(|(j, o)| {
                j != self_index
                    && o.active
                    && o.route.is_some_and(|(entry, _, os, ostop, oexit)| {
                        entry % 2 != phase && ostop.is_some_and(|st| os + o.half_l > st && os - o.half_l < oexit)
                    })
            });
            if !green || box_busy {
                // The obstacle sits 1.5 m beyond the line: IDM keeps its 2 m standstill gap, so the front stops
                // 0.5 m before the line.
                let d = stop - front;
                let can_stop = d > 0.0 && v * v / (2.0 * d) <= 4.0;
                if can_stop || v < 1.0 || box_busy {
                    obstacles.push(((d + 1.5).max(0.05), 0.0));
                }
            }
        }
        if let Some(gate) = veh.route.gate_s {
            let opposing = (veh.route.entry + 2) % 4;
            if front < gate {
                let conflict = snaps.iter().enumerate().any(|(j, o)| {
                    if j == self_index || !o.active {
                        return false;
                    }
                    let Some((entry, turn, os, Some(ostop), oexit)) = o.route else { return false };
                    if entry != opposing || turn == Turn::Left || os - o.half_l > oexit {
                        return false;
                    }
                    let ofront = os + o.half_l;
                    if ofront >= ostop {
                        return true;
                    }
                    let dist = ostop - ofront;
                    if signal.0 == Some(phase) {
                        // Oncoming traffic that is moving and due within 4 s (a queue standing at the line is
                        // waiting for something else: going first breaks the deadlock).
                        o.speed > 1.0 && dist < 60.0 && dist / o.speed < 4.0
                    } else {
                        o.speed * o.speed / (2.0 * dist.max(0.05)) > 4.5
                    }
                });
                if conflict {
                    obstacles.push(((gate - front + 1.5).max(0.05), 0.0));
                }
            }
        }
    }
    // End of the route: the ego stops; others drive off (and respawn).
    if veh.kind == VehicleKind::Ego {
        let end = veh.stop_at.unwrap_or(path.length - 1.0).min(path.length - 1.0);
        obstacles.push(((end - front).max(0.05), 0.0));
    }

    let mut a = idm(v, v0, veh.a_max, veh.b_comf, veh.headway, None);
    for &ob in &obstacles {
        a = a.min(idm(v, v0, veh.a_max, veh.b_comf, veh.headway, Some(ob)));
    }
    let a = a.clamp(-MAX_BRAKE, veh.a_max);
    let v_new = (v + a * dt).max(0.0);
    veh.s += 0.5 * (v + v_new) * dt;
    let (x, y, h, _) = path.pose(veh.s);
    agent.accel = (v_new - v) / dt;
    agent.speed = v_new;
    agent.turn_rate = wrap_angle(h - heading) / dt;
    agent.x = x;
    agent.y = y;
    agent.heading = wrap_angle(h);
}

struct PedCtx<'a> {
    world: &'a World,
    snaps: &'a [Snap],
    signal: (Option<usize>, f64),
    t: f64,
    dt: f64,
    p_cross: f64,
    p_stop: f64,
    u_range: (f64, f64),
}

/// Largest pedestrian turn rate, rad/s, and its rate of change, rad/s^2.
const PED_TURN_RATE: f64 = 1.6;
const PED_TURN_ACCEL: f64 = 6.0;

fn step_pedestrian(agent: &mut Agent, ctx: &PedCtx<'_>, rng: &mut ChaCha8Rng) {
    let (x, y) = (agent.x, agent.y);
    let Behaviour::Pedestrian(ped) = &mut agent.behaviour else { return };
    let world = ctx.world;

    // Mode transitions.
    match ped.mode {
        PedMode::Stop { until_s } if ctx.t >= until_s => choose_goal(ped, [x, y], ctx, rng),
        PedMode::WaitCross(c) => {
            if crossing_clear(ped.strip, c, [x, y], ctx) {
                let to = &world.strips[c.to_strip];
                ped.waypoints = vec![to.point(c.u_to, ped.lane_v), to.point(c.u_to, 0.4)];
                ped.mode = PedMode::Cross(c);
            }
        }
        PedMode::Walk | PedMode::Cross(_) => {
            let reach = (agent.speed * ctx.dt * 1.5).max(0.3);
            while let Some(wp) = ped.waypoints.last() {
                if (wp[0] - x).hypot(wp[1] - y) < reach {
                    ped.waypoints.pop();
                } else {
                    break;
                }
            }
            if ped.waypoints.is_empty() {
                if let PedMode::Cross(c) = ped.mode {
                    ped.strip = c.to_strip;
                    ped.mode = PedMode::Walk;
                }
                if let Some(c) = ped.pending.take() {
                    ped.mode = PedMode::WaitCross(c);
                } else {
                    choose_goal(ped, [x, y], ctx, rng);
                }
            }
        }
        PedMode::Stop { .. } => {}
    }

    // Desired heading and speed.
    let (mut desired, mut v_target) = (agent.heading, 0.0);
    match ped.mode {
        PedMode::Walk | PedMode::Cross(_) => {
            if let Some(wp) = ped.waypoints.last() {
                desired = (wp[1] - y).atan2(wp[0] - x);
                v_target = if matches!(ped.mode, PedMode::Cross(_)) { ped.v_pref.max(1.2) } else { ped.v_pref };
                if ped.waypoints.len() == 1 && ped.pending.is_none() {
                    let d = (wp[0] - x).hypot(wp[1] - y);
                    v_target = v_target.min((2.0 * 0.8 * d).sqrt() + 0.2);
                }
            }
        }
        PedMode::WaitCross(c) => {
            let to = world.strips[c.to_strip].point(c.u_to, 0.0);
            desired = (to[1] - y).atan2(to[0] - x);
        }
        PedMode::Stop { .. } => {}
    }
    if matches!(ped.mode, PedMode::Walk) {
        let n: f64 = rng.sample(StandardNormal);
        ped.wander += -ped.wander / 3.0 * ctx.dt + 0.05 * ctx.dt.sqrt() * n;
    } else {
        ped.wander *= 1.0 - ctx.dt;
    }
    desired += ped.wander;
    let err = wrap_angle(desired - agent.heading);
    let w_target = (2.5 * err).clamp(-PED_TURN_RATE, PED_TURN_RATE);
    let dw = PED_TURN_ACCEL * ctx.dt;
    let w = w_target.clamp(agent.turn_rate - dw, agent.turn_rate + dw);
    if err.abs() > FRAC_PI_2 {
        v_target *= 0.2;
    } else {
        v_target *= err.cos().max(0.2);
    }
    let a = ((v_target - agent.speed) / ctx.dt).clamp(-1.5, 1.0);
    let v_new = (agent.speed + a * ctx.dt).max(0.0);
    let h_new = wrap_angle(agent.heading + w * ctx.dt);
    let (sn, cs) = h_new.sin_cos();
    let v_mid = 0.5 * (agent.speed + v_new);
    agent.x += cs * v_mid * ctx.dt;
    agent.y += sn * v_mid * ctx.dt;
    agent.accel = (v_new - agent.speed) / ctx.dt;
    agent.speed = v_new;
    agent.turn_rate = w;
    agent.heading = h_new;
}

/// Picks what a pedestrian does next: stop, cross, turn the corner or walk on.
fn choose_goal(ped: &mut Pedestrian, p: [f64; 2], ctx: &PedCtx<'_>, rng: &mut ChaCha8Rng) {
    let world = ctx.world;
    let strip = &world.strips[ped.strip];
    let (u, _) = strip.coords(p);
    let (u_lo, u_hi) = (ctx.u_range.0.min(strip.length - 2.0), ctx.u_range.1.min(strip.length - 2.0));
    let r: f64 = rng.random();
    ped.mode = PedMode::Walk;
    ped.pending = None;
    ped.waypoints.clear();
    if r < ctx.p_stop {
        ped.mode = PedMode::Stop { until_s: ctx.t + rng.random_range(1.0..6.0) };
        return;
    }
    if r < ctx.p_stop + ctx.p_cross {
        if let Some(c) = plan_crossing(ped.strip, u, world, rng) {
            ped.waypoints = vec![strip.point(c.u_from, 0.4), strip.point(c.u_from, ped.lane_v)];
            ped.pending = Some(c);
            return;
        }
    }
    // Around the corner (intersection), or along this sidewalk.
    if let Some(partner) = strip.partner {
        if u < 20.0 && rng.random_bool(0.4) {
            let other = &world.strips[partner];
            let u2 = rng.random_range(4.0..u_hi.max(5.0));
            ped.waypoints = vec![other.point(u2, ped.lane_v), strip.corner];
            ped.strip = partner;
            return;
        }
    }
    let du = rng.random_range(5.0..25.0) * if rng.random_bool(0.5) { 1.0 } else { -1.0 };
    let mut u2 = u + du;
    if u2 < u_lo || u2 > u_hi {
        u2 = u - du;
    }
    let u2 = u2.clamp(u_lo, u_hi.max(u_lo));
    let v2 = (ped.lane_v + rng.random_range(-0.3..0.3)).clamp(1.1, world.sidewalk_w - 0.4);
    ped.waypoints = vec![strip.point(u2, v2)];
}

fn nearest_crosswalk(strip: &crate::world::Strip, u: f64) -> Option<f64> {
    strip.crosswalks_u.iter().copied().min_by(|a, b| (a - u).abs().total_cmp(&(b - u).abs()))
}

/// A crossing from `strip` near `u`: at a crosswalk within reach, else straight across where the kerb is clear.
fn plan_crossing(strip_i: usize, u: f64, world: &World, rng: &mut ChaCha8Rng) -> Option<Crossing> {
    let strip = &world.strips[strip_i];
    let to_strip = strip.opposite;
    let other = &world.strips[to_strip];
    let reach = if world.layout == Layout::Intersection { 15.0 } else { 25.0 };
    if let Some(cw) = nearest_crosswalk(strip, u) {
        if (cw - u).abs() < reach && (world.layout == Layout::Intersection || rng.random_bool(0.5)) {
            return Some(Crossing { to_strip, u_from: cw, u_to: cw, at_crosswalk: true });
        }
    }
    if world.layout == Layout::Intersection && u < 20.0 {
        return None;
    }
    // Nearest kerb gap on both sides, within 10 m.
    for k in 0..40 {
        let du = f64::from(k / 2) * 0.5 * if k % 2 == 0 { 1.0 } else { -1.0 };
        let uf = u + du;
        if strip.crossing_free(uf) {
            let ut = uf + rng.random_range(-2.0..2.0);
            if other.crossing_free(ut) {
                return Some(Crossing { to_strip, u_from: uf, u_to: ut, at_crosswalk: false });
            }
        }
    }
    None
}

/// True when a pedestrian waiting at the kerb may cross now.
fn crossing_clear(strip_i: usize, c: Crossing, p: [f64; 2], ctx: &PedCtx<'_>) -> bool {
    let world = ctx.world;
    if world.layout == Layout::Intersection && c.at_crosswalk {
        // Crossing arm k is parallel to the other road's traffic.
        let allowed = (strip_i / 2 + 1) % 2;
        if ctx.signal.0 != Some(allowed) || world.green_s - ctx.signal.1 > world.walk_s {
            return false;
        }
    }
    let to = world.strips[c.to_strip].point(c.u_to, 0.4);
    let mid = [(p[0] + to[0]) / 2.0, (p[1] + to[1]) / 2.0];
    let tta_limit = if c.at_crosswalk { 3.0 } else { 8.0 };
    ctx.snaps.iter().all(|o| {
        if !o.active || o.kind != SnapKind::Vehicle {
            return true;
        }
        if segment_distance([o.x, o.y], p, to) < o.half_l + 1.0 {
            return false;
        }
        if o.speed < 0.3 {
            return true;
        }
        let (sn, cs) = o.heading.sin_cos();
        let (dx, dy) = (mid[0] - o.x, mid[1] - o.y);
        let along = cs * dx + sn * dy;
        let across = (-sn * dx + cs * dy).abs();
        !(along > -o.half_l && across < 15.0 && (along - o.half_l) / o.speed < tta_limit)
    })
}

fn segment_distance(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let (abx, aby) = (b[0] - a[0], b[1] - a[1]);
    let len2 = abx * abx + aby * aby;
    let t = if len2 > 0.0 { (((p[0] - a[0]) * abx + (p[1] - a[1]) * aby) / len2).clamp(0.0, 1.0) } else { 0.0 };
    (p[0] - a[0] - t * abx).hypot(p[1] - a[1] - t * aby)
}
