//! The core's side of the onboard log: which file is open (armed, or
//! `LOG_DISARMED`), and the records of each tick, encoded here and handed
//! to the edge in [`Outputs::log`](super::Outputs) as
//! [`LogCommand`]s. Nothing here waits or touches a file.

use std::time::Duration;

use crate::geo::{wrap_2pi, wrap_pi};
use crate::guidance::navigator::StopReport;
use crate::logging::format::{MessageDef, Value, write_record};
use crate::logging::messages::{self as m};
use crate::logging::{FileLimits, LogCommand};
use crate::vehicle::{Core, Failsafe, LinkId};
use mavlink::dialects::ardupilotmega::MavMessage;
use mission::MissionType;

/// Obstacle tracks are logged at most this often (they can be many).
const TRACKS_EVERY: Duration = Duration::from_millis(200);
/// The battery is logged at most this often.
const BATTERY_EVERY: Duration = Duration::from_secs(1);
/// Record buffers kept for reuse: a reader that hands each back before the
/// next step needs one.
const MAX_SPARE_RECORD_BUFFERS: usize = 2;
/// At most this many tracks a time (the nearest-numbered first).
const MAX_TRACKS: usize = 16;
/// GPS time starts 1980-01-06; UTC is 18 leap seconds behind it.
const GPS_EPOCH_UNIX_S: i64 = 315_964_800;
const GPS_LEAP_S: i64 = 18;

#[derive(Default)]
pub(super) struct LogState {
    open: bool,
    /// Records of this step, sent as one [`LogCommand::Records`].
    records: Vec<u8>,
    /// Record buffers the log's reader handed back, for the next steps.
    spare_records: Vec<Vec<u8>>,
    commands: Vec<LogCommand>,
    last_fast: Option<Duration>,
    last_tracks: Option<Duration>,
    last_battery: Option<Duration>,
    logged_mode: Option<u32>,
    logged_armed: bool,
    logged_plans: Option<u64>,
    /// Bit per [`Failsafe::ALL`] entry.
    logged_failsafes: u32,
}

impl LogState {
    fn write(&mut self, def: &MessageDef, values: &[Value]) {
        if self.open {
            write_record(&mut self.records, def, values);
        }
    }

    /// Queues `command` after the records written so far.
    fn push(&mut self, command: LogCommand) {
        self.flush_records();
        self.commands.push(command);
    }

    /// Moves the records written so far into a command, leaving a buffer
    /// as large for the next tick (no regrowth while it fills).
    fn flush_records(&mut self) {
        if !self.records.is_empty() {
            let next = self
                .spare_records
                .pop()
                .unwrap_or_else(|| Vec::with_capacity(self.records.len()));
            let records = std::mem::replace(&mut self.records, next);
            self.commands.push(LogCommand::Records(records));
        }
    }

    /// What to hand to the edge this step, appended to `out`.
    pub(super) fn drain_commands_into(&mut self, out: &mut Vec<LogCommand>) {
        self.flush_records();
        out.append(&mut self.commands);
    }

    /// A [`LogCommand::Records`] buffer whose records have been read: the
    /// next steps write into it instead of a new one.
    pub(super) fn recycle_records(&mut self, mut buffer: Vec<u8>) {
        if self.spare_records.len() < MAX_SPARE_RECORD_BUFFERS {
            buffer.clear();
            self.spare_records.push(buffer);
        }
    }

    pub(super) fn request(&mut self, link: LinkId, message: MavMessage) {
        self.push(LogCommand::Request {
            link,
            message: Box::new(message),
        });
    }

    pub(super) fn link_closed(&mut self, link: LinkId) {
        self.push(LogCommand::LinkClosed(link));
    }
}

/// GPS week and milliseconds into it.
fn gps_week_ms(utc_unix_us: i64) -> (u64, u64) {
    let gps_ms = (utc_unix_us / 1000 - (GPS_EPOCH_UNIX_S - GPS_LEAP_S) * 1000).max(0) as u64;
    let week_ms = 7 * 24 * 3600 * 1000;
    (gps_ms / week_ms, gps_ms % week_ms)
}

