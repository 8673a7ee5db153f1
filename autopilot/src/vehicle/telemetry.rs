//! Telemetry built from the core's state, and the stream/heartbeat tasks.

// PROTOCOL_VERSION is deprecated but still requested (see telemetry::identity).
#![allow(deprecated)]

use std::ops::Bound;

use mavlink::dialects::ardupilotmega::{
    ATTITUDE_DATA, BATTERY_STATUS_DATA, EKF_STATUS_REPORT_DATA, EXTENDED_SYS_STATE_DATA, EkfStatusFlags,
    GLOBAL_POSITION_INT_DATA, GPS_RAW_INT_DATA, GpsFixType, HOME_POSITION_DATA, LOCAL_POSITION_NED_DATA,
    MavBatteryChargeState, MavBatteryFault, MavBatteryFunction, MavBatteryMode, MavBatteryType, MavFrame,
    MavLandedState, MavMessage, MavSysStatusSensor, MavSysStatusSensorExtended, MavVtolState,
    NAV_CONTROLLER_OUTPUT_DATA, POSITION_TARGET_GLOBAL_INT_DATA, PositionTargetTypemask, RELAY_STATUS_DATA,
    SERVO_OUTPUT_RAW_DATA, SYS_STATUS_DATA, SYSTEM_TIME_DATA, VFR_HUD_DATA,
};
use vehicle_types::BatterySample;

use super::failsafe::Failsafe;
use super::{Core, Destination};
use crate::geo::{FrameKind, LocalFrame, wrap_2pi, wrap_pi};
use crate::modes::Mode;
use crate::telemetry::identity::{self, VehicleStatus};
use crate::telemetry::streams::{StreamGroup, StreamMsg};

const AUTOPILOT_VERSION_ID: u32 = 148;
const PROTOCOL_VERSION_ID: u32 = 300;
const HEARTBEAT_ID: u32 = 0;

fn cdeg_0_36000(rad: f64) -> u16 {
    ((wrap_2pi(rad).to_degrees() * 100.0).round() as u32 % 36000) as u16
}

impl Core {
    pub(super) fn slot_rate_hz(&self, slot: u8, group: StreamGroup) -> f64 {
        f64::from(self.p.streams.rate(slot, group).get(&self.params))
    }

    pub(super) fn send_heartbeat(&mut self) {
        let hb = identity::heartbeat(&VehicleStatus {
            mode: self.mode,
            armed: self.armed,
            failsafe: self.failsafe_active(),
        });
        self.send(Destination::AllLinks, MavMessage::HEARTBEAT(hb));
    }

    pub(super) fn send_streams(&mut self) {
        // Every tick: the links are walked by key and the buffer is the
        // core's, so telemetry allocates nothing.
        let mut due = std::mem::take(&mut self.due_streams);
        let mut next = self.links.keys().next().copied();
        while let Some(link) = next {
            next = self
                .links
                .range((Bound::Excluded(link), Bound::Unbounded))
                .next()
                .map(|(k, _)| *k);
            due.clear();
            let Some(streams) = self.links.get(&link) else {
                continue;
            };
            let slot = streams.slot();
            let rates: [f64; StreamGroup::COUNT] =
                std::array::from_fn(|g| self.slot_rate_hz(slot, StreamGroup::ALL[g]));
            if let Some(streams) = self.links.get_mut(&link) {
                streams.due(self.now.wall, |g| rates[g as usize], &mut due);
            }
            for msg in &due {
                if let Some(message) = self.build(*msg) {
                    self.send(Destination::Link(link), message);
                }
            }
        }
        self.due_streams = due;
    }

    /// Whether REQUEST_MESSAGE for `id` is something Furrow can answer.
    pub(super) fn can_build(&self, id: u32) -> bool {
        matches!(id, HEARTBEAT_ID | AUTOPILOT_VERSION_ID | PROTOCOL_VERSION_ID)
            || StreamMsg::from_message_id(id).is_some()
    }

