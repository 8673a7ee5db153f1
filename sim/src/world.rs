//! The SITL world: one vehicle on the WGS-84 ellipsoid, its battery, its
//! GNSS receiver, and optionally obstacles and laser scanners, advanced in
//! simulated time.

use std::collections::VecDeque;
use std::time::Duration;

use super::battery::Battery;
use super::geo::LocalFrame;
use super::gnss_sim::GnssSim;
use super::imu_sim::{ImuSim, ImuSimConfig};
use super::magnetic::MagneticTape;
use super::obstacles::{ObstacleWorld, Rectangle, Shape, VehicleOutline};
use super::scanner::{SimScanner, SimScannerConfig, scanner_seed};
use super::vehicle::{self, VehicleTruth, wrap_pi};
use super::{ActuatorDemand, BatterySample, GeoPoint, GnssSimConfig, MagneticSensorConfig, VehicleModel, WorldConfig};
use drivers::scanner::Scan;

/// The physics rate used when the configured one is unusable (≤ 0, NaN).
const FALLBACK_PHYSICS_RATE_HZ: f64 = 400.0;
/// A mistyped rate must not turn one step into billions of sub-steps.
const MAX_PHYSICS_RATE_HZ: f64 = 100_000.0;
/// Scans nobody takes are dropped oldest first beyond this (two scanners'
/// worth of a bit over a second at 50 Hz): a reader that stalls sees a gap
/// in `scan_counter`, as it would on the wire, and memory stays bounded.
const MAX_PENDING_SCANS: usize = 128;

#[derive(Clone, Debug)]
pub struct World {
    config: WorldConfig,
    frame: LocalFrame,
    time: Duration,
    truth: VehicleTruth,
    battery: Battery,
    gnss: GnssSim,
    /// The inertial unit, if one is fitted.
    imu: Option<ImuSim>,
    /// The magnetic guide tape, if one is laid.
    tape: Option<MagneticTape>,
    /// Seeds the magnetic sensors' edge noise and the scanners' noise
    /// (streams of their own, apart from the receiver's).
    seed: u64,
    /// What the scanners see and the vehicle can hit, if anything.
    obstacles: Option<ObstacleWorld>,
    scanners: Vec<SimScanner>,
    /// Scans taken and not yet collected, with their scanner's index.
    scans: VecDeque<(usize, Scan)>,
    /// Scans handed back by [`Self::recycle_scans`], rendered into next.
    spare_scans: Vec<Scan>,
    stage_times: WorldStageTimes,
}

/// Wall time spent in each part of the world's steps, nanoseconds (zero
/// unless stepped with [`World::step_timed`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct WorldStageTimes {
    /// Vehicle and battery integration.
    pub physics_ns: u64,
    /// The receiver's epochs: noise and NMEA sentences out.
    pub gnss_out_ns: u64,
    /// Ray casting the scanners' scans.
    pub scan_render_ns: u64,
}

impl World {
    /// The vehicle starts at home (its reference point), heading
    /// `home_heading_deg`, at rest. The same seed gives the same noise.
    pub fn new(config: WorldConfig, seed: u64) -> Self {
        let truth = VehicleTruth {
            yaw_rad: wrap_pi(config.home_heading_deg.to_radians()),
            ..VehicleTruth::default()
        };
        Self {
            frame: LocalFrame::new(config.home),
            gnss: GnssSim::new(seed, &config.gnss),
            imu: None,
            config,
            time: Duration::ZERO,
            truth,
            battery: Battery::default(),
            tape: None,
            seed,
            obstacles: None,
            scanners: Vec::new(),
            scans: VecDeque::new(),
            spare_scans: Vec::new(),
            stage_times: WorldStageTimes::default(),
        }
    }

    pub fn time(&self) -> Duration {
        self.time
    }

    /// Advance by `dt` with `demand` held. Physics runs in sub-steps of
    /// 1/`physics_rate_hz` (the last one shorter, so time lands exactly); GNSS
    /// epochs and laser scans fall at exact multiples of their own periods
    /// and sample the state at that instant, re-integrated inside a sub-step
    /// if need be.
    pub fn step(&mut self, dt: Duration, demand: &ActuatorDemand) {
        self.step_timed(dt, demand, &mut || 0);
    }

