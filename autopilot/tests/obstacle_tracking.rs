//! Scan → points → clusters → tracks, on synthetic scans: round people
//! (radius 0.25 m) and walls ray-cast by a 270°, 0.5° scanner at 50 Hz with
//! 10 mm of range noise.

use std::f64::consts::PI;
use std::time::Duration;

use autopilot::geo::Ned;
use autopilot::obstacles::cluster::{BeamAngles, Cluster, ClusterConfig, ScanPoint, cluster_points, scan_points};
use autopilot::obstacles::outline::FitScratch;
use autopilot::obstacles::tracking::{ObstacleTracker, TrackingConfig, TrackingStatus};
use autopilot::obstacles::{Pose, ScannerMount, Track, TrackStatus};
use drivers::scanner::Scan;
use test_support::noise::Noise;

const STEP_RAD: f64 = 0.5 * PI / 180.0;
const SCAN_PERIOD_MS: u64 = 20;
const RANGE_NOISE_M: f64 = 0.010;
const MAX_RANGE_M: f64 = 20.0;

/// A round object moving at constant velocity.
#[derive(Clone, Copy, Debug)]
struct Person {
    start: Ned,
    vel_north_mps: f64,
    vel_east_mps: f64,
    radius_m: f64,
    /// Seen only between these times (s).
    from_s: f64,
    until_s: f64,
}

impl Person {
    fn walking(start: Ned, vel_north_mps: f64, vel_east_mps: f64) -> Self {
        Person {
            start,
            vel_north_mps,
            vel_east_mps,
            radius_m: 0.25,
            from_s: 0.0,
            until_s: f64::INFINITY,
        }
    }
    fn at(&self, t_s: f64) -> Ned {
        Ned::new(
            self.start.north_m + self.vel_north_mps * t_s,
            self.start.east_m + self.vel_east_mps * t_s,
        )
    }
}

/// Ray-casts one scan by the scanner `mount` on a vehicle at `pose`: the
/// geometry is done here independently of `scan_points` (scanner position
/// and beam directions from the pose by complex multiplication).
fn ray_cast(
    t_s: f64,
    pose: &Pose,
    mount: &ScannerMount,
    people: &[Person],
    walls: &[(Ned, Ned)],
    rng: &mut Noise,
) -> Scan {
    // Local (north, east) as a complex number n + i·e: a clockwise yaw ψ
    // from north multiplies by e^{iψ}.
    let rot = |v: (f64, f64), a: f64| (v.0 * a.cos() - v.1 * a.sin(), v.0 * a.sin() + v.1 * a.cos());
    let off = rot((mount.x_m, mount.y_m), pose.yaw_rad);
    let sensor = (pose.position.north_m + off.0, pose.position.east_m + off.1);
    let start = -0.75 * PI;
    let beams = (1.5 * PI / STEP_RAD).round() as usize + 1;
    let ranges_m = (0..beams)
        .map(|i| {
            let d = rot((1.0, 0.0), pose.yaw_rad + mount.yaw_rad + start + i as f64 * STEP_RAD);
            let mut best = f64::INFINITY;
            for p in people.iter().filter(|p| t_s >= p.from_s && t_s < p.until_s) {
                let c = p.at(t_s);
                let (cn, ce) = (c.north_m - sensor.0, c.east_m - sensor.1);
                let b = d.0 * cn + d.1 * ce;
                let disc = b * b - (cn * cn + ce * ce - p.radius_m * p.radius_m);
                if disc >= 0.0 && b - disc.sqrt() > 0.0 {
                    best = best.min(b - disc.sqrt());
                }
            }
            for (p, q) in walls {
                let (pn, pe) = (p.north_m - sensor.0, p.east_m - sensor.1);
                let (un, ue) = (q.north_m - p.north_m, q.east_m - p.east_m);
                let den = d.0 * ue - d.1 * un;
                if den.abs() > 1e-12 {
                    let t = (pn * ue - pe * un) / den;
                    let s = (pn * d.1 - pe * d.0) / den;
                    if t > 0.0 && (0.0..=1.0).contains(&s) {
                        best = best.min(t);
                    }
                }
            }
            if best <= MAX_RANGE_M {
                (best + RANGE_NOISE_M * rng.normal()) as f32
            } else {
                f32::NAN
            }
        })
        .collect();
    Scan {
        t: Duration::from_secs_f64(t_s),
        scan_counter: 0,
        start_angle_rad: start,
        step_rad: STEP_RAD,
        ranges_m,
    }
}