    /// The message REQUEST_MESSAGE asks for, if it can be built now (also
    /// what a bench samples every tick: what the vehicle would report).
    pub fn build_requested(&self, id: u32) -> Option<MavMessage> {
        match id {
            HEARTBEAT_ID => Some(MavMessage::HEARTBEAT(identity::heartbeat(&VehicleStatus {
                mode: self.mode,
                armed: self.armed,
                failsafe: self.failsafe_active(),
            }))),
            AUTOPILOT_VERSION_ID => Some(MavMessage::AUTOPILOT_VERSION(identity::autopilot_version(self.sysid))),
            PROTOCOL_VERSION_ID => Some(MavMessage::PROTOCOL_VERSION(identity::protocol_version())),
            _ => StreamMsg::from_message_id(id).and_then(|m| self.build(m)),
        }
    }

    fn build(&self, msg: StreamMsg) -> Option<MavMessage> {
        Some(match msg {
            StreamMsg::SysStatus => MavMessage::SYS_STATUS(self.sys_status()),
            StreamMsg::GpsRawInt => MavMessage::GPS_RAW_INT(self.gps_raw_int()),
            StreamMsg::NavControllerOutput => MavMessage::NAV_CONTROLLER_OUTPUT(self.nav_controller_output()?),
            StreamMsg::PositionTargetGlobalInt => MavMessage::POSITION_TARGET_GLOBAL_INT(self.position_target()?),
            StreamMsg::ServoOutputRaw => MavMessage::SERVO_OUTPUT_RAW(self.servo_output_raw()),
            StreamMsg::GlobalPositionInt => MavMessage::GLOBAL_POSITION_INT(self.global_position_int()?),
            StreamMsg::LocalPositionNed => MavMessage::LOCAL_POSITION_NED(self.local_position_ned()?),
            StreamMsg::Attitude => MavMessage::ATTITUDE(self.attitude()),
            StreamMsg::SimState => MavMessage::SIMSTATE(self.simstate()?),
            StreamMsg::VfrHud => MavMessage::VFR_HUD(self.vfr_hud()),
            StreamMsg::SystemTime => MavMessage::SYSTEM_TIME(SYSTEM_TIME_DATA {
                time_unix_usec: self
                    .estimator
                    .gnss()
                    .utc_now_us(self.now.boot)
                    .map_or(0, |u| u.max(0) as u64),
                time_boot_ms: self.now.boot_ms(),
            }),
            StreamMsg::BatteryStatus => MavMessage::BATTERY_STATUS(battery_status(self.battery.as_ref()?)),
            StreamMsg::EkfStatusReport => MavMessage::EKF_STATUS_REPORT(self.ekf_status_report()),
            StreamMsg::ExtendedSysState => MavMessage::EXTENDED_SYS_STATE(EXTENDED_SYS_STATE_DATA {
                vtol_state: MavVtolState::MAV_VTOL_STATE_UNDEFINED,
                landed_state: MavLandedState::MAV_LANDED_STATE_ON_GROUND,
            }),
            StreamMsg::HomePosition => return self.build_home_position(),
            StreamMsg::MissionCurrent => MavMessage::MISSION_CURRENT(self.mission_current()),
            StreamMsg::FenceStatus => MavMessage::FENCE_STATUS(self.fence_status()?),
            StreamMsg::RelayStatus => MavMessage::RELAY_STATUS(self.relay_status()?),
            StreamMsg::ObstacleDistance => MavMessage::OBSTACLE_DISTANCE(self.obstacle_distance()?),
        })
    }

    pub(super) fn build_home_position(&self) -> Option<MavMessage> {
        let home = self.home?;
        let local = self.frame().map(|f| f.to_local(&home)).unwrap_or_default();
        let origin_alt = self.frame().map_or(home.alt_m, |f| f.origin().alt_m);
        Some(MavMessage::HOME_POSITION(HOME_POSITION_DATA {
            latitude: home.lat_e7(),
            longitude: home.lon_e7(),
            altitude: (home.alt_m * 1000.0).round() as i32,
            x: local.north_m as f32,
            y: local.east_m as f32,
            z: -(home.alt_m - origin_alt) as f32,
            q: [1.0, 0.0, 0.0, 0.0],
            approach_x: 0.0,
            approach_y: 0.0,
            approach_z: 0.0,
            time_usec: self
                .estimator
                .gnss()
                .utc_now_us(self.now.boot)
                .map_or(0, |u| u.max(0) as u64),
        }))
    }

