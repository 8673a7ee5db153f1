//! The mission protocol, wired to the core: the `mission` crate's protocol
//! does the transfers; the core announces failures, rebuilds what derives
//! from a replaced plan, and keeps the protocol's idea of home current.

use mavlink::dialects::ardupilotmega::MavSeverity;
use mission::{HomeItem, MissionEvent, Outgoing, Reply, Sender};

use super::{Core, Destination, Inbound, LinkId, UndecodableItem};

impl Core {
    pub(super) fn handle_mission_message(&mut self, inbound: &Inbound) -> bool {
        let sender = Sender {
            system_id: inbound.header.system_id as u8,
            component_id: inbound.header.component_id,
        };
        let (mut out, mut events) = (Vec::new(), Vec::new());
        let handled = self.missions.protocol.handle(
            self.now.wall,
            inbound.link,
            sender,
            &inbound.message,
            &mut out,
            &mut events,
        );
        self.mission_replies(out);
        self.mission_events(events);
        handled
    }

    pub(super) fn handle_undecodable_items(&mut self, items: &[UndecodableItem]) {
        for item in items {
            let ours = (item.target_system == 0 || item.target_system == self.sysid)
                && (item.target_component == 0 || item.target_component == super::COMPONENT_ID);
            if !ours {
                continue;
            }
            let sender = Sender {
                system_id: item.header.system_id as u8,
                component_id: item.header.component_id,
            };
            let (mut out, mut events) = (Vec::new(), Vec::new());
            self.missions.protocol.handle_undecodable_item(
                self.now.wall,
                item.link,
                sender,
                item.seq,
                item.mission_type,
                item.bad_frame,
                &mut out,
                &mut events,
            );
            self.mission_replies(out);
            self.mission_events(events);
        }
    }

    pub(super) fn poll_mission_protocol(&mut self) {
        let (mut out, mut events) = (Vec::new(), Vec::new());
        self.missions.protocol.poll(self.now.wall, &mut out, &mut events);
        self.mission_replies(out);
        self.mission_events(events);
    }

    /// Keeps mission item 0 (home, on download) current.
    pub(super) fn update_protocol_home(&mut self) {
        let home = self.home.map(|h| HomeItem {
            lat_e7: h.lat_e7(),
            lon_e7: h.lon_e7(),
            alt_m: h.alt_m as f32,
        });
        self.missions.protocol.set_home(home);
    }

    pub(super) fn mission_replies(&mut self, out: Vec<Outgoing<LinkId>>) {
        for o in out {
            let dest = match o.dest {
                Reply::Link(link) => Destination::Link(link),
                Reply::AllLinks => Destination::AllLinks,
            };
            self.send(dest, o.message);
        }
    }

    pub(super) fn mission_events(&mut self, events: Vec<MissionEvent>) {
        for event in events {
            match event {
                MissionEvent::PlanReplaced(mission_type) => {
                    self.missions.changed(mission_type);
                    self.plan_changed(mission_type);
                    let plan = self.missions.plan(mission_type);
                    let text = format!("{} accepted: {} items", capitalised(mission_type.name()), plan.len());
                    self.send_text(MavSeverity::MAV_SEVERITY_INFO, &text);
                }
                MissionEvent::TransferFailed { text, .. } => self.send_text(MavSeverity::MAV_SEVERITY_WARNING, &text),
                MissionEvent::SaveRequested { mission_type, plan } => self.plan_save_requested(mission_type, plan),
            }
        }
    }
}

fn capitalised(word: &str) -> String {
    let mut c = word.chars();
    c.next()
        .map(|f| f.to_uppercase().chain(c).collect())
        .unwrap_or_default()
}