/// The whole pipeline for one scan.
#[derive(Default)]
struct Pipeline {
    tracker: ObstacleTracker,
    points: Vec<ScanPoint>,
    clusters: Vec<Cluster>,
    fit: FitScratch,
}

impl Pipeline {
    fn scan(&mut self, scan: &Scan, pose: &Pose, mount: &ScannerMount) -> TrackingStatus {
        let sensor = scan_points(
            scan,
            pose,
            mount,
            MAX_RANGE_M,
            &mut BeamAngles::default(),
            &mut self.points,
        );
        cluster_points(
            &self.points,
            &ClusterConfig::default(),
            &mut self.fit,
            &mut self.clusters,
        );
        self.tracker
            .update(scan.t, sensor, &self.clusters, &TrackingConfig::default())
    }
}

fn nearest_track(tracks: &[Track], p: Ned) -> Option<&Track> {
    tracks
        .iter()
        .filter(|t| t.status != TrackStatus::Tentative)
        .min_by(|a, b| a.position.distance_to(&p).total_cmp(&b.position.distance_to(&p)))
}

fn time_s(k: u64) -> f64 {
    (k * SCAN_PERIOD_MS) as f64 / 1000.0
}

/// A person walking 1.5 m/s across the scanner's view, 1 s after the track
/// is born: the velocity error over many runs (different noise and
/// positions relative to the beams).
#[test]
fn a_walking_persons_velocity_converges_within_a_second() {
    let pose = Pose::default();
    let mount = ScannerMount::default();
    let runs = 40;
    let (mut sq_err, mut worst, mut sq_pos) = (0.0f64, 0.0f64, 0.0f64);
    for run in 0..runs {
        let mut rng = Noise::new(1000 + run);
        let depth = 3.0 + 0.1 * run as f64;
        let person = Person::walking(Ned::new(depth, -2.0 + 0.013 * run as f64), 0.0, 1.5);
        let mut pipeline = Pipeline::default();
        let mut born: Option<(u64, u32)> = None;
        for k in 0..200u64 {
            let t = time_s(k);
            let s = pipeline.scan(&ray_cast(t, &pose, &mount, &[person], &[], &mut rng), &pose, &mount);
            if born.is_none() && s.births == 1 {
                born = Some((k, pipeline.tracker.tracks()[0].id));
            }
            let Some((k0, id)) = born else { continue };
            if k == k0 + 50 {
                let tracks = pipeline.tracker.tracks();
                assert_eq!(tracks.len(), 1, "{tracks:?}");
                let track = tracks[0];
                assert_eq!(track.id, id);
                assert_eq!(track.status, TrackStatus::Confirmed);
                let err = (track.vel_north_mps - 0.0).hypot(track.vel_east_mps - 1.5);
                sq_err += err * err;
                worst = worst.max(err);
                sq_pos += track.position.distance_to(&person.at(t)).powi(2);
                break;
            }
        }
        assert!(born.is_some(), "run {run}: never tracked");
    }
    let rms = (sq_err / runs as f64).sqrt();
    let pos_rms = (sq_pos / runs as f64).sqrt();
    println!(
        "walking 1.5 m/s at 3–7 m, 1 s after birth: velocity error RMS {rms:.3} m/s, worst {worst:.3} m/s; \
         position error RMS {pos_rms:.3} m"
    );
    assert!(rms < 0.15, "{rms}");
    assert!(worst < 0.3, "{worst}");
    assert!(pos_rms < 0.05, "{pos_rms}");
}