    fn sys_status(&self) -> SYS_STATUS_DATA {
        let (fence_present, fence_enabled, fence_healthy) = self.fence_status_bits();
        let (heading_present, heading_healthy) = self.heading_sensor_bits();
        let obstacles = self.obstacle_status();
        let present = self.sensors_present(fence_present, heading_present, obstacles.enabled);
        let health = self.sensors_health(present, fence_healthy, heading_healthy, obstacles.scans_fresh);
        let enabled = self.sensors_enabled(present, fence_enabled);
        let (voltage, current, remaining) = self.battery_status_fields();
        SYS_STATUS_DATA {
            onboard_control_sensors_present: present,
            onboard_control_sensors_enabled: enabled,
            onboard_control_sensors_health: health,
            load: self.loop_load_permille(),
            voltage_battery: voltage,
            current_battery: current,
            drop_rate_comm: 0,
            errors_comm: 0,
            errors_count1: 0,
            errors_count2: 0,
            errors_count3: 0,
            errors_count4: 0,
            battery_remaining: remaining,
            onboard_control_sensors_present_extended: MavSysStatusSensorExtended::empty(),
            onboard_control_sensors_enabled_extended: MavSysStatusSensorExtended::empty(),
            onboard_control_sensors_health_extended: MavSysStatusSensorExtended::empty(),
        }
    }

    /// SYS_STATUS's "present" bits: the sensors and functions this vehicle has.
    fn sensors_present(
        &self,
        fence_present: bool,
        heading_present: bool,
        obstacles_enabled: bool,
    ) -> MavSysStatusSensor {
        let mut present = MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_GPS
            | MavSysStatusSensor::MAV_SYS_STATUS_AHRS
            | MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS
            | MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_XY_POSITION_CONTROL
            | MavSysStatusSensor::MAV_SYS_STATUS_PREARM_CHECK;
        if self.battery.is_some() {
            present |= MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_BATTERY;
        }
        if fence_present {
            present |= MavSysStatusSensor::MAV_SYS_STATUS_GEOFENCE;
        }
        if heading_present {
            present |= MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_MAG;
        }
        // An inertial unit once it has reported (as the heading sensor).
        if self.estimator.imu().last().is_some() {
            present |=
                MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_GYRO | MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_ACCEL;
        }
        if obstacles_enabled {
            present |= MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_PROXIMITY
                | MavSysStatusSensor::MAV_SYS_STATUS_OBSTACLE_AVOIDANCE;
        }
        present
    }

