//! The geofence at run time: checked every tick against the estimated
//! position; a new breach is announced and, armed, acted on (`FENCE_ACTION`).

use mavlink::dialects::ardupilotmega::{FENCE_STATUS_DATA, FenceBreach, FenceMitigate, MavSeverity};

use mission::MissionType;

use super::Core;
use crate::fence::{Breach, Fence};
use crate::modes::Mode;

impl Core {
    fn fence_enabled(&self) -> bool {
        self.p.fence.enable.get(&self.params) && !self.missions.plan(MissionType::Fence).is_empty()
    }

    /// The compiled fence, built once the local frame exists.
    fn fence(&mut self) -> Option<&Fence> {
        if self.missions.fence.is_none() {
            let frame = self.frame()?;
            self.missions.fence = Some(Fence::from_items(
                self.missions.plan(MissionType::Fence).items(),
                &frame,
            ));
        }
        self.missions.fence.as_ref()
    }

    pub(super) fn check_fence(&mut self) {
        if !self.fence_enabled() || !self.estimator.estimate().position_valid {
            self.missions.breach = None;
            return;
        }
        let here = self.estimator.estimate().position;
        let breach = self.fence().and_then(|f| f.breach(&here));
        let new_breach = breach.is_some() && self.missions.breach.is_none();
        self.missions.breach = breach;
        let Some(breach) = breach.filter(|_| new_breach) else {
            return;
        };
        self.missions.breach_count = self.missions.breach_count.saturating_add(1);
        self.missions.breach_time_ms = self.now.boot_ms();
        if !self.armed {
            self.send_text(
                MavSeverity::MAV_SEVERITY_WARNING,
                &format!("Fence: vehicle {}", breach.describe()),
            );
            return;
        }
        let action = match self.p.fence.action.get(&self.params) {
            0 => None,
            1 if self.mode != Mode::Rtl && self.rtl_target().is_some() => Some(Mode::Rtl),
            _ => Some(Mode::Hold),
        };
        match action {
            Some(mode) if mode != self.mode => {
                self.send_text(
                    MavSeverity::MAV_SEVERITY_CRITICAL,
                    &format!("Fence breach: {}, {mode}", breach.describe()),
                );
                self.enter_mode(mode);
            }
            _ => self.send_text(
                MavSeverity::MAV_SEVERITY_CRITICAL,
                &format!("Fence breach: {}", breach.describe()),
            ),
        }
    }

    /// Arming refused outside the fence (checked against the fence compiled
    /// by the last tick).
    pub(super) fn fence_arming_failure(&self) -> Option<&'static str> {
        if !self.fence_enabled() || !self.estimator.estimate().position_valid {
            return None;
        }
        let here = self.estimator.estimate().position;
        self.missions
            .fence
            .as_ref()
            .and_then(|f| f.breach(&here))
            .map(|b| match b {
                Breach::OutsideInclusion => "Vehicle outside the fence",
                Breach::InsideExclusion => "Vehicle inside an exclusion zone",
            })
    }

    /// SYS_STATUS geofence bits: (present, enabled, healthy).
    pub(super) fn fence_status_bits(&self) -> (bool, bool, bool) {
        let present = !self.missions.plan(MissionType::Fence).is_empty();
        (
            present,
            present && self.p.fence.enable.get(&self.params),
            self.missions.breach.is_none(),
        )
    }

    pub(super) fn fence_status(&self) -> Option<FENCE_STATUS_DATA> {
        if self.missions.plan(MissionType::Fence).is_empty() {
            return None;
        }
        Some(FENCE_STATUS_DATA {
            breach_time: self.missions.breach_time_ms,
            breach_count: self.missions.breach_count,
            breach_status: u8::from(self.missions.breach.is_some()),
            breach_type: if self.missions.breach.is_some() {
                FenceBreach::FENCE_BREACH_BOUNDARY
            } else {
                FenceBreach::FENCE_BREACH_NONE
            },
            breach_mitigation: FenceMitigate::FENCE_MITIGATE_UNKNOWN,
        })
    }
}