    /// [`Self::step`], adding the wall time of each part to
    /// [`Self::stage_times`] as read from `now_ns` (a monotonic nanosecond
    /// clock; the readings change nothing the world computes).
    pub fn step_timed(&mut self, dt: Duration, demand: &ActuatorDemand, now_ns: &mut dyn FnMut() -> u64) {
        let started_ns = now_ns();
        let emitting_before_ns = self.stage_times.gnss_out_ns + self.stage_times.scan_render_ns;
        let end = self.time + dt;
        let now_state = self.truth;
        self.emit_due_epochs(&now_state, self.time, demand, now_ns);
        let sub_step = self.sub_step();
        while self.time < end {
            let h = sub_step.min(end - self.time);
            let start = self.truth;
            let motion = vehicle::step(&self.config.vehicle, &mut self.truth, demand, h.as_secs_f64());
            self.battery.step(
                &self.config.battery,
                motion.speed_mps,
                motion.accel_mps2,
                h.as_secs_f64(),
            );
            let sub_step_start = self.time;
            self.time += h;
            self.emit_due_epochs(&start, sub_step_start, demand, now_ns);
        }
        let emitting_ns = self.stage_times.gnss_out_ns + self.stage_times.scan_render_ns - emitting_before_ns;
        let step_ns = now_ns().saturating_sub(started_ns);
        self.stage_times.physics_ns += step_ns.saturating_sub(emitting_ns);
    }

    /// Wall time spent so far in each part of [`Self::step_timed`].
    pub fn stage_times(&self) -> WorldStageTimes {
        self.stage_times
    }

    /// The vehicle at `t`, which lies in the sub-step that began at
    /// `start_t` in state `start` and ends now.
    fn state_at(&self, start: &VehicleTruth, start_t: Duration, t: Duration, demand: &ActuatorDemand) -> VehicleTruth {
        if t >= self.time {
            return self.truth;
        }
        let mut state = *start;
        let into_s = t.saturating_sub(start_t).as_secs_f64();
        vehicle::step(&self.config.vehicle, &mut state, demand, into_s);
        state
    }

    /// Emit every GNSS epoch and laser scan due by now; `start` is the state
    /// at `start_t`, the beginning of the sub-step just taken (or now,
    /// before any).
    fn emit_due_epochs(
        &mut self,
        start: &VehicleTruth,
        start_t: Duration,
        demand: &ActuatorDemand,
        now_ns: &mut dyn FnMut() -> u64,
    ) {
        // The clock is read only when there is something to emit: most
        // sub-steps have nothing.
        if self.gnss.due(self.time).is_some() {
            let started_ns = now_ns();
            self.emit_due_gnss(start, start_t, demand);
            self.stage_times.gnss_out_ns += now_ns().saturating_sub(started_ns);
        }
        if self.imu.as_ref().is_some_and(|imu| imu.due(self.time).is_some()) {
            let started_ns = now_ns();
            self.emit_due_imu(start, start_t, demand);
            self.stage_times.gnss_out_ns += now_ns().saturating_sub(started_ns);
        }
        if self.scanners.iter().any(|s| s.due(self.time).is_some()) {
            let started_ns = now_ns();
            self.emit_due_scans(start, start_t, demand);
            self.stage_times.scan_render_ns += now_ns().saturating_sub(started_ns);
        }
    }

    fn emit_due_gnss(&mut self, start: &VehicleTruth, start_t: Duration, demand: &ActuatorDemand) {
        while let Some(epoch_t) = self.gnss.due(self.time) {
            // Re-integrate the part of the sub-step up to the epoch.
            let state = self.state_at(start, start_t, epoch_t, demand);
            self.gnss.emit(
                epoch_t,
                &state,
                &self.config.gnss,
                self.frame,
                self.config.utc_start_unix_us,
            );
        }
    }

    fn emit_due_imu(&mut self, start: &VehicleTruth, start_t: Duration, demand: &ActuatorDemand) {
        while let Some(sample_t) = self.imu.as_ref().and_then(|imu| imu.due(self.time)) {
            let state = self.state_at(start, start_t, sample_t, demand);
            if let Some(imu) = &mut self.imu {
                imu.emit(sample_t, &state);
            }
        }
    }

    /// Take every scan due by now, earliest first (the lower index on a
    /// tie), each from the true pose at its own instant.
    fn emit_due_scans(&mut self, start: &VehicleTruth, start_t: Duration, demand: &ActuatorDemand) {
        if self.scanners.is_empty() {
            return;
        }
        let empty = ObstacleWorld::default();
        loop {
            let next = self
                .scanners
                .iter()
                .enumerate()
                .filter_map(|(i, s)| s.due(self.time).map(|t| (t, i)))
                .min();
            let Some((scan_t, index)) = next else {
                return;
            };
            let state = self.state_at(start, start_t, scan_t, demand);
            let obstacles = self.obstacles.as_ref().unwrap_or(&empty);
            let mut scan = self.spare_scans.pop().unwrap_or_else(empty_scan);
            if !self.scanners[index].scan_into(obstacles, &state, &mut scan) {
                self.spare_scans.push(scan);
                return;
            }
            if self.scans.len() >= MAX_PENDING_SCANS
                && let Some((_, dropped)) = self.scans.pop_front()
            {
                self.spare_scans.push(dropped);
            }
            self.scans.push_back((index, scan));
        }
    }