    /// SYS_STATUS's "health" bits: the present ones, less those failing now.
    fn sensors_health(
        &self,
        present: MavSysStatusSensor,
        fence_healthy: bool,
        heading_healthy: bool,
        scans_fresh: bool,
    ) -> MavSysStatusSensor {
        let estimate = self.estimator.estimate();
        let gps_ok = self
            .estimator
            .gnss()
            .has_fix(self.now.boot, std::time::Duration::from_secs(2));
        let mut health = present;
        // Both are healthy while every fitted scanner is live: without scans
        // avoidance cannot work (and the vehicle will not drive).
        if !scans_fresh {
            health.remove(MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_PROXIMITY);
            health.remove(MavSysStatusSensor::MAV_SYS_STATUS_OBSTACLE_AVOIDANCE);
        }

        // As ArduPilot: the geofence health bit means "not breached", so a
        // vehicle without a fence reports it healthy (MAVProxy announces a
        // breach otherwise).
        if fence_healthy {
            health |= MavSysStatusSensor::MAV_SYS_STATUS_GEOFENCE;
        } else {
            health.remove(MavSysStatusSensor::MAV_SYS_STATUS_GEOFENCE);
        }
        if !gps_ok {
            health.remove(MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_GPS);
        }
        if !heading_healthy {
            health.remove(MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_MAG);
        }
        let imu = self.estimator.imu();
        if !imu.gyro_healthy(self.now.boot) {
            health.remove(MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_GYRO);
        }
        if !imu.accel_healthy(self.now.boot) || self.failsafe_is_active(Failsafe::ImuLost) {
            health.remove(MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_ACCEL);
        }
        if self.battery_arming_failure().is_some() {
            health.remove(MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_BATTERY);
        }
        if !(estimate.position_valid && estimate.heading_valid) {
            health.remove(MavSysStatusSensor::MAV_SYS_STATUS_AHRS);
        }
        // A failsafe's sensor stays unhealthy as long as the failsafe is on,
        // even where the raw reading would pass.
        for failsafe in self.active_failsafes() {
            if let Some(sensor) = failsafe.health_sensor() {
                health.remove(sensor);
            }
            if failsafe == Failsafe::Scanner {
                health.remove(MavSysStatusSensor::MAV_SYS_STATUS_OBSTACLE_AVOIDANCE);
            }
        }
        if !self.arming_failures().is_empty() {
            health.remove(MavSysStatusSensor::MAV_SYS_STATUS_PREARM_CHECK);
        }
        health
    }

    /// SYS_STATUS's "enabled" bits: the present ones, less those idle in
    /// this mode and arming state.
    fn sensors_enabled(&self, present: MavSysStatusSensor, fence_enabled: bool) -> MavSysStatusSensor {
        let mut enabled = present;
        if !self.armed {
            enabled.remove(MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS);
        }
        if !self.mode.is_autopilot() {
            enabled.remove(MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_XY_POSITION_CONTROL);
        }
        if !(self.mode.self_driving() && self.armed) {
            enabled.remove(MavSysStatusSensor::MAV_SYS_STATUS_OBSTACLE_AVOIDANCE);
        }
        if !fence_enabled {
            enabled.remove(MavSysStatusSensor::MAV_SYS_STATUS_GEOFENCE);
        }
        enabled
    }

    /// SYS_STATUS's `load`: the median loop run time as per-mille of the
    /// loop period, capped at 1000.
    fn loop_load_permille(&self) -> u16 {
        let tick = self.sched.tick_stats();
        let period_us = self.loop_period().as_micros() as f64;
        if tick.runs > 0 {
            (tick.histogram.quantile_ns(0.5) as f64 / 1000.0 / period_us * 1000.0).min(1000.0) as u16
        } else {
            0
        }
    }

    /// SYS_STATUS's battery fields (mV, cA, %), or MAVLink's "unknown"
    /// values without a battery monitor.
    fn battery_status_fields(&self) -> (u16, i16, i8) {
        match &self.battery {
            Some(b) => (
                (b.voltage_v * 1000.0).round().clamp(0.0, 65534.0) as u16,
                (b.current_a * 100.0).round().clamp(-32768.0, 32767.0) as i16,
                b.remaining_pct.round().clamp(0.0, 100.0) as i8,
            ),
            None => (u16::MAX, -1, -1),
        }
    }

    /// The heading sensor (dual antenna or compass) in SYS_STATUS's
    /// magnetometer slot, the role ArduPilot's compass plays: (present,
    /// healthy). Present once it has reported; healthy while it reports
    /// within `FS_HDG_TIMEOUT` and the heading failsafe is off. A vehicle
    /// steering on its GNSS course has none, and says so. No gyro or
    /// accelerometer bits: Furrow has no IMU, and a ground station that
    /// requires one (MAVSDK's `health_all_ok`) is told the truth.
    fn heading_sensor_bits(&self) -> (bool, bool) {
        let Some(last) = self.estimator.heading_sensor_last() else {
            return (false, false);
        };
        let timeout = crate::time::duration_from_secs(f64::from(self.p.failsafe.heading_lost_s.get(&self.params)));
        let fresh = self.now.boot.saturating_sub(last) <= timeout;
        (true, fresh && !self.failsafe_is_active(Failsafe::HeadingLost))
    }