fn deg_0_360(rad: f64) -> f64 {
    wrap_2pi(rad).to_degrees()
}

impl Core {
    fn log_time_us(&self) -> u64 {
        self.now.boot.as_micros() as u64
    }

    /// Once per tick, after the tasks: opens or closes the file, then writes
    /// what changed and this tick's state.
    pub(super) fn log_tick(&mut self, gnss_samples: usize) {
        let enabled = self.p.logging.enabled(&self.params);
        let want_open = enabled && (self.armed || self.p.logging.disarmed.get(&self.params) != 0);
        let armed_changed = self.armed != self.onboard_log.logged_armed;
        if self.onboard_log.open && (!want_open || (armed_changed && self.armed)) {
            // A disarm ends its arming's file; an arming starts a new one
            // (and is logged there).
            if armed_changed && !self.armed {
                self.log_arming_event();
            }
            self.onboard_log.open = false;
            self.onboard_log.push(LogCommand::Close);
        } else if armed_changed {
            self.log_arming_event();
        }
        self.onboard_log.logged_armed = self.armed;
        if want_open && !self.onboard_log.open {
            self.log_start(self.p.logging.limits(&self.params));
        }
        if !self.onboard_log.open {
            return;
        }
        self.log_changes();
        self.log_periodic(gnss_samples);
    }

    /// EV for the arming or disarming just seen.
    fn log_arming_event(&mut self) {
        let id = if self.armed { m::EV_ARMED } else { m::EV_DISARMED };
        let t = self.log_time_us();
        self.onboard_log.write(&m::EV, &[Value::U(t), Value::U(u64::from(id))]);
    }

    /// A new file: the parameters, then the mission, mode and arming state.
    fn log_start(&mut self, limits: FileLimits) {
        self.onboard_log.push(LogCommand::Open(limits));
        self.onboard_log.open = true;
        let t = self.log_time_us();
        for (def, value) in self.params.iter() {
            write_record(
                &mut self.onboard_log.records,
                &m::PARM,
                &[
                    Value::U(t),
                    Value::S(def.name.as_str()),
                    Value::F(value),
                    Value::F(def.default),
                ],
            );
        }
        self.onboard_log.logged_mode = None;
        self.onboard_log.logged_plans = None;
        self.onboard_log.logged_failsafes = 0;
        if self.armed {
            self.onboard_log
                .write(&m::EV, &[Value::U(t), Value::U(u64::from(m::EV_ARMED))]);
        }
    }

    /// MODE, CMD and ERR when what they record changed.
    fn log_changes(&mut self) {
        let t = self.log_time_us();
        let mode = self.mode.number();
        if self.onboard_log.logged_mode != Some(mode) {
            self.onboard_log.logged_mode = Some(mode);
            let values = [
                Value::U(t),
                Value::U(u64::from(mode)),
                Value::U(u64::from(mode)),
                Value::U(0),
            ];
            self.onboard_log.write(&m::MODE, &values);
        }
        if self.onboard_log.logged_plans != Some(self.missions.generation) {
            self.onboard_log.logged_plans = Some(self.missions.generation);
            let plan = self.missions.plan(MissionType::Mission);
            let total = plan.len() as u64;
            for item in plan.items() {
                let values = [
                    Value::U(t),
                    Value::U(total),
                    Value::U(u64::from(item.seq)),
                    Value::U(u64::from(item.command)),
                    Value::F(f64::from(item.params[0])),
                    Value::F(f64::from(item.params[1])),
                    Value::F(f64::from(item.params[2])),
                    Value::F(f64::from(item.params[3])),
                    Value::F(f64::from(item.x) * 1e-7),
                    Value::F(f64::from(item.y) * 1e-7),
                    Value::F(f64::from(item.z)),
                    Value::U(u64::from(item.frame)),
                ];
                write_record(&mut self.onboard_log.records, &m::CMD, &values);
            }
        }
        let mut failsafes = 0u32;
        for (i, f) in Failsafe::ALL.iter().enumerate() {
            if self.failsafes.is_active(*f) {
                failsafes |= 1 << i;
            }
        }
        let changed = failsafes ^ self.onboard_log.logged_failsafes;
        for i in (0..Failsafe::ALL.len()).filter(|i| changed & (1 << i) != 0) {
            // Subsystem: Furrow's failsafe number (1-based), code 1 raised.
            let code = u64::from(failsafes & (1 << i) != 0);
            self.onboard_log
                .write(&m::ERR, &[Value::U(t), Value::U(i as u64 + 1), Value::U(code)]);
        }
        self.onboard_log.logged_failsafes = failsafes;
    }

