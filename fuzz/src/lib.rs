//! What the fuzz targets share: a simulated vehicle that a fuzzed ground
//! station talks to, with the link layer's delivery rules in front of it.
//!
//! The targets check properties as they go (`assert!`): a failed property is
//! a finding, like a panic, and libFuzzer saves the input that caused it.

pub mod flight;
pub mod order;

use std::time::Duration;

use autopilot::link::frame::ReceivedFrame;
use autopilot::link::router::Router;
use autopilot::sitl::simulation::{ModelKind, Simulation, SimulationConfig, SimulationParams};
use autopilot::time::FrozenTimer;
use autopilot::vehicle::{COMPONENT_ID, Inbound, LinkEvent, LinkId, UndecodableItem};
use mavlink::dialects::ardupilotmega::MavMessage;
use mavlink::{MavHeader, MavlinkVersion, Message};

/// The link the fuzzed ground station talks on.
pub const GCS_LINK: LinkId = LinkId(0);

/// What the core answered while a batch of messages was serviced.
#[derive(Debug, Default)]
pub struct Answers {
    pub messages: Vec<MavMessage>,
}

impl Answers {
    pub fn command_acks(&self) -> usize {
        self.messages
            .iter()
            .filter(|m| matches!(m, MavMessage::COMMAND_ACK(_)))
            .count()
    }
}

/// A SITL vehicle (world, NMEA driver, core) with one ground-station link.
pub struct FuzzVehicle {
    sim: Simulation,
    timer: FrozenTimer,
    wall: Duration,
    /// Commands delivered to the core since the last [`FuzzVehicle::service`].
    commands_delivered: usize,
}

impl Default for FuzzVehicle {
    fn default() -> Self {
        Self::new()
    }
}

impl FuzzVehicle {
    /// A vehicle with its first GNSS fixes (half a simulated second), a
    /// ground station connected, and its telemetry drained.
    pub fn new() -> Self {
        let config = SimulationConfig {
            model: ModelKind::Ackermann,
            ..SimulationConfig::default()
        };
        let mut params = SimulationParams::new(config.model);
        // The simulated scanners' CoLa-A round trip costs more than the rest
        // of a step under coverage instrumentation, and the `cola` target
        // fuzzes that parser; a GCS can still turn them back on.
        let _ = params.apply(&[("SIM_SCAN_DISABLE".to_owned(), 3.0)]);
        let mut sim = Simulation::new(&config, params);
        sim.inputs_mut().link_events.push(LinkEvent::Opened {
            link: GCS_LINK,
            stream_slot: 0,
        });
        let mut vehicle = FuzzVehicle {
            sim,
            timer: FrozenTimer,
            wall: Duration::ZERO,
            commands_delivered: 0,
        };
        vehicle.steps(25);
        vehicle
    }

    pub fn sim(&self) -> &Simulation {
        &self.sim
    }

    /// Delivers a framed message as the link hub does: routed, decoded
    /// messages to the core, undecodable mission items as such.
    pub fn deliver_frame(&mut self, frame: ReceivedFrame) {
        let (target_system, target_component) = match &frame.message {
            Ok(m) => (m.target_system_id(), m.target_component_id()),
            Err(_) => (None, None),
        };
        // A fresh router each time: a GCS can change SYSID_THISMAV, and only
        // local delivery matters here (there is no second link to forward to).
        let decision = Router::new(self.sim.core().sysid(), COMPONENT_ID).route(
            GCS_LINK,
            frame.header.system_id,
            frame.header.component_id,
            frame.message_id(),
            target_system,
            target_component,
        );
        if !decision.deliver_locally {
            return;
        }
        match frame.message {
            Ok(message) => self.deliver(frame.header, frame.version, message),
            Err(_) => {
                if let Some(item) = mission::protocol::inspect_undecodable_item(frame.message_id(), frame.raw.payload())
                {
                    self.deliver_undecodable_item(frame.header, item);
                }
            }
        }
    }

    /// Queues a decoded message for the core.
    pub fn deliver(&mut self, header: MavHeader, version: MavlinkVersion, message: MavMessage) {
        if matches!(message, MavMessage::COMMAND_LONG(_) | MavMessage::COMMAND_INT(_))
            && self.sim.core().is_for_us(&message)
        {
            self.commands_delivered += 1;
        }
        self.sim.inputs_mut().messages.push(Inbound {
            link: GCS_LINK,
            header,
            version,
            message,
        });
    }

    pub fn deliver_undecodable_item(&mut self, header: MavHeader, item: mission::protocol::UndecodableItem) {
        self.sim.inputs_mut().undecodable_items.push(UndecodableItem {
            link: GCS_LINK,
            header,
            seq: item.seq,
            mission_type: item.mission_type,
            target_system: item.target_system,
            target_component: item.target_component,
            bad_frame: item.bad_frame,
        });
    }

    /// Closes and reopens the ground station's link (a TCP reconnect).
    pub fn reconnect(&mut self) {
        let events = &mut self.sim.inputs_mut().link_events;
        events.push(LinkEvent::Closed { link: GCS_LINK });
        events.push(LinkEvent::Opened {
            link: GCS_LINK,
            stream_slot: 0,
        });
    }

    /// Lets the core answer what was delivered, and checks the command
    /// protocol's promise: exactly one COMMAND_ACK per command.
    pub fn service(&mut self) -> Answers {
        let out = self.sim.service_links(self.wall);
        let answers = Answers {
            messages: out.mavlink.drain(..).map(|o| o.message).collect(),
        };
        assert_eq!(
            answers.command_acks(),
            self.commands_delivered,
            "every command addressed to the vehicle gets exactly one COMMAND_ACK"
        );
        self.commands_delivered = 0;
        answers
    }

    /// Advances world and core by `count` core periods (wall time with them).
    /// Anything still queued is serviced first, so its answers are checked.
    pub fn steps(&mut self, count: u32) {
        self.service();
        for _ in 0..count {
            self.wall += self.sim.core().loop_period();
            let wall = self.wall;
            self.sim.step(wall, &mut self.timer).mavlink.clear();
        }
    }

    /// Moves the wall clock only (GCS-facing timers: mission item timeouts,
    /// RC override and heartbeat loss).
    pub fn advance_wall(&mut self, by: Duration) {
        self.wall += by;
    }
}