    fn gps_raw_int(&self) -> GPS_RAW_INT_DATA {
        let g = self.estimator.gnss();
        let fix_type = match g.mavlink_fix_type(self.now.boot) {
            6 => GpsFixType::GPS_FIX_TYPE_RTK_FIXED,
            5 => GpsFixType::GPS_FIX_TYPE_RTK_FLOAT,
            4 => GpsFixType::GPS_FIX_TYPE_DGPS,
            3 => GpsFixType::GPS_FIX_TYPE_3D_FIX,
            1 => GpsFixType::GPS_FIX_TYPE_NO_FIX,
            _ => GpsFixType::GPS_FIX_TYPE_NO_GPS,
        };
        let has_position = g.lat_deg.is_finite() && g.lon_deg.is_finite() && g.quality.is_some();
        let h_acc_mm = g
            .sigma_north_m
            .zip(g.sigma_east_m)
            .map_or(self.estimator.estimate().horiz_sigma_m, |(n, e)| n.max(e));
        GPS_RAW_INT_DATA {
            time_usec: g
                .utc_now_us(self.now.boot)
                .map_or(self.now.boot.as_micros() as u64, |u| u.max(0) as u64),
            lat: if has_position {
                (g.lat_deg * 1e7).round() as i32
            } else {
                0
            },
            lon: if has_position {
                (g.lon_deg * 1e7).round() as i32
            } else {
                0
            },
            alt: if has_position {
                (g.alt_msl_m * 1000.0).round() as i32
            } else {
                0
            },
            eph: if g.hdop > 0.0 {
                (f64::from(g.hdop) * 100.0).round().min(65534.0) as u16
            } else {
                u16::MAX
            },
            epv: u16::MAX,
            vel: (g.speed_mps * 100.0).round().clamp(0.0, 65534.0) as u16,
            cog: g.course_deg.map_or(u16::MAX, |c| cdeg_0_36000(c.to_radians())),
            fix_type,
            satellites_visible: g.satellites,
            alt_ellipsoid: 0,
            h_acc: (h_acc_mm * 1000.0).round().clamp(0.0, f64::from(u32::MAX)) as u32,
            v_acc: g.sigma_up_m.map_or(0, |s| (s * 1000.0).round() as u32),
            vel_acc: 0,
            // The heading's quality: the filter's yaw σ (degE5) once a
            // heading sensor (HDT/THS or a compass) feeds it.
            hdg_acc: match (g.heading_deg, self.estimator.ekf_status()) {
                (Some(_), Some(status)) if status.heading_sigma_rad.is_finite() => {
                    (status.heading_sigma_rad.to_degrees() * 1e5)
                        .round()
                        .clamp(1.0, f64::from(u32::MAX)) as u32
                }
                _ => 0,
            },
            // 0 = this GPS gives no yaw; 36000 = north.
            yaw: g.heading_deg.map_or(0, |h| match cdeg_0_36000(h.to_radians()) {
                0 => 36000,
                cd => cd,
            }),
        }
    }

    /// How much a heading in the local frame must turn to be a true heading
    /// at the vehicle (meridian convergence, plant-grid rotation): MAVLink
    /// headings are true.
    pub(super) fn true_heading_offset_rad(&self) -> f64 {
        let e = self.estimator.estimate();
        match self.frame() {
            Some(frame) => {
                let at = frame.to_geodetic(&e.position);
                if at.is_valid() {
                    wrap_pi(frame.heading_to_true(&at, e.yaw_rad) - e.yaw_rad)
                } else {
                    0.0
                }
            }
            None => 0.0,
        }
    }