    /// The per-tick records (at most `LOG_FILE_RATEMAX`), GPS on each new
    /// sample, the battery and the obstacle tracks at their own rates.
    fn log_periodic(&mut self, gnss_samples: usize) {
        let now = self.now.boot;
        let due = |last: Option<Duration>, every: Duration| last.is_none_or(|l| now.saturating_sub(l) >= every);
        if gnss_samples > 0 {
            self.log_gps();
        }
        let rate_hz = f64::from(self.p.logging.rate_max_hz.get(&self.params));
        let every = if rate_hz > 0.0 {
            crate::time::duration_from_secs(1.0 / rate_hz)
        } else {
            Duration::ZERO
        };
        if due(self.onboard_log.last_fast, every) {
            self.onboard_log.last_fast = Some(now);
            // Local headings to true ones, once for all records.
            let turn = self.true_heading_offset_rad();
            self.log_pose(turn);
            self.log_drive();
            self.log_navigation(turn);
            self.log_ekf();
            self.log_obstacles();
        }
        if due(self.onboard_log.last_battery, BATTERY_EVERY) {
            self.onboard_log.last_battery = Some(now);
            self.log_battery();
        }
        if due(self.onboard_log.last_tracks, TRACKS_EVERY) {
            self.onboard_log.last_tracks = Some(now);
            self.log_tracks();
        }
    }

    fn log_gps(&mut self) {
        let t = self.log_time_us();
        let g = self.estimator.gnss();
        let (week, ms) = g.utc_now_us(self.now.boot).map_or((0, 0), gps_week_ms);
        let values = [
            Value::U(t),
            Value::U(0),
            Value::U(u64::from(g.mavlink_fix_type(self.now.boot))),
            Value::U(ms),
            Value::U(week),
            Value::U(u64::from(g.satellites)),
            Value::F(f64::from(g.hdop)),
            Value::F(g.lat_deg),
            Value::F(g.lon_deg),
            Value::F(g.alt_msl_m),
            Value::F(g.speed_mps),
            Value::F(g.course_deg.unwrap_or(0.0)),
            Value::F(0.0),
            Value::F(g.heading_deg.unwrap_or(0.0)),
            Value::U(1),
        ];
        self.onboard_log.write(&m::GPS, &values);
    }

    fn log_pose(&mut self, turn: f64) {
        let t = self.log_time_us();
        let e = *self.estimator.estimate();
        if let (Some(frame), true) = (self.frame(), e.position_valid) {
            let p = frame.to_geodetic(&e.position);
            let alt = self.estimator.gnss().alt_msl_m;
            let home_alt = self.home.map_or(alt, |h| h.alt_m);
            let values = [
                Value::U(t),
                Value::F(p.lat_deg),
                Value::F(p.lon_deg),
                Value::F(alt),
                Value::F(alt - home_alt),
                Value::F(0.0),
            ];
            self.onboard_log.write(&m::POS, &values);
        }
        let s = self.navigator.status();
        let des_yaw = if s.active { s.tracker.desired_yaw_rad } else { e.yaw_rad };
        let values = [
            Value::U(t),
            Value::F(0.0),
            Value::F(0.0),
            Value::F(0.0),
            Value::F(0.0),
            Value::F(deg_0_360(des_yaw + turn)),
            Value::F(deg_0_360(e.yaw_rad + turn)),
            Value::F(0.0),
            Value::F(0.0),
            Value::U(3),
        ];
        self.onboard_log.write(&m::ATT, &values);
    }