/// The identities of two people, and every scan's tracks: `a` and `b` are
/// followed for 5 s, must be confirmed as two tracks by 0.8 s, and outside
/// the `close` interval (s) each must still be nearest to its first track.
fn follow_two(seed: u64, a: Person, b: Person, close: (f64, f64)) -> Vec<Vec<Track>> {
    let pose = Pose::default();
    let mount = ScannerMount::default();
    let mut rng = Noise::new(seed);
    let mut pipeline = Pipeline::default();
    let mut ids: Option<(u32, u32)> = None;
    let mut history = Vec::new();
    for k in 0..250u64 {
        let t = time_s(k);
        pipeline.scan(&ray_cast(t, &pose, &mount, &[a, b], &[], &mut rng), &pose, &mount);
        let tracks = pipeline.tracker.tracks();
        history.push(tracks.to_vec());
        let id_of = |p: Ned| {
            nearest_track(tracks, p)
                .filter(|t| t.position.distance_to(&p) < 0.3)
                .map(|t| t.id)
        };
        if k == 40 {
            let (ia, ib) = (id_of(a.at(t)), id_of(b.at(t)));
            assert!(ia.is_some() && ib.is_some() && ia != ib, "{tracks:?}");
            ids = ia.zip(ib);
        }
        if k > 40 && (t < close.0 || t > close.1) {
            let (ia, ib) = (id_of(a.at(t)), id_of(b.at(t)));
            assert_eq!(ia.zip(ib), ids, "seed {seed}, t = {t:.2}: {tracks:?}");
        }
    }
    let confirmed = history
        .last()
        .map_or(0, |t| t.iter().filter(|t| t.status == TrackStatus::Confirmed).count());
    assert_eq!(confirmed, 2);
    history
}

/// Two people walk an X at 1.5 m/s: their paths cross at right angles 5 m
/// ahead, B `lag_s` after A. Their centres come within 1.06·|lag| m, so at
/// ±0.5 s they pass 3 cm apart (closer and the ray-cast bodies would
/// overlap), and on the way one hides part, then all, of the other.
fn crossing(seed: u64, lag_s: f64) -> Vec<Vec<Track>> {
    let (dn, de) = (1.5 * (PI / 4.0).cos(), 1.5 * (PI / 4.0).sin());
    // A goes north-east and passes (5, 0) at 2 s; B north-west, at 2 s + lag.
    let a = Person::walking(Ned::new(5.0 - 2.0 * dn, -2.0 * de), dn, de);
    let tb = 2.0 + lag_s;
    let b = Person::walking(Ned::new(5.0 - tb * dn, tb * de), dn, -de);
    let first = 2.0f64.min(tb);
    follow_two(seed, a, b, (first - 0.4, first + lag_s.abs() + 0.6))
}

#[test]
fn people_crossing_at_an_x_keep_their_ids() {
    for seed in 0..5 {
        crossing(seed, 0.5);
        crossing(seed, -0.5);
    }
}

/// Two people meet head-on on parallel lines 0.6 m apart (0.1 m between
/// them, less than the cluster gap): for a moment the scanner sees one
/// object between them.
#[test]
fn people_passing_side_by_side_keep_their_ids() {
    for seed in 0..5 {
        let a = Person::walking(Ned::new(3.0, -0.3), 1.5, 0.0);
        let b = Person::walking(Ned::new(9.0, 0.3), -1.5, 0.0);
        follow_two(seed, a, b, (1.6, 2.6));
    }
}

#[test]
fn the_same_scans_give_the_same_tracks() {
    let first = crossing(77, 0.5);
    let second = crossing(77, 0.5);
    assert_eq!(first, second);
    // And the noise matters, so the comparison is not vacuous.
    assert_ne!(first, crossing(78, 0.5));
}