    fn global_position_int(&self) -> Option<GLOBAL_POSITION_INT_DATA> {
        let frame = self.frame()?;
        let e = self.estimator.estimate();
        let turn = self.true_heading_offset_rad();
        let (sin, cos) = turn.sin_cos();
        let (vn, ve) = (
            e.vel_north_mps * cos - e.vel_east_mps * sin,
            e.vel_north_mps * sin + e.vel_east_mps * cos,
        );
        let p = frame.to_geodetic(&e.position);
        let alt_m = self.estimator.gnss().alt_msl_m;
        let home_alt = self.home.map_or(alt_m, |h| h.alt_m);
        Some(GLOBAL_POSITION_INT_DATA {
            time_boot_ms: self.now.boot_ms(),
            lat: p.lat_e7(),
            lon: p.lon_e7(),
            alt: (alt_m * 1000.0).round() as i32,
            relative_alt: ((alt_m - home_alt) * 1000.0).round() as i32,
            vx: (vn * 100.0).round().clamp(-32768.0, 32767.0) as i16,
            vy: (ve * 100.0).round().clamp(-32768.0, 32767.0) as i16,
            vz: 0,
            hdg: if e.heading_valid {
                cdeg_0_36000(e.yaw_rad + turn)
            } else {
                u16::MAX
            },
        })
    }

    /// The estimate in metres north, east and down of the local origin (the
    /// first fix, as ArduPilot's EKF origin), on the tangent plane there and
    /// towards true north whatever `GEO_FRAME` the core works in: what a
    /// ground station checks positions against below GLOBAL_POSITION_INT's
    /// 1e-7° steps.
    fn local_position_ned(&self) -> Option<LOCAL_POSITION_NED_DATA> {
        let frame = self.frame()?;
        let e = self.estimator.estimate();
        let origin = frame.origin();
        let plain_tangent_plane = frame.kind() == FrameKind::TangentPlane && frame.map().is_none();
        let position = if plain_tangent_plane {
            e.position
        } else {
            LocalFrame::new(origin).to_local(&frame.to_geodetic(&e.position))
        };
        let turn = self.true_heading_offset_rad();
        let (sin, cos) = turn.sin_cos();
        Some(LOCAL_POSITION_NED_DATA {
            time_boot_ms: self.now.boot_ms(),
            x: position.north_m as f32,
            y: position.east_m as f32,
            z: -(self.estimator.gnss().alt_msl_m - origin.alt_m) as f32,
            vx: (e.vel_north_mps * cos - e.vel_east_mps * sin) as f32,
            vy: (e.vel_north_mps * sin + e.vel_east_mps * cos) as f32,
            vz: 0.0,
        })
    }

    fn attitude(&self) -> ATTITUDE_DATA {
        let e = self.estimator.estimate();
        ATTITUDE_DATA {
            time_boot_ms: self.now.boot_ms(),
            roll: 0.0,
            pitch: 0.0,
            yaw: wrap_pi(e.yaw_rad + self.true_heading_offset_rad()) as f32,
            rollspeed: 0.0,
            pitchspeed: 0.0,
            yawspeed: e.yaw_rate_rad_s as f32,
        }
    }

    fn vfr_hud(&self) -> VFR_HUD_DATA {
        let e = self.estimator.estimate();
        let speed = e.ground_speed_mps() as f32;
        VFR_HUD_DATA {
            airspeed: speed,
            groundspeed: speed,
            alt: self.estimator.gnss().alt_msl_m as f32,
            climb: 0.0,
            heading: (wrap_2pi(e.yaw_rad + self.true_heading_offset_rad())
                .to_degrees()
                .round() as i16)
                % 360,
            throttle: (self.drive.throttle.abs() * 100.0).round() as u16,
        }
    }