    fn sub_step(&self) -> Duration {
        let rate = self.config.physics_rate_hz;
        let rate = if rate.is_finite() && rate > 0.0 {
            rate.min(MAX_PHYSICS_RATE_HZ)
        } else {
            FALLBACK_PHYSICS_RATE_HZ
        };
        Duration::from_nanos((1e9 / rate).round() as u64)
    }

    /// Append everything the receiver sent since the last call, then forget it.
    pub fn take_gnss_bytes(&mut self, out: &mut Vec<u8>) {
        self.gnss.take_bytes(out);
    }

    /// Fit (or remove, with `None`) the inertial unit: its samples start on
    /// its rate's grid from now, with a power-on bias drawn from the
    /// world's seed (a stream of its own: the other devices' noise is
    /// unchanged).
    pub fn set_imu(&mut self, config: Option<ImuSimConfig>) {
        self.imu = config.map(|c| ImuSim::new(c, self.seed, self.time));
    }

    /// Append the `$VNIMU` lines the unit sent since the last call.
    pub fn take_imu_bytes(&mut self, out: &mut Vec<u8>) {
        if let Some(imu) = &mut self.imu {
            imu.take_bytes(out);
        }
    }

    /// The unit's gyro bias now (x, y, z), if one is fitted: the truth a
    /// calibration is judged against.
    pub fn imu_gyro_bias_rad_s(&self) -> Option<[f64; 3]> {
        self.imu.as_ref().map(ImuSim::gyro_bias_rad_s)
    }

    pub fn truth(&self) -> &VehicleTruth {
        &self.truth
    }

    /// The reference point on the ground, in WGS-84.
    pub fn truth_geodetic(&self) -> GeoPoint {
        self.local_to_geodetic(self.truth.north_m, self.truth.east_m)
    }

    /// The point `north_m`, `east_m` on the home tangent plane (down = 0).
    pub fn local_to_geodetic(&self, north_m: f64, east_m: f64) -> GeoPoint {
        self.frame.to_geodetic(north_m, east_m, 0.0)
    }

    /// (north, east) of `p` in the home NED frame.
    pub fn geodetic_to_local(&self, p: &GeoPoint) -> (f64, f64) {
        let (north_m, east_m, _) = self.frame.to_local(p);
        (north_m, east_m)
    }

    pub fn battery(&self) -> BatterySample {
        self.battery.sample(&self.config.battery)
    }

    pub fn config(&self) -> &WorldConfig {
        &self.config
    }

    /// Takes effect at the next epoch (a new rate starts its grid from now;
    /// a new walk σ describes the receiver's slow error from then on).
    pub fn set_gnss_config(&mut self, gnss: GnssSimConfig) {
        self.gnss.reschedule(&gnss, self.time);
        self.gnss
            .rescale_walk(self.config.gnss.pos_walk_sigma_m, gnss.pos_walk_sigma_m);
        self.config.gnss = gnss;
    }

    /// Keeps the pose and carries the motion over as far as the new model
    /// allows.
    pub fn set_vehicle_model(&mut self, model: VehicleModel) {
        vehicle::adapt(&model, &mut self.truth);
        self.config.vehicle = model;
    }

    /// Lay (or lift, with `None`) the magnetic guide tape. Nothing else in the
    /// world depends on it.
    pub fn set_tape(&mut self, tape: Option<MagneticTape>) {
        self.tape = tape;
    }

    pub fn tape(&self) -> Option<&MagneticTape> {
        self.tape.as_ref()
    }

    /// Place (or clear, with `None`) the obstacles. Scanners see them from
    /// their next scan; nothing else in the world depends on them (the
    /// vehicle drives through obstacles: see [`Self::clearance_m`]).
    /// The other vehicles of a fleet are kept (see [`Self::set_other_vehicles`]).
    pub fn set_obstacles(&mut self, obstacles: Option<ObstacleWorld>) {
        let vehicles = self
            .obstacles
            .as_mut()
            .map(|o| std::mem::take(&mut o.vehicles))
            .unwrap_or_default();
        self.obstacles = obstacles;
        if !vehicles.is_empty() {
            self.obstacles.get_or_insert_default().vehicles = vehicles;
        }
    }

    /// The outlines of the other vehicles sharing this world, where they
    /// are now: the scanners see them and [`Self::clearance_m`] counts them.
    /// Their buffer is reused, so moving them every step allocates nothing.
    /// They are kept nearest first: a scanner then meets the near ones
    /// first and passes over what they hide.
    pub fn set_other_vehicles(&mut self, outlines: impl Iterator<Item = Rectangle>) {
        let own = [self.truth.north_m, self.truth.east_m];
        let vehicles = &mut self.obstacles.get_or_insert_default().vehicles;
        vehicles.clear();
        vehicles.extend(outlines.map(|r| r.to_shape()));
        let squared_distance_m2 = |shape: &Shape| match shape {
            Shape::Box { center, .. } => (center[0] - own[0]).powi(2) + (center[1] - own[1]).powi(2),
            _ => f64::INFINITY,
        };
        vehicles.sort_unstable_by(|a, b| squared_distance_m2(a).total_cmp(&squared_distance_m2(b)));
    }

