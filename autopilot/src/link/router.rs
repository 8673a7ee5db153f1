//! Routing between links, with ArduPilot's rules (`MAVLink_routing.cpp`):
//! learn which link each (system, component) talks on; deliver a message
//! locally when it is broadcast or addressed to us; forward it to every
//! other link that has seen its target (broadcasts to every other link that
//! has seen anyone). RADIO/RADIO_STATUS stay local.

use crate::vehicle::LinkId;

const RADIO_STATUS_ID: u32 = 109;
const RADIO_ID: u32 = 166;
const MAX_ROUTES: usize = 64;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Route {
    sysid: u32,
    compid: u8,
    link: LinkId,
}

/// What to do with one inbound message.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct RouteDecision {
    pub deliver_locally: bool,
    pub forward_to: Vec<LinkId>,
}

pub struct Router {
    own_sysid: u32,
    own_compid: u8,
    routes: Vec<Route>,
}

impl Router {
    pub fn new(own_sysid: u8, own_compid: u8) -> Self {
        Router {
            own_sysid: u32::from(own_sysid),
            own_compid,
            routes: Vec::new(),
        }
    }

    pub fn remove_link(&mut self, link: LinkId) {
        self.routes.retain(|r| r.link != link);
    }

    /// Links that have seen at least one system.
    fn links_with_routes(&self) -> Vec<LinkId> {
        let mut links: Vec<LinkId> = self.routes.iter().map(|r| r.link).collect();
        links.sort();
        links.dedup();
        links
    }

    fn learn(&mut self, link: LinkId, sysid: u32, compid: u8) {
        // Our own id coming back means a loop, not a route.
        if sysid == self.own_sysid && compid == self.own_compid {
            return;
        }
        let route = Route { sysid, compid, link };
        if !self.routes.contains(&route) {
            if self.routes.len() == MAX_ROUTES {
                self.routes.remove(0);
            }
            self.routes.push(route);
        }
    }

    /// Decides for a message from `(sysid, compid)` on `link` with these
    /// targets (`None` when the message has no target field).
    pub fn route(
        &mut self,
        link: LinkId,
        sysid: u32,
        compid: u8,
        message_id: u32,
        target_system: Option<u8>,
        target_component: Option<u8>,
    ) -> RouteDecision {
        self.learn(link, sysid, compid);
        if message_id == RADIO_STATUS_ID || message_id == RADIO_ID {
            return RouteDecision {
                deliver_locally: true,
                forward_to: Vec::new(),
            };
        }
        let broadcast_system = target_system.is_none_or(|s| s == 0);
        let broadcast_component = target_component.is_none_or(|c| c == 0);
        let match_system = broadcast_system || target_system.map(u32::from) == Some(self.own_sysid);
        let match_component = match_system && (broadcast_component || target_component == Some(self.own_compid));
        let mut deliver_locally = match_system && match_component;
        if deliver_locally && !broadcast_system && !broadcast_component {
            return RouteDecision {
                deliver_locally,
                forward_to: Vec::new(),
            };
        }

        let mut forward_to = Vec::new();
        if broadcast_system {
            forward_to = self.links_with_routes();
            forward_to.retain(|l| *l != link);
        } else {
            for r in &self.routes {
                let target_matches = target_system.map(u32::from) == Some(r.sysid)
                    && (broadcast_component || target_component == Some(r.compid) || !match_system);
                if target_matches && r.link != link && !forward_to.contains(&r.link) {
                    forward_to.push(r.link);
                }
            }
        }
        if forward_to.is_empty() && match_system {
            deliver_locally = true;
        }
        RouteDecision {
            deliver_locally,
            forward_to,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const A: LinkId = LinkId(1);
    const B: LinkId = LinkId(2);
    const C: LinkId = LinkId(3);
    const HEARTBEAT: u32 = 0;
    const COMMAND_LONG: u32 = 76;

    fn router_with_gcs_on_a_and_b() -> Router {
        let mut r = Router::new(1, 1);
        r.route(A, 255, 190, HEARTBEAT, None, None);
        r.route(B, 254, 190, HEARTBEAT, None, None);
        r
    }

    #[test]
    fn command_for_us_is_local_only() {
        let mut r = router_with_gcs_on_a_and_b();
        let d = r.route(A, 255, 190, COMMAND_LONG, Some(1), Some(1));
        assert_eq!(
            d,
            RouteDecision {
                deliver_locally: true,
                forward_to: vec![]
            }
        );
    }

    #[test]
    fn broadcast_goes_locally_and_to_other_links_that_have_seen_someone() {
        let mut r = router_with_gcs_on_a_and_b();
        let d = r.route(A, 255, 190, HEARTBEAT, None, None);
        assert!(d.deliver_locally);
        assert_eq!(d.forward_to, vec![B]);
        // C has seen nobody: nothing goes there.
        assert!(!d.forward_to.contains(&C));
    }

    #[test]
    fn message_for_another_system_is_forwarded_not_handled() {
        let mut r = router_with_gcs_on_a_and_b();
        r.route(C, 42, 1, HEARTBEAT, None, None);
        let d = r.route(A, 255, 190, COMMAND_LONG, Some(42), Some(1));
        assert_eq!(
            d,
            RouteDecision {
                deliver_locally: false,
                forward_to: vec![C]
            }
        );
        // An unknown system: nowhere to go and not ours.
        let d = r.route(A, 255, 190, COMMAND_LONG, Some(77), Some(1));
        assert_eq!(
            d,
            RouteDecision {
                deliver_locally: false,
                forward_to: vec![]
            }
        );
    }

    #[test]
    fn message_for_another_component_of_ours_goes_where_that_component_is() {
        let mut r = router_with_gcs_on_a_and_b();
        // No route to component 100: ArduPilot hands it to the autopilot,
        // which decides (Core::is_for_us ignores it).
        let d = r.route(A, 255, 190, COMMAND_LONG, Some(1), Some(100));
        assert_eq!(
            d,
            RouteDecision {
                deliver_locally: true,
                forward_to: vec![]
            }
        );
        // A camera (1, 100) talks on C: now the message goes there only.
        r.route(C, 1, 100, HEARTBEAT, None, None);
        let d = r.route(A, 255, 190, COMMAND_LONG, Some(1), Some(100));
        assert_eq!(
            d,
            RouteDecision {
                deliver_locally: false,
                forward_to: vec![C]
            }
        );
    }

    #[test]
    fn closed_links_lose_their_routes() {
        let mut r = router_with_gcs_on_a_and_b();
        r.remove_link(B);
        let d = r.route(A, 255, 190, HEARTBEAT, None, None);
        assert!(d.forward_to.is_empty());
    }
}