    fn nav_controller_output(&self) -> Option<NAV_CONTROLLER_OUTPUT_DATA> {
        if !self.mode.is_autopilot() {
            return None;
        }
        let s = self.navigator.status();
        let turn = self.true_heading_offset_rad();
        let deg = |rad: f64| (wrap_pi(rad + turn).to_degrees().round()) as i16;
        if self.mode == Mode::Magnetic {
            // The tape is the path: its offset from the sensors' midpoint.
            let m = &self.magnetic.status;
            let yaw = self.estimator.estimate().yaw_rad;
            return Some(NAV_CONTROLLER_OUTPUT_DATA {
                nav_roll: 0.0,
                nav_pitch: 0.0,
                alt_error: 0.0,
                aspd_error: 0.0,
                xtrack_error: -m.lateral_m as f32,
                nav_bearing: deg(yaw + m.steer_rad),
                target_bearing: deg(yaw + m.angle_rad),
                wp_dist: 0,
            });
        }
        Some(NAV_CONTROLLER_OUTPUT_DATA {
            nav_roll: 0.0,
            nav_pitch: 0.0,
            alt_error: 0.0,
            aspd_error: 0.0,
            xtrack_error: s.crosstrack_m as f32,
            nav_bearing: deg(s.nav_bearing_rad),
            target_bearing: deg(s.target_bearing_rad),
            wp_dist: s.wp_dist_m.round().clamp(0.0, 65535.0) as u16,
        })
    }

    fn position_target(&self) -> Option<POSITION_TARGET_GLOBAL_INT_DATA> {
        let target = self.navigator.target()?;
        let frame = self.frame()?;
        let p = frame.to_geodetic(&target.point);
        // A manoeuvre's stroke ends with a heading: sent, as a true one.
        let yaw = self.navigator.target_yaw().map(|yaw| frame.heading_to_true(&p, yaw));
        Some(POSITION_TARGET_GLOBAL_INT_DATA {
            time_boot_ms: self.now.boot_ms(),
            lat_int: p.lat_e7(),
            lon_int: p.lon_e7(),
            alt: self.estimator.gnss().alt_msl_m as f32,
            vx: 0.0,
            vy: 0.0,
            vz: 0.0,
            afx: 0.0,
            afy: 0.0,
            afz: 0.0,
            yaw: yaw.unwrap_or(0.0) as f32,
            yaw_rate: 0.0,
            type_mask: PositionTargetTypemask::from_bits_truncate(0xF000)
                | PositionTargetTypemask::POSITION_TARGET_TYPEMASK_VX_IGNORE
                | PositionTargetTypemask::POSITION_TARGET_TYPEMASK_VY_IGNORE
                | PositionTargetTypemask::POSITION_TARGET_TYPEMASK_VZ_IGNORE
                | PositionTargetTypemask::POSITION_TARGET_TYPEMASK_AX_IGNORE
                | PositionTargetTypemask::POSITION_TARGET_TYPEMASK_AY_IGNORE
                | PositionTargetTypemask::POSITION_TARGET_TYPEMASK_AZ_IGNORE
                | PositionTargetTypemask::POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE
                | if yaw.is_some() {
                    PositionTargetTypemask::empty()
                } else {
                    PositionTargetTypemask::POSITION_TARGET_TYPEMASK_YAW_IGNORE
                },
            coordinate_frame: MavFrame::MAV_FRAME_GLOBAL,
        })
    }

    fn relay_status(&self) -> Option<RELAY_STATUS_DATA> {
        (self.missions.relays_used != 0).then(|| RELAY_STATUS_DATA {
            time_boot_ms: self.now.boot_ms(),
            on: self.missions.relays_on,
            present: self.missions.relays_used,
        })
    }

    fn servo_output_raw(&self) -> SERVO_OUTPUT_RAW_DATA {
        let pwm = self.servo_pwm_us;
        SERVO_OUTPUT_RAW_DATA {
            time_usec: self.now.boot.as_micros() as u32,
            servo1_raw: pwm[0],
            servo2_raw: pwm[1],
            servo3_raw: pwm[2],
            servo4_raw: pwm[3],
            servo5_raw: pwm[4],
            servo6_raw: pwm[5],
            servo7_raw: pwm[6],
            servo8_raw: pwm[7],
            port: 0,
            servo9_raw: pwm[8],
            servo10_raw: pwm[9],
            servo11_raw: pwm[10],
            servo12_raw: pwm[11],
            servo13_raw: pwm[12],
            servo14_raw: pwm[13],
            servo15_raw: pwm[14],
            servo16_raw: pwm[15],
        }
    }