    /// Puts the vehicle at (`north_m`, `east_m`) about home, heading
    /// `yaw_rad`, at rest: a fleet's vehicles share one home (one frame for
    /// obstacles and each other) and start at places of their own.
    pub fn place(&mut self, north_m: f64, east_m: f64, yaw_rad: f64) {
        self.truth = VehicleTruth {
            north_m,
            east_m,
            yaw_rad: wrap_pi(yaw_rad),
            ..VehicleTruth::default()
        };
    }

    /// The vehicle's outline at its true pose now.
    pub fn outline_now(&self, outline: &VehicleOutline) -> Rectangle {
        outline.rectangle(self.truth.north_m, self.truth.east_m, self.truth.yaw_rad)
    }

    pub fn obstacles(&self) -> Option<&ObstacleWorld> {
        self.obstacles.as_ref()
    }

    /// Fit these scanners (replacing any, and dropping their uncollected
    /// scans); scanner `i` is index `i` in [`Self::take_scans`]. Each scans
    /// from the first multiple of its period from now, with noise of its own
    /// drawn from the world's seed, so adding scanners leaves the GNSS and
    /// magnetic noise as they were. With no obstacles set they scan an empty
    /// world (all NaN).
    pub fn set_scanners(&mut self, scanners: Vec<SimScannerConfig>) {
        self.scans.clear();
        self.scanners = scanners
            .into_iter()
            .enumerate()
            .map(|(i, config)| SimScanner::new(config, scanner_seed(self.seed, i), self.time))
            .collect();
    }

    /// How far from the vehicle's reference point its scanners can see
    /// anything (0 with none fitted).
    pub fn scan_reach_m(&self) -> f64 {
        self.scanner_configs()
            .filter(|c| c.enabled)
            .map(|c| c.mount_x_m.hypot(c.mount_y_m) + c.max_range_m)
            .filter(|reach_m| reach_m.is_finite())
            .fold(0.0, f64::max)
    }

    pub fn scanner_configs(&self) -> impl Iterator<Item = &SimScannerConfig> {
        self.scanners.iter().map(SimScanner::config)
    }

    /// Append the scans taken since the last call (scanner index, scan),
    /// in time order, then forget them.
    pub fn take_scans(&mut self, out: &mut Vec<(usize, Scan)>) {
        out.extend(self.scans.drain(..));
    }

    /// Hand back scans taken with [`Self::take_scans`] once read (`scans`
    /// is left empty): the next scans are rendered into their buffers, so a
    /// caller that returns them keeps scanning without allocating.
    pub fn recycle_scans(&mut self, scans: &mut Vec<(usize, Scan)>) {
        let room = MAX_PENDING_SCANS.saturating_sub(self.spare_scans.len());
        self.spare_scans
            .extend(scans.drain(..).map(|(_, scan)| scan).take(room));
    }

    /// The gap between the vehicle's outline at its true pose and the
    /// nearest obstacle now: ≤ 0 is a collision. `None` without obstacles.
    pub fn clearance_m(&self, outline: &VehicleOutline) -> Option<f64> {
        let obstacles = self.obstacles.as_ref()?;
        let rect = outline.rectangle(self.truth.north_m, self.truth.east_m, self.truth.yaw_rad);
        Some(obstacles.clearance_m(&rect, self.time.as_secs_f64()))
    }

    /// Takes effect at the next reading.
    pub fn set_magnetic_config(&mut self, magnetic: MagneticSensorConfig) {
        self.config.magnetic = magnetic;
    }

    /// The magnetic sensors' probe masks (front, rear) for the true pose now,
    /// bit i−1 = probe i, probe 1 rightmost (see [`MagneticSensorConfig`]);
    /// 0 = that sensor is off the tape. `None` when no tape is laid. Reading
    /// changes nothing: the same instant reads the same.
    pub fn magnetic_sensors(&self) -> Option<(u16, u16)> {
        let tape = self.tape.as_ref()?;
        Some(
            self.config
                .magnetic
                .read_both(tape, &self.truth, self.seed, self.time.as_nanos()),
        )
    }
}

fn empty_scan() -> Scan {
    Scan {
        t: Duration::ZERO,
        scan_counter: 0,
        start_angle_rad: 0.0,
        step_rad: 0.0,
        ranges_m: Vec::new(),
    }
}
