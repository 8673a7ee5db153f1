//! MANUAL: the operator's steering and throttle (MANUAL_CONTROL or
//! RC_CHANNELS_OVERRIDE) passed through while fresh; neutral once they stop.

use crate::vehicle::Core;
use crate::vehicle::drive::Demand;

impl Core {
    pub(super) fn manual_demand(&self) -> Demand {
        let timeout = f64::from(self.p.system.rc_override_time_s.get(&self.params));
        let fresh = self
            .manual
            .updated_wall
            .is_some_and(|t| self.now.wall.saturating_sub(t).as_secs_f64() <= timeout);
        if fresh {
            Demand::Manual {
                steering: self.manual.steering,
                throttle: self.manual.throttle,
            }
        } else {
            Demand::Stop
        }
    }
}