    fn ekf_status_report(&self) -> EKF_STATUS_REPORT_DATA {
        let e = self.estimator.estimate();
        let mut flags = EkfStatusFlags::empty();
        if e.heading_valid {
            flags |= EkfStatusFlags::EKF_ATTITUDE;
        }
        if e.position_valid {
            flags |= EkfStatusFlags::EKF_VELOCITY_HORIZ
                | EkfStatusFlags::EKF_POS_HORIZ_REL
                | EkfStatusFlags::EKF_POS_HORIZ_ABS
                | EkfStatusFlags::EKF_PRED_POS_HORIZ_REL
                | EkfStatusFlags::EKF_PRED_POS_HORIZ_ABS;
        }
        // Dead reckoning may still call its position valid: a GNSS, heading
        // or EKF failsafe that is on says otherwise, as long as it is on.
        for failsafe in self.active_failsafes() {
            flags.remove(failsafe.ekf_flags_withheld());
        }
        // As ArduPilot: the "variances" are the innovation test ratios'
        // square roots (1.0 = at the gate), which GCSs colour by.
        let Some(status) = self.estimator.ekf_status().filter(|s| s.initialised) else {
            return EKF_STATUS_REPORT_DATA {
                velocity_variance: 0.0,
                pos_horiz_variance: 0.0,
                pos_vert_variance: 0.0,
                compass_variance: 0.0,
                terrain_alt_variance: 0.0,
                flags: EkfStatusFlags::EKF_UNINITIALIZED,
                airspeed_variance: 0.0,
            };
        };
        if status.gnss_position.consecutive_rejected > 0 {
            flags |= EkfStatusFlags::EKF_GPS_GLITCHING;
        }
        // The position bar also shows the fix: its σ against 1 m, so a
        // downgrade to single (σ ≈ 2.5 m per axis) turns it red, RTK float
        // (≈ 0.3 m) leaves it green, as the test ratio alone would not.
        let position = status.gnss_position.report_value().max(status.position_sigma_m as f32);
        EKF_STATUS_REPORT_DATA {
            velocity_variance: status.gnss_velocity.report_value(),
            pos_horiz_variance: position,
            pos_vert_variance: 0.0,
            compass_variance: status.heading.report_value(),
            terrain_alt_variance: 0.0,
            flags,
            airspeed_variance: 0.0,
        }
    }
}

fn battery_status(b: &BatterySample) -> BATTERY_STATUS_DATA {
    let mut voltages = [u16::MAX; 10];
    voltages[0] = (b.voltage_v * 1000.0).round().clamp(0.0, 65534.0) as u16;
    let remaining = b.remaining_pct.round().clamp(0.0, 100.0) as i8;
    BATTERY_STATUS_DATA {
        current_consumed: b.consumed_mah.round() as i32,
        energy_consumed: -1,
        temperature: i16::MAX,
        voltages,
        current_battery: (b.current_a * 100.0).round().clamp(-32768.0, 32767.0) as i16,
        id: 0,
        battery_function: MavBatteryFunction::MAV_BATTERY_FUNCTION_ALL,
        mavtype: MavBatteryType::MAV_BATTERY_TYPE_LION,
        battery_remaining: remaining,
        time_remaining: 0,
        charge_state: if remaining > 20 {
            MavBatteryChargeState::MAV_BATTERY_CHARGE_STATE_OK
        } else if remaining > 10 {
            MavBatteryChargeState::MAV_BATTERY_CHARGE_STATE_LOW
        } else {
            MavBatteryChargeState::MAV_BATTERY_CHARGE_STATE_CRITICAL
        },
        voltages_ext: [0; 4],
        mode: MavBatteryMode::MAV_BATTERY_MODE_UNKNOWN,
        fault_bitmask: MavBatteryFault::empty(),
    }
}