    /// STER, THR and PIDA.
    fn log_drive(&mut self) {
        let t = self.log_time_us();
        let e = *self.estimator.estimate();
        let wheelbase_m = f64::from(self.p.vehicle.wheelbase_m.get(&self.params)).max(0.1);
        let steer_rad = self.navigator.status().tracker.steer_rad;
        let des_turn_rate = e.speed_mps * steer_rad.tan() / wheelbase_m;
        let manual = self.mode.has_manual_input();
        let values = [
            Value::U(t),
            Value::F(if manual { self.manual.steering * 4500.0 } else { 0.0 }),
            Value::F(self.drive.steering),
            Value::F(e.speed_mps * des_turn_rate),
            Value::F(e.speed_mps * e.yaw_rate_rad_s),
            Value::F(des_turn_rate.to_degrees()),
            Value::F(e.yaw_rate_rad_s.to_degrees()),
        ];
        self.onboard_log.write(&m::STER, &values);
        let demand_mps = self.speed_control.limited_demand_mps();
        let values = [
            Value::U(t),
            Value::F(if manual { self.manual.throttle * 100.0 } else { 0.0 }),
            Value::F(self.drive.throttle * 100.0),
            Value::F(demand_mps),
            Value::F(e.speed_mps),
            Value::F(e.speed_mps * e.yaw_rate_rad_s),
        ];
        self.onboard_log.write(&m::THR, &values);
        let (terms, feed_forward) = self.speed_control.last_terms();
        let values = [
            Value::U(t),
            Value::F(demand_mps),
            Value::F(e.speed_mps),
            Value::F(demand_mps - e.speed_mps),
            Value::F(terms.p),
            Value::F(terms.i),
            Value::F(terms.d),
            Value::F(feed_forward),
        ];
        self.onboard_log.write(&m::PIDA, &values);
    }

    /// NTUN, the preview point and the tracker's PIDs while navigating.
    fn log_navigation(&mut self, turn: f64) {
        let s = *self.navigator.status();
        if !self.mode.is_autopilot() || !s.active {
            return;
        }
        let t = self.log_time_us();
        let yaw = self.estimator.estimate().yaw_rad;
        let k = &s.tracker;
        let values = [
            Value::U(t),
            Value::F(s.wp_dist_m),
            Value::F(deg_0_360(s.target_bearing_rad + turn)),
            Value::F(deg_0_360(k.desired_yaw_rad + turn)),
            Value::F(deg_0_360(yaw + turn)),
            Value::F(s.crosstrack_m),
        ];
        self.onboard_log.write(&m::NTUN, &values);
        let values = [
            Value::U(t),
            Value::F(k.preview_point.north_m),
            Value::F(k.preview_point.east_m),
            Value::F(k.preview_m),
            Value::F(k.lateral_error_m),
            Value::F(k.yaw_error_rad),
            Value::F(k.steer_rad),
            Value::U(u64::from(k.capturing)),
        ];
        self.onboard_log.write(&m::PREV, &values);
        for (def, terms, error, ff) in [
            (&m::PIDL, k.lateral, k.lateral_error_m, k.feedforward_rad),
            (&m::PIDY, k.yaw, wrap_pi(k.yaw_error_rad), 0.0),
        ] {
            let values = [
                Value::U(t),
                Value::F(0.0),
                Value::F(error),
                Value::F(-error),
                Value::F(terms.p),
                Value::F(terms.i),
                Value::F(terms.d),
                Value::F(ff),
            ];
            self.onboard_log.write(def, &values);
        }
    }

