//! The parameter protocol, wired to the core: the `params` crate's service
//! does the protocol; the core turns its notices into STATUSTEXT.

use ::params::service::{Outgoing, ParamNotice, Reply, Sender};
use mavlink::dialects::ardupilotmega::MavSeverity;

use super::{Core, Destination, Inbound};

impl Core {
    pub(super) fn handle_param_message(&mut self, inbound: &Inbound) {
        let sender = Sender {
            system_id: inbound.header.system_id as u8,
            component_id: inbound.header.component_id,
        };
        let mut out = Vec::new();
        let mut notices = Vec::new();
        self.param_service.handle(
            &mut self.params,
            inbound.link,
            sender,
            &inbound.message,
            &mut out,
            &mut notices,
        );
        self.send_param_replies(out);
        self.param_notices(notices);
    }

    /// Turns the service's notices into STATUSTEXT (and saves).
    pub(super) fn param_notices(&mut self, notices: Vec<ParamNotice>) {
        for notice in notices {
            match notice {
                ParamNotice::Changed { .. } => {}
                ParamNotice::SaveRequested { index, value } => self.param_save_requested(index, value),
                ParamNotice::RebootRequired { name } => self.send_text(
                    MavSeverity::MAV_SEVERITY_WARNING,
                    &format!("{name} takes effect after a restart"),
                ),
                ParamNotice::Refused { text } => self.send_text(MavSeverity::MAV_SEVERITY_WARNING, &text),
            }
        }
    }

    /// Continues any PARAM_REQUEST_LIST download (called at the stream rate).
    pub(super) fn stream_params(&mut self) {
        let mut out = Vec::new();
        self.param_service.poll(&self.params, &mut out);
        self.send_param_replies(out);
    }

    pub(super) fn send_param_replies(&mut self, out: Vec<Outgoing<super::LinkId>>) {
        for o in out {
            let dest = match o.dest {
                Reply::Link(link) => Destination::Link(link),
                Reply::AllLinks => Destination::AllLinks,
            };
            self.send(dest, o.message);
        }
    }
}
