//! A ground station inside the test: talks to a [`Simulation`] through the
//! same `Inbound`/`Outbound` messages the link layer carries.
#![allow(dead_code, unused_imports)]

use std::time::Duration;

use autopilot::sitl::gcs;
use autopilot::sitl::simulation::{ModelKind, Simulation, SimulationConfig, SimulationParams};
use autopilot::time::FrozenTimer;
use autopilot::vehicle::Outbound;
use mavlink::dialects::ardupilotmega::{MavCmd, MavMessage};
use mission::command::{cmd, frame};
use mission::{MissionItem, MissionType, Plan};

pub struct Harness {
    pub sim: Simulation,
    pub received: Vec<Outbound>,
    /// What the link layer would answer mission downloads from after the
    /// last step.
    pub published_downloads: Option<std::sync::Arc<mission::Downloads>>,
    timer: FrozenTimer,
}

impl Harness {
    pub fn new(seed: u64, model: ModelKind) -> Self {
        Self::with_config(SimulationConfig {
            seed,
            model,
            ..SimulationConfig::default()
        })
    }

    /// A vehicle simulated as `config` says (without an IMU, say).
    pub fn with_config(config: SimulationConfig) -> Self {
        let mut sim = Simulation::new(&config, SimulationParams::new(config.model));
        gcs::connect(&mut sim);
        Harness {
            sim,
            received: Vec::new(),
            published_downloads: None,
            timer: FrozenTimer,
        }
    }

    /// Steps one tick; wall time follows simulated time so runs replay.
    pub fn step(&mut self) {
        let wall = self.sim.time();
        let out = self.sim.step(wall, &mut self.timer);
        self.received.append(&mut out.mavlink);
        self.published_downloads.clone_from(&out.mission_downloads);
    }

    pub fn run_for(&mut self, seconds: f64) {
        let end = self.sim.time() + Duration::from_secs_f64(seconds);
        while self.sim.time() < end {
            self.step();
        }
    }

    /// Steps until `done` or the time limit; returns whether `done` held.
    pub fn run_until(&mut self, seconds: f64, mut done: impl FnMut(&Simulation) -> bool) -> bool {
        let end = self.sim.time() + Duration::from_secs_f64(seconds);
        while self.sim.time() < end {
            self.step();
            if done(&self.sim) {
                return true;
            }
        }
        false
    }

    pub fn send(&mut self, message: MavMessage) {
        gcs::send(&mut self.sim, message);
    }

    pub fn command(&mut self, command: MavCmd, params: [f32; 7]) {
        self.send(gcs::command_long(command, params));
    }

    pub fn set_mode(&mut self, number: u32) {
        self.send(gcs::set_mode(number));
    }

    pub fn arm(&mut self) {
        self.send(gcs::arm());
    }

    /// A GUIDED target `north_m`/`east_m` from home.
    pub fn goto_local(&mut self, north_m: f64, east_m: f64) {
        let target = gcs::local_target(&self.sim, north_m, east_m);
        self.send(target);
    }

    /// Distance of the true reference point from a local point.
    pub fn distance_to(&self, north_m: f64, east_m: f64) -> f64 {
        let t = self.sim.world().truth();
        (t.north_m - north_m).hypot(t.east_m - east_m)
    }

    pub fn texts(&self) -> Vec<String> {
        self.received
            .iter()
            .filter_map(|o| match &o.message {
                MavMessage::STATUSTEXT(t) => Some(t.text.to_str().unwrap_or("").to_string()),
                _ => None,
            })
            .collect()
    }

    pub fn acks(&self, command: MavCmd) -> Vec<mavlink::dialects::ardupilotmega::MavResult> {
        self.received
            .iter()
            .filter_map(|o| match &o.message {
                MavMessage::COMMAND_ACK(a) if a.command == command => Some(a.result),
                _ => None,
            })
            .collect()
    }
}

/// A mission item `north_m`, `east_m` from home (x and y in 1e-4 m).
pub fn item(seq: u16, command: u16, frame: u8, params: [f32; 4], north_m: f64, east_m: f64) -> MissionItem {
    MissionItem {
        seq,
        frame,
        command,
        current: false,
        autocontinue: true,
        params,
        x: (north_m * 1e4).round() as i32,
        y: (east_m * 1e4).round() as i32,
        z: 0.0,
    }
}

/// Home, DO_CHANGE_SPEED, then drive-through waypoints (the last a stop).
pub fn speed_then_waypoints(speed_mps: f32, points: &[(f64, f64)]) -> Plan {
    let mut items = vec![
        item(0, cmd::NAV_WAYPOINT, frame::LOCAL_NED, [0.0; 4], 0.0, 0.0),
        item(
            1,
            cmd::DO_CHANGE_SPEED,
            frame::MISSION,
            [1.0, speed_mps, -1.0, 0.0],
            0.0,
            0.0,
        ),
    ];
    for (i, &(n, e)) in points.iter().enumerate() {
        items.push(item(
            (i + 2) as u16,
            cmd::NAV_WAYPOINT,
            frame::LOCAL_NED,
            [0.0; 4],
            n,
            e,
        ));
    }
    Plan::new(MissionType::Mission, items)
}