/// Driving past a standing person with the scanner off-centre and turned:
/// the person's track stays where the person is, not moving — only right if
/// eq. 1–2 are right for the mount and the vehicle's yaw.
#[test]
fn a_standing_person_seen_from_a_moving_turning_vehicle_stands_still() {
    let mount = ScannerMount {
        x_m: 1.1,
        y_m: -0.35,
        yaw_rad: -0.6,
    };
    let person = Person::walking(Ned::new(6.0, 1.0), 0.0, 0.0);
    let mut rng = Noise::new(5);
    let mut pipeline = Pipeline::default();
    for k in 0..150u64 {
        let t = time_s(k);
        // Drives north-east at 1 m/s while turning at 0.2 rad/s.
        let pose = Pose {
            position: Ned::new(0.7 * t, 0.7 * t),
            yaw_rad: 0.3 + 0.2 * t,
        };
        pipeline.scan(&ray_cast(t, &pose, &mount, &[person], &[], &mut rng), &pose, &mount);
    }
    let tracks = pipeline.tracker.tracks();
    assert_eq!(tracks.len(), 1, "{tracks:?}");
    let track = tracks[0];
    assert_eq!(track.status, TrackStatus::Confirmed);
    assert!(track.position.distance_to(&person.start) < 0.05, "{track:?}");
    assert!(track.speed_mps() < 0.1, "{track:?}");
}

/// A front and a rear scanner both see a person beside the vehicle at the
/// same instants: one track, confirmed as fast as with one scanner.
#[test]
fn two_scanners_seeing_one_person_make_one_track() {
    let pose = Pose {
        position: Ned::new(0.0, 0.0),
        yaw_rad: 0.0,
    };
    let front = ScannerMount {
        x_m: 1.5,
        y_m: 0.4,
        yaw_rad: PI / 4.0,
    };
    let rear = ScannerMount {
        x_m: -0.3,
        y_m: 0.4,
        yaw_rad: 3.0 * PI / 4.0,
    };
    let person = Person::walking(Ned::new(0.0, 3.0), 1.0, 0.0);
    let mut rng = Noise::new(9);
    let mut pipeline = Pipeline::default();
    let mut births = 0;
    for k in 0..100u64 {
        let t = time_s(k);
        for mount in [&front, &rear] {
            births += pipeline
                .scan(&ray_cast(t, &pose, mount, &[person], &[], &mut rng), &pose, mount)
                .births;
        }
        if k == 2 {
            assert_eq!(pipeline.tracker.tracks()[0].status, TrackStatus::Confirmed);
        }
    }
    assert_eq!(births, 1);
    let tracks = pipeline.tracker.tracks();
    assert_eq!(tracks.len(), 1, "{tracks:?}");
    assert!((tracks[0].vel_north_mps - 1.0).abs() < 0.15, "{tracks:?}");
}

/// A person steps out from behind nothing, stands, and vanishes: confirmed
/// after the configured number of scans, deleted after the timeout; a wall
/// in the view is never a track.
#[test]
fn a_track_is_confirmed_after_n_scans_and_deleted_after_the_timeout() {
    let config = TrackingConfig::default();
    let pose = Pose::default();
    let mount = ScannerMount::default();
    let mut person = Person::walking(Ned::new(4.0, -1.0), 0.0, 0.5);
    person.from_s = 0.5;
    person.until_s = 1.5;
    let wall = (Ned::new(8.0, -5.0), Ned::new(8.0, 5.0));
    let mut rng = Noise::new(3);
    let mut pipeline = Pipeline::default();
    let (mut confirmed_at, mut deleted_at) = (None, None);
    for k in 0..200u64 {
        let t = time_s(k);
        let s = pipeline.scan(&ray_cast(t, &pose, &mount, &[person], &[wall], &mut rng), &pose, &mount);
        if t < person.from_s {
            assert!(pipeline.tracker.tracks().is_empty(), "the wall is tracked");
        }
        if confirmed_at.is_none() && s.confirmed == 1 {
            confirmed_at = Some(k);
        }
        if s.deaths > 0 {
            deleted_at = Some(k);
        }
    }
    let first_seen = 25; // 0.5 s at 50 Hz
    assert_eq!(confirmed_at, Some(first_seen + u64::from(config.confirm_hits) - 1));
    let last_seen = 74; // the last scan before 1.5 s
    let deleted_after_s = deleted_at.map(|k| time_s(k) - time_s(last_seen));
    assert!(
        deleted_after_s.is_some_and(|d| d > config.delete_s - 1e-9 && d <= config.delete_s + 0.021),
        "{deleted_after_s:?}"
    );
    assert!(pipeline.tracker.tracks().is_empty());
}
