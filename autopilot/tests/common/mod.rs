//! A ground station inside the test: talks to a [`Simulation`] through the
//! same `Inbound`/`Outbound` messages the link layer carries.
#![allow(dead_code)]

use std::time::Duration;

use autopilot::sitl::simulation::{ModelKind, Simulation, SimulationConfig, SimulationParams};
use autopilot::time::FrozenTimer;
use autopilot::vehicle::{Inbound, LinkEvent, LinkId, Outbound};
use mavlink::dialects::ardupilotmega::{
    COMMAND_LONG_DATA, MavCmd, MavFrame, MavMessage, PositionTargetTypemask,
    SET_POSITION_TARGET_GLOBAL_INT_DATA,
};
use mavlink::{MavHeader, MavlinkVersion};

pub const GCS: LinkId = LinkId(0);

pub struct Harness {
    pub sim: Simulation,
    pub received: Vec<Outbound>,
    timer: FrozenTimer,
}

impl Harness {
    pub fn new(seed: u64, model: ModelKind) -> Self {
        let config = SimulationConfig {
            seed,
            model,
            ..SimulationConfig::default()
        };
        let mut sim = Simulation::new(&config, SimulationParams::new(model));
        sim.inputs_mut().link_events.push(LinkEvent::Opened {
            link: GCS,
            stream_slot: 0,
        });
        Harness {
            sim,
            received: Vec::new(),
            timer: FrozenTimer,
        }
    }

    /// Steps one tick; wall time follows simulated time so runs replay.
    pub fn step(&mut self) {
        let wall = self.sim.time();
        let out = self.sim.step(wall, &mut self.timer);
        self.received.append(&mut out.mavlink);
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
        let header = MavHeader {
            system_id: 255,
            component_id: 190,
            sequence: 0,
        };
        self.sim.inputs_mut().messages.push(Inbound {
            link: GCS,
            header,
            version: MavlinkVersion::V2,
            message,
        });
    }

    pub fn command(&mut self, command: MavCmd, params: [f32; 7]) {
        self.send(MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
            param1: params[0],
            param2: params[1],
            param3: params[2],
            param4: params[3],
            param5: params[4],
            param6: params[5],
            param7: params[6],
            command,
            target_system: 1,
            target_component: 1,
            confirmation: 0,
        }));
    }

    pub fn set_mode(&mut self, number: u32) {
        self.command(
            MavCmd::MAV_CMD_DO_SET_MODE,
            [1.0, number as f32, 0.0, 0.0, 0.0, 0.0, 0.0],
        );
    }

    pub fn arm(&mut self) {
        self.command(
            MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
            [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        );
    }

    /// A GUIDED target `north_m`/`east_m` from home.
    pub fn goto_local(&mut self, north_m: f64, east_m: f64) {
        let p = self.sim.world().local_to_geodetic(north_m, east_m);
        self.send(MavMessage::SET_POSITION_TARGET_GLOBAL_INT(
            SET_POSITION_TARGET_GLOBAL_INT_DATA {
                time_boot_ms: 0,
                lat_int: (p.lat_deg * 1e7).round() as i32,
                lon_int: (p.lon_deg * 1e7).round() as i32,
                alt: 0.0,
                vx: 0.0,
                vy: 0.0,
                vz: 0.0,
                afx: 0.0,
                afy: 0.0,
                afz: 0.0,
                yaw: 0.0,
                yaw_rate: 0.0,
                type_mask: PositionTargetTypemask::from_bits_truncate(0b0000_1111_1111_1000),
                target_system: 1,
                target_component: 1,
                coordinate_frame: MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT,
            },
        ));
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