    fn log_ekf(&mut self) {
        let Some(status) = self.estimator.ekf_status().filter(|s| s.initialised) else {
            return;
        };
        let t = self.log_time_us();
        let values = [
            Value::U(t),
            Value::F(status.gnss_position.innovation[0]),
            Value::F(status.gnss_position.innovation[1]),
            Value::F(status.gnss_velocity.innovation[0]),
            Value::F(status.gnss_velocity.innovation[1]),
            Value::F(status.heading.innovation[0]),
            Value::F(status.gnss_position.test_ratio),
            Value::F(status.gnss_velocity.test_ratio),
            Value::F(status.heading.test_ratio),
            Value::U(u64::from(status.healthy)),
        ];
        self.onboard_log.write(&m::EKFI, &values);
    }

    fn log_obstacles(&mut self) {
        let o = self.obstacle_status();
        if !o.enabled {
            return;
        }
        let t = self.log_time_us();
        let values = [
            Value::U(t),
            Value::U(u64::from(o.enabled)),
            Value::U(u64::from(o.scans_fresh)),
            Value::U(u64::from(o.stopped)),
            Value::U(u64::from(o.detouring)),
            Value::U(o.confirmed_tracks as u64),
            Value::U(o.tentative_tracks as u64),
            Value::F(o.nearest_m.unwrap_or(-1.0)),
            Value::F(o.speed_limit_mps.unwrap_or(-1.0)),
        ];
        self.onboard_log.write(&m::OBST, &values);
    }

    fn log_tracks(&mut self) {
        let t = self.log_time_us();
        let Core {
            obstacles, onboard_log, ..
        } = self;
        for track in obstacles.tracks().iter().take(MAX_TRACKS) {
            let confirmed = matches!(track.status, crate::obstacles::TrackStatus::Confirmed);
            let values = [
                Value::U(t),
                Value::U(u64::from(track.id)),
                Value::U(u64::from(confirmed)),
                Value::F(track.position.north_m),
                Value::F(track.position.east_m),
                Value::F(track.vel_north_mps),
                Value::F(track.vel_east_mps),
                Value::F(track.radius_m),
                Value::F(track.age_s),
            ];
            onboard_log.write(&m::OBTK, &values);
        }
    }

    fn log_battery(&mut self) {
        let Some(b) = self.battery else {
            return;
        };
        let t = self.log_time_us();
        let values = [
            Value::U(t),
            Value::U(0),
            Value::F(b.voltage_v),
            Value::F(b.voltage_v),
            Value::F(b.current_a),
            Value::F(b.consumed_mah / 1000.0),
            Value::F(0.0),
            Value::F(0.0),
            Value::F(0.0),
            Value::F(b.remaining_pct),
        ];
        self.onboard_log.write(&m::BAT, &values);
    }

    /// MSG: every STATUSTEXT the vehicle says while a file is open.
    pub(super) fn log_text(&mut self, text: &str) {
        let t = self.log_time_us();
        self.onboard_log.write(&m::MSG, &[Value::U(t), Value::S(text)]);
    }

    /// PSTP: how a precision stop ended.
    pub(super) fn log_stop_report(&mut self, report: &StopReport) {
        let t = self.log_time_us();
        let values = [
            Value::U(t),
            Value::I(report.seq.map_or(-1, i64::from)),
            Value::F(report.along_m),
            Value::F(report.crosstrack_m),
            Value::F(report.yaw_error_rad),
            Value::F(report.position_error_m()),
            Value::U(u64::from(report.within_tolerance)),
        ];
        self.onboard_log.write(&m::PSTP, &values);
    }
}

#[cfg(test)]
mod tests {
    use super::gps_week_ms;

    #[test]
    fn gps_time_from_utc() {
        // 2024-01-07 00:00:00 UTC: GPS week 2296 starts at 2024-01-07
        // 00:00:00 GPS = 2024-01-06 23:59:42 UTC.
        let utc_us = 1_704_585_600_000_000;
        assert_eq!(gps_week_ms(utc_us), (2296, 18_000));
    }
}
