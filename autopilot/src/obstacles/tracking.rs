//! Clusters → tracks (seed 004 §III.B): one constant-velocity Kalman filter
//! ([`CvKalman`]) per object, clusters associated to tracks by Mahalanobis
//! gating and a global (greedy by ascending cost) assignment, births from
//! clusters no track claims, confirmation after a few hits, coasting and
//! deletion by time.
//!
//! Several scanners may call [`ObstacleTracker::update`] in turn, each with
//! its own clusters and position. A track that one scanner already updated
//! at `t` is simply updated again by another scanner's cluster at the same
//! `t` (the second prediction is over zero time), and a cluster that falls
//! in any track's gate never gives birth, so an object seen by two scanners
//! is one track.
//!
//! Time is whatever clock the scans carry. A scan older than the newest one
//! seen (two scanners' scans arriving slightly out of order) is applied at
//! the newest time — the filter never goes back, and the error is the
//! object's speed times the lateness. A clock that jumps back by more than
//! [`CLOCK_JUMP`] starts the tracker afresh.
//!
//! Sources: docs/references.md §Seed 004.

use std::time::Duration;

use nalgebra::Matrix2;

use super::cluster::Cluster;
use super::kalman::state::{EAST, NORTH};
use super::kalman::{CvKalman, chi2_gate_2dof, polar_measurement_covariance};
#[cfg(test)]
use super::outline::FitScratch;
use super::outline::Outline;
use super::{Track, TrackStatus};
use crate::geo::Ned;

/// A scan this much older than the newest one means the clock was reset.
pub const CLOCK_JUMP: Duration = Duration::from_secs(1);

/// A cluster this many times the radius of the track it would update, that
/// also lies in another track's gate or covers its centre, is two objects
/// seen as one (people passing close): neither track is updated with it,
/// they coast on their velocity until the objects separate. Updating one of
/// them with the merged centroid would drag it towards the other and can
/// swap identities. The gate alone misses it when the other object stands:
/// its track is so sure of its place that the merged centroid, half a
/// person away, falls outside its gate.
const MERGED_RADIUS_RATIO: f64 = 1.5;

/// A full view whose nearest return lies within this (m) of an anchored
/// outline shows the same object where it stood: its
/// centroid moved only because the view did.
const STILL_TOLERANCE_M: f64 = 0.1;

/// A view on an anchor with this many times its returns replaces it.
const SHARPER_VIEW: usize = 2;

/// A full view's centroid within this (m) beyond the object's largest
/// extent seen of where it came to rest shows it still there: the range
/// noise of the returns the centroid is the mean of.
const REST_TOLERANCE_M: f64 = 0.1;
/// …and only for an object wider than this (m) at its widest: anything a
/// person's size could be a person, whose view-made centroid wander is
/// within the outline test's tolerance anyway, while the disc would take
/// someone creeping towards the vehicle for a thing at rest.
const REST_MIN_EXTENT_M: f64 = 0.7;

/// Returns on one outline this long (s): the object stands (the nearest
/// point of someone walking at 0.3 m/s leaves their 0.5 m outline within
/// about a second).
pub const STILL_S: f64 = 1.5;

/// No track is born this close (m) beyond the edges of an existing one.
const BIRTH_EXCLUSION_M: f64 = 0.2;

/// Tracking parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrackingConfig {
    /// Power spectral density `q` of the white acceleration (eq. 6's `a`),
    /// m²/s³ per axis; a walking person: about 1–2.
    pub accel_density: f64,
    /// Range and bearing σ of the scanner (the corrected eq. 7).
    pub range_sigma_m: f64,
    pub bearing_sigma_rad: f64,
    /// Extra σ per axis for the cluster centroid's jitter (how much of the
    /// object is visible changes from scan to scan), added to `R`.
    pub centroid_sigma_m: f64,
    /// The gate keeps the true cluster with this probability (χ², 2 dof).
    pub gate_probability: f64,
    /// A tentative track is confirmed after this many scan instants with a
    /// cluster.
    pub confirm_hits: u32,
    /// Unseen this long (s): a confirmed track coasts, a tentative one is
    /// deleted.
    pub coast_s: f64,
    /// Unseen this long (s): deleted.
    pub delete_s: f64,
    /// A track whose position σ grows above this (m) is deleted.
    pub max_position_sigma_m: f64,
    /// Prior σ of a new track's velocity, per axis.
    pub initial_velocity_sigma_mps: f64,
}

impl Default for TrackingConfig {
    fn default() -> Self {
        TrackingConfig {
            accel_density: 1.5,
            // LMS1xx class: ~12 mm systematic + statistical range error.
            range_sigma_m: 0.02,
            // Half a 0.5° beam step.
            bearing_sigma_rad: 0.0044,
            centroid_sigma_m: 0.03,
            gate_probability: 0.99,
            confirm_hits: 3,
            coast_s: 0.3,
            // Beyond ~1 s a coasting person's σ (q·T³/3 alone is 0.5 m² at
            // q = 1.5) reaches the σ limit anyway.
            delete_s: 1.0,
            // Leigh et al. delete a person track at σ > 0.9 m.
            max_position_sigma_m: 0.9,
            initial_velocity_sigma_mps: 2.0,
        }
    }
}

/// What one call to [`ObstacleTracker::update`] left behind.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TrackingStatus {
    /// Confirmed or coasting tracks (the ones to act on).
    pub confirmed: usize,
    pub tentative: usize,
    /// Tracks born and deleted in this call.
    pub births: u32,
    pub deaths: u32,
}

/// A track and what only the tracker needs to know about it.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Entry {
    track: Track,
    kf: CvKalman,
    /// The time the filter's state is at.
    filter_t: Duration,
    born_t: Duration,
    seen_t: Duration,
    /// The last full view's outline and the centroid it was fitted about:
    /// it stays where the returns were while the filtered position moves
    /// with them.
    fit: Option<(Outline, Ned)>,
    /// The outlines the returns have stayed on, and since when.
    stillness: Stillness,
    /// The last full view (not occluded, cut by the field's edge or in
    /// pieces) and the filtered position after it. How long the object had
    /// stood still is known as of then only: a sliver stays where the edge
    /// of the field is however the object moves behind it, and an object
    /// out of sight may walk off. After it the outline moves with the
    /// filtered position, as the only estimate of where the object went.
    full_view_t: Duration,
    full_view_position: Ned,
    /// Where its centroid came to rest, and since when.
    rest: Rest,
}

/// Every tracked object, and the next id to give.
#[derive(Clone, Debug, PartialEq)]
pub struct ObstacleTracker {
    entries: Vec<Entry>,
    /// The tracks of `entries`, in the same order, for [`Self::tracks`].
    tracks: Vec<Track>,
    next_id: u32,
    newest_t: Option<Duration>,
    scratch: UpdateScratch,
}

/// Tracks room is made for up front, here and in the core's per-track
/// buffers: a yard that fills up does not reallocate while driving (more
/// still fit, by growing).
pub const EXPECTED_TRACKS: usize = 32;

impl Default for ObstacleTracker {
    fn default() -> Self {
        ObstacleTracker {
            entries: Vec::with_capacity(EXPECTED_TRACKS),
            tracks: Vec::with_capacity(EXPECTED_TRACKS),
            next_id: 1,
            newest_t: None,
            scratch: UpdateScratch::default(),
        }
    }
}

/// The working buffers of [`ObstacleTracker::update`], kept between
/// updates so a scan allocates nothing once they have grown. Not part of
/// the tracker's state: any two compare equal.
#[derive(Clone, Debug, Default)]
struct UpdateScratch {
    measurements: Vec<Measurement>,
    /// (Mahalanobis distance², track, measurement) inside the gate.
    pairs: Vec<(f64, usize, usize)>,
    assigned: Vec<Option<usize>>,
    taken: Vec<bool>,
    gated: Vec<bool>,
    merged: Vec<bool>,
    pieces: Vec<bool>,
    /// Per-track flags: a refused filter step, or a track to delete.
    flags: Vec<bool>,
    /// (north, measurement) sorted by north.
    by_north: Vec<(f64, usize)>,
    /// The measurements no track took.
    untaken: Vec<usize>,
}

impl PartialEq for UpdateScratch {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

/// Empties `v` and fills it with `n` copies of `value`, keeping its buffer.
fn refill<T: Clone>(v: &mut Vec<T>, n: usize, value: T) {
    v.clear();
    v.resize(n, value);
}

/// The clusters that can update a track (not structure, a finite centroid),
/// each with its measurement covariance seen from `sensor`.
fn gather_measurements(
    measurements: &mut Vec<Measurement>,
    clusters: &[Cluster],
    sensor: Ned,
    config: &TrackingConfig,
) {
    measurements.clear();
    measurements.extend(
        clusters
            .iter()
            .enumerate()
            .filter(|(_, c)| !c.is_structure && c.centroid.north_m.is_finite() && c.centroid.east_m.is_finite())
            .map(|(cluster, c)| Measurement {
                cluster,
                r: measurement_covariance(sensor, c.centroid, config),
            }),
    );
}

/// The measurements' (centroid north, index), sorted by north, into `out`.
fn sort_by_north(out: &mut Vec<(f64, usize)>, measurements: &[Measurement], clusters: &[Cluster]) {
    out.clear();
    out.extend(
        measurements
            .iter()
            .enumerate()
            .map(|(m, meas)| (clusters[meas.cluster].centroid.north_m, m)),
    );
    out.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
}

/// The measurements (of `by_north`) north or south of `entry`'s track by
/// no more than its widest gate allows: any further one is surely outside
/// it ([`CvKalman::surely_outside_gate`], with the largest trace of a
/// measurement's `R`, `widest_r`, plus what a partial view adds, and a
/// thousandth more against rounding). All of them when that bound is not
/// finite. Each track then looks at the few measurements near it, not at
/// every one.
fn within_north<'a>(by_north: &'a [(f64, usize)], entry: &Entry, widest_r: f64, gate: f64) -> &'a [(f64, usize)] {
    let p = entry.kf.covariance();
    let radius_sq = entry.track.radius_m * entry.track.radius_m;
    let trace = p[(NORTH, NORTH)] + p[(EAST, EAST)] + widest_r + 2.0 * radius_sq;
    let half_width_m = (2.0 * gate * trace).sqrt() * 1.001;
    let north_m = entry.kf.position().north_m;
    if !(half_width_m.is_finite() && north_m.is_finite()) {
        return by_north;
    }
    let from = by_north.partition_point(|&(n, _)| n < north_m - half_width_m);
    let to = by_north.partition_point(|&(n, _)| n <= north_m + half_width_m);
    &by_north[from..to.max(from)]
}

/// A partial view's centroid — a partly hidden cluster, or one piece of an
/// object the scan shows in several — can be off by up to the object's
/// radius: it may keep a track alive and roughly in place, but must not
/// steer its velocity.
fn measurement_r(entry: &Entry, meas: &Measurement, partial: bool, clusters: &[Cluster]) -> Matrix2<f64> {
    if partial || clusters[meas.cluster].occluded {
        meas.r + Matrix2::identity() * entry.track.radius_m * entry.track.radius_m
    } else {
        meas.r
    }
}

/// A cluster that can update a track: its index and measurement covariance.
#[derive(Clone, Debug)]
struct Measurement {
    cluster: usize,
    r: Matrix2<f64>,
}

impl ObstacleTracker {
    pub fn new() -> Self {
        Self::default()
    }

    /// The tracks, oldest first.
    pub fn tracks(&self) -> &[Track] {
        &self.tracks
    }

    /// Forgets every track (ids keep counting up, so an old id never names a
    /// new object).
    pub fn clear(&mut self) {
        self.entries.clear();
        self.tracks.clear();
        self.newest_t = None;
    }

    /// One scanner's clusters taken at `t` from `sensor` (local frame).
    pub fn update(
        &mut self,
        t: Duration,
        sensor: Ned,
        clusters: &[Cluster],
        config: &TrackingConfig,
    ) -> TrackingStatus {
        let mut status = TrackingStatus::default();
        if self.newest_t.is_some_and(|newest| t + CLOCK_JUMP < newest) {
            status.deaths += count_u32(self.entries.len());
            self.clear();
        }
        let now = self.newest_t.map_or(t, |newest| newest.max(t));
        self.newest_t = Some(now);

        let mut scratch = std::mem::take(&mut self.scratch);
        status.deaths += self.predict_all(now, config, &mut scratch.flags);
        gather_measurements(&mut scratch.measurements, clusters, sensor, config);
        self.associate(&mut scratch, clusters, config);
        self.mark_merged(&mut scratch, clusters);
        self.mark_pieces(&mut scratch, clusters);
        self.update_assigned(&mut scratch, clusters, now);
        status.deaths += self.remove(&scratch.flags);
        status.births += self.birth_tracks(&scratch, clusters, config, now);

        status.deaths += self.age_all(now, config, &mut scratch.flags);
        self.scratch = scratch;
        self.tracks.clear();
        self.tracks.extend(self.entries.iter().map(|e| e.track));
        self.count_tracks(&mut status);
        status
    }

    /// Every (track, measurement) pair inside the gate, cheapest first (ties
    /// broken by index so the outcome never depends on sort details), and
    /// the greedy assignment along that order.
    fn associate(&self, scratch: &mut UpdateScratch, clusters: &[Cluster], config: &TrackingConfig) {
        let UpdateScratch {
            measurements,
            pairs,
            assigned,
            taken,
            gated,
            by_north,
            ..
        } = scratch;
        let gate = chi2_gate_2dof(config.gate_probability);
        pairs.clear();
        sort_by_north(by_north, measurements, clusters);
        let widest_r = measurements
            .iter()
            .map(|meas| meas.r[(0, 0)] + meas.r[(1, 1)])
            .fold(0.0, f64::max);
        for (i, entry) in self.entries.iter().enumerate() {
            for &(_, m) in within_north(by_north, entry, widest_r, gate) {
                let meas = &measurements[m];
                let centroid = clusters[meas.cluster].centroid;
                let r = measurement_r(entry, meas, false, clusters);
                // Most pairs are far apart: skip them before the inverse.
                if entry.kf.surely_outside_gate(centroid, &r, gate) {
                    continue;
                }
                let d2 = entry.kf.mahalanobis_sq(centroid, &r);
                if d2 <= gate {
                    pairs.push((d2, i, m));
                }
            }
        }
        // No two pairs are equal (track and measurement differ), so an
        // unstable sort gives the one order.
        pairs.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));

        refill(assigned, self.entries.len(), None);
        refill(taken, measurements.len(), false);
        refill(gated, measurements.len(), false);
        for &(_, i, m) in pairs.iter() {
            gated[m] = true;
            if assigned[i].is_none() && !taken[m] {
                assigned[i] = Some(m);
                taken[m] = true;
            }
        }
    }

    /// Merged objects: a big cluster another, unserved track also claims
    /// (in its gate, or its centre within the cluster).
    fn mark_merged(&self, scratch: &mut UpdateScratch, clusters: &[Cluster]) {
        let UpdateScratch {
            measurements,
            pairs,
            assigned,
            merged,
            ..
        } = scratch;
        refill(merged, measurements.len(), false);
        for (i, slot) in assigned.iter().enumerate() {
            let Some(m) = *slot else { continue };
            let cluster = &clusters[measurements[m].cluster];
            if cluster.radius_m <= MERGED_RADIUS_RATIO * self.entries[i].track.radius_m {
                continue;
            }
            let gated = pairs
                .iter()
                .any(|&(_, k, mm)| mm == m && k != i && assigned[k].is_none());
            let covered = || {
                self.entries
                    .iter()
                    .zip(assigned.iter())
                    .enumerate()
                    .any(|(k, (other, slot))| {
                        k != i
                            && slot.is_none()
                            && other.kf.position().distance_to(&cluster.centroid) <= cluster.radius_m
                    })
            };
            if gated || covered() {
                merged[m] = true;
            }
        }
    }

    /// An object cut in pieces (a run of beams without echo across a
    /// person: two dropouts in a row already split a cluster): the track
    /// takes the piece nearest its prediction, and another piece no track
    /// took lies where this object is. The taken piece's centroid is then
    /// that of a part — one leg's worth of returns off the centre — and an
    /// ordinary update with it turns a few centimetres of offset into a
    /// velocity error of a good fraction of a walking speed, predicting a
    /// collision the object is not on course for.
    fn mark_pieces(&self, scratch: &mut UpdateScratch, clusters: &[Cluster]) {
        let UpdateScratch {
            measurements,
            assigned,
            taken,
            pieces,
            untaken,
            ..
        } = scratch;
        // Few measurements are left over once the tracks have theirs.
        untaken.clear();
        untaken.extend((0..measurements.len()).filter(|&m| !taken[m]));
        pieces.clear();
        pieces.extend(assigned.iter().zip(&self.entries).map(|(slot, entry)| {
            slot.is_some_and(|m| {
                untaken
                    .iter()
                    .any(|&other| other != m && part_of(&entry.track, &clusters[measurements[other].cluster]))
            })
        }));
    }

    /// Updates every track with its assigned cluster (none for a merged one)
    /// and counts the misses; flags the tracks whose filter refused.
    fn update_assigned(&mut self, scratch: &mut UpdateScratch, clusters: &[Cluster], now: Duration) {
        let UpdateScratch {
            measurements,
            assigned,
            merged,
            pieces,
            flags: failed,
            ..
        } = scratch;
        refill(failed, self.entries.len(), false);
        for (i, entry) in self.entries.iter_mut().enumerate() {
            let hit = assigned[i].filter(|&m| !merged[m]);
            match hit {
                Some(m) => {
                    let cluster = &clusters[measurements[m].cluster];
                    let r = measurement_r(entry, &measurements[m], pieces[i], clusters);
                    if entry.kf.update(cluster.centroid, &r).is_err() {
                        failed[i] = true;
                        continue;
                    }
                    // Two scanners at one instant are one hit.
                    if entry.track.hits == 0 || entry.seen_t < now {
                        entry.track.hits = entry.track.hits.saturating_add(1);
                    }
                    entry.track.misses = 0;
                    // A sliver's size, shape and stillness are not the object's;
                    // its centroid still updates the filter as a full view's
                    // would (left out, the velocity of someone walking on
                    // into the blind zone would go unknown just as it counts).
                    if !(cluster.occluded || cluster.cut_by_field_edge || pieces[i]) {
                        entry.track.radius_m = cluster.radius_m;
                        entry.fit = cluster.outline.map(|o| (o, cluster.centroid));
                        entry.stillness.see(cluster, now);
                        entry.rest.see(cluster, now);
                        entry.full_view_t = now;
                        entry.full_view_position = entry.kf.position();
                    } else {
                        // A part of the object off where it stood shows it
                        // moving; on it, it proves nothing.
                        entry.stillness.see_part(cluster, now);
                        entry.rest.see_part(cluster, now);
                    }
                    entry.seen_t = now;
                }
                None if entry.seen_t < now => entry.track.misses = entry.track.misses.saturating_add(1),
                None => {}
            }
        }
    }

    /// Starts a tentative track on every cluster outside all gates that is
    /// not a piece of a known object; returns how many were born.
    fn birth_tracks(
        &mut self,
        scratch: &UpdateScratch,
        clusters: &[Cluster],
        config: &TrackingConfig,
        now: Duration,
    ) -> u32 {
        let known = self.entries.len();
        let mut births = 0;
        for (m, meas) in scratch.measurements.iter().enumerate() {
            if scratch.gated[m] {
                continue;
            }
            let cluster = &clusters[meas.cluster];
            // A piece of an object already tracked (half a person whose
            // other half an occluding leg cut off, or the person again after
            // a few missed scans) lands outside the track's tight gate, yet
            // is no new object: a second track on it would be born with no
            // velocity and predict a standing obstacle where a walking one
            // is. Clusters of the same scan are distinct objects, so only
            // tracks from before this scan exclude.
            let part_of_known = self.entries[..known].iter().any(|e| part_of(&e.track, cluster));
            if part_of_known {
                continue;
            }
            let Ok(kf) = CvKalman::new(cluster.centroid, &meas.r, config.initial_velocity_sigma_mps) else {
                continue;
            };
            let id = self.take_id();
            self.entries.push(Entry {
                track: Track {
                    id,
                    status: TrackStatus::Tentative,
                    position: cluster.centroid,
                    vel_north_mps: 0.0,
                    vel_east_mps: 0.0,
                    position_sigma_m: kf.position_sigma_m(),
                    velocity_sigma_mps: kf.velocity_sigma_mps(),
                    radius_m: cluster.radius_m,
                    outline: cluster.outline,
                    age_s: 0.0,
                    unseen_s: 0.0,
                    hits: 1,
                    misses: 0,
                    still_s: 0.0,
                },
                kf,
                filter_t: now,
                born_t: now,
                seen_t: now,
                fit: cluster.outline.map(|o| (o, cluster.centroid)),
                stillness: Stillness::new(cluster),
                rest: Rest::new(cluster, now),
                full_view_t: now,
                full_view_position: cluster.centroid,
            });
            births += 1;
        }
        births
    }

    /// Counts the tentative and confirmed tracks.
    fn count_tracks(&self, status: &mut TrackingStatus) {
        status.tentative = self
            .tracks
            .iter()
            .filter(|t| t.status == TrackStatus::Tentative)
            .count();
        status.confirmed = self.tracks.len() - status.tentative;
    }

    /// The confirmed or coasting track whose edge (centre distance minus
    /// its radius, at least 0) is nearest `sensor`: (id, metres). Only the
    /// tests ask for it: the core never needs it.
    #[cfg(test)]
    pub fn nearest_edge(&self, sensor: Ned) -> Option<(u32, f64)> {
        let mut nearest: Option<(u32, f64)> = None;
        for track in self.tracks.iter().filter(|t| t.status != TrackStatus::Tentative) {
            let edge_m = (sensor.distance_to(&track.position) - track.radius_m).max(0.0);
            if nearest.is_none_or(|(_, d)| edge_m < d) {
                nearest = Some((track.id, edge_m));
            }
        }
        nearest
    }

    /// Every filter to `now`; a refused step deletes the track. Returns the
    /// number deleted.
    fn predict_all(&mut self, now: Duration, config: &TrackingConfig, failed: &mut Vec<bool>) -> u32 {
        refill(failed, self.entries.len(), false);
        for (entry, failed) in self.entries.iter_mut().zip(failed.iter_mut()) {
            let dt_s = now.saturating_sub(entry.filter_t).as_secs_f64();
            if entry.kf.predict(dt_s, config.accel_density).is_err() {
                *failed = true;
            } else {
                entry.filter_t = now;
            }
        }
        self.remove(failed)
    }

    /// Ages, statuses and the public view of every track; deletes the ones
    /// unseen too long or too uncertain. Returns the number deleted.
    fn age_all(&mut self, now: Duration, config: &TrackingConfig, dead: &mut Vec<bool>) -> u32 {
        refill(dead, self.entries.len(), false);
        for (entry, dead) in self.entries.iter_mut().zip(dead.iter_mut()) {
            let unseen_s = now.saturating_sub(entry.seen_t).as_secs_f64();
            let track = &mut entry.track;
            track.age_s = now.saturating_sub(entry.born_t).as_secs_f64();
            track.unseen_s = unseen_s;
            track.position = entry.kf.position();
            let full_view_t = entry.full_view_t;
            track.still_s = entry
                .stillness
                .still_s(full_view_t)
                .max(entry.rest.still_s(full_view_t));
            // A standing object's outline stays where its returns were
            // (its filtered position walks as the view of it changes);
            // anything else's moves on with the filter after its last full
            // view, as the only estimate of where it went.
            let moved = if track.still_s >= STILL_S {
                (0.0, 0.0)
            } else {
                (
                    track.position.north_m - entry.full_view_position.north_m,
                    track.position.east_m - entry.full_view_position.east_m,
                )
            };
            track.outline = entry.fit.map(|(outline, centre)| {
                outline.shifted(
                    centre.north_m + moved.0 - track.position.north_m,
                    centre.east_m + moved.1 - track.position.east_m,
                )
            });
            (track.vel_north_mps, track.vel_east_mps) = entry.kf.velocity_mps();
            track.position_sigma_m = entry.kf.position_sigma_m();
            track.velocity_sigma_mps = entry.kf.velocity_sigma_mps();
            // A NaN σ or limit deletes.
            let too_uncertain = !at_most(track.position_sigma_m, config.max_position_sigma_m);
            *dead = too_uncertain
                || match track.status {
                    // A tentative track never coasts: unconfirmed, it may be noise.
                    TrackStatus::Tentative => !at_most(unseen_s, config.coast_s),
                    TrackStatus::Confirmed | TrackStatus::Coasting => !at_most(unseen_s, config.delete_s),
                };
            if *dead {
                continue;
            }
            track.status = match track.status {
                TrackStatus::Tentative if track.hits >= config.confirm_hits => TrackStatus::Confirmed,
                TrackStatus::Tentative => TrackStatus::Tentative,
                _ if unseen_s > config.coast_s => {
                    // A streak of hits ends when the track coasts.
                    track.hits = 0;
                    TrackStatus::Coasting
                }
                _ => TrackStatus::Confirmed,
            };
        }
        self.remove(dead)
    }

    /// Drops the entries marked in `dead` (same order); returns how many.
    fn remove(&mut self, dead: &[bool]) -> u32 {
        let before = self.entries.len();
        let mut flags = dead.iter();
        self.entries.retain(|_| !flags.next().copied().unwrap_or(false));
        count_u32(before - self.entries.len())
    }

    fn take_id(&mut self) -> u32 {
        let id = self.next_id;
        // 0 is never an id: MAVLink and the GCS read it as "none".
        self.next_id = self.next_id.checked_add(1).unwrap_or(1);
        id
    }
}

/// The last two outlines (local frame: outline and the centre it is about)
/// a track's returns left their anchors for, and when they last did
/// (`None`: never since birth). Two, because two scanners see different
/// sides of one object: each one's returns stay on its own view's outline.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Stillness {
    anchors: [Option<Anchor>; 2],
    since: Option<Duration>,
}

/// An outline the returns are checked against, the centre it is about,
/// how many returns it was fitted to and how far apart they were.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Anchor {
    outline: Outline,
    centre: Ned,
    points: usize,
    beam_spacing_m: f64,
}

impl Anchor {
    fn of(cluster: &Cluster) -> Option<Anchor> {
        cluster.outline.map(|outline| Anchor {
            outline,
            centre: cluster.centroid,
            points: cluster.points,
            // The cluster's radius is half its extent plus one spacing.
            beam_spacing_m: (2.0 * cluster.radius_m - cluster.extent_m).max(0.0),
        })
    }

    /// Whether `p` lies on the outline, to [`STILL_TOLERANCE_M`] plus the
    /// spacing of the returns it was fitted to: between two beams a face
    /// (and its end) can reach that much beyond the outline, and the
    /// nearest return of a later view falls anywhere on it.
    fn holds(&self, p: Ned) -> bool {
        let offset = (p.north_m - self.centre.north_m, p.east_m - self.centre.east_m);
        self.outline.distance_outside_m(offset) <= STILL_TOLERANCE_M + self.beam_spacing_m
    }
}

impl Stillness {
    fn new(cluster: &Cluster) -> Self {
        Stillness {
            anchors: [Anchor::of(cluster), None],
            since: None,
        }
    }

    /// A full view: the anchors stay while the cluster's nearest return
    /// lies on one of them, else its outline becomes the first. Only the
    /// nearest: the ends of a face move along it as the view reveals more
    /// of it, while the nearest point of something walking leaves with it.
    ///
    /// An anchor fitted from afar is coarse: a face seen at a grazing angle
    /// or between beams a hand apart is missing from it, and its hidden side
    /// is guessed along the beam. Approached, the same standing object shows
    /// those faces up to a beam spacing and more off that anchor, which would
    /// read as a step. So a view on an anchor with [`SHARPER_VIEW`] times its
    /// returns replaces it (the object is still where it was, seen better):
    /// the test tightens as the range shrinks, without ever letting a walker
    /// drift more than the tolerance from one anchor to the next.
    fn see(&mut self, cluster: &Cluster, now: Duration) {
        let p = cluster.nearest;
        if let Some(slot) = self.anchors.iter().position(|a| a.is_some_and(|a| a.holds(p))) {
            if let Some(anchor) = self.anchors[slot]
                && cluster.points >= SHARPER_VIEW * anchor.points
            {
                self.anchors[slot] = Anchor::of(cluster).or(self.anchors[slot]);
            }
            return;
        }
        self.anchors = [Anchor::of(cluster), self.anchors[0]];
        self.since = Some(now);
    }

    /// A partial view: its nearest return off every anchor shows the
    /// object has left them (a standing object's parts lie on its outline),
    /// but its outline is a part's, never an anchor.
    fn see_part(&mut self, cluster: &Cluster, now: Duration) {
        if !self.anchors.iter().any(|a| a.is_some_and(|a| a.holds(cluster.nearest))) {
            self.since = Some(now);
        }
    }

    /// Seconds on the anchors as of `at`: infinite if never left, 0
    /// without one or if they were left after `at`.
    fn still_s(&self, at: Duration) -> f64 {
        match (self.anchors[0], self.since) {
            (None, _) => 0.0,
            (Some(_), None) => f64::INFINITY,
            (Some(_), Some(since)) => at.saturating_sub(since).as_secs_f64(),
        }
    }
}

/// Where a track's centroid came to rest: every full view's centroid has
/// stayed within the object's largest extent seen (plus
/// [`REST_TOLERANCE_M`]) of it since `since`.
///
/// Every view's centroid lies on or within the object, so two of them are
/// never further apart than the object is across, however the view turns:
/// a box orbited in a turn, seen by the front scanner on one face and the
/// rear one on the opposite face, stays at rest while its filtered
/// velocity swings by a metre per second. Something walking leaves the
/// disc within its own size of travel (a person: 0.6 m, under 0.6 s at
/// 1 m/s), yet a person creeping below about 0.4 m/s would stay in their
/// own disc for the 1.5 s a caller asks a track to have stayed still: so
/// the disc is kept only for objects wider than any person
/// ([`REST_MIN_EXTENT_M`]).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Rest {
    point: Ned,
    extent_m: f64,
    since: Duration,
}

impl Rest {
    fn new(cluster: &Cluster, now: Duration) -> Self {
        Rest {
            point: cluster.centroid,
            extent_m: 2.0 * cluster.radius_m.max(0.0),
            since: now,
        }
    }

    fn see(&mut self, cluster: &Cluster, now: Duration) {
        let extent_m = self.extent_m.max(2.0 * cluster.radius_m.max(0.0));
        if cluster.centroid.distance_to(&self.point) <= extent_m + REST_TOLERANCE_M {
            self.extent_m = extent_m;
        } else {
            *self = Rest::new(cluster, now);
        }
    }

    /// A partial view: its centroid lies within the object, so one beyond
    /// the largest extent seen of the rest point shows it moved.
    fn see_part(&mut self, cluster: &Cluster, now: Duration) {
        if cluster.centroid.distance_to(&self.point) > self.extent_m + REST_TOLERANCE_M {
            self.since = now;
        }
    }

    fn still_s(&self, now: Duration) -> f64 {
        if self.extent_m <= REST_MIN_EXTENT_M {
            return 0.0;
        }
        now.saturating_sub(self.since).as_secs_f64()
    }
}

/// Whether `cluster` lies where `track`'s object is: within
/// [`BIRTH_EXCLUSION_M`] beyond both their edges, so that it can be a piece
/// of that object.
fn part_of(track: &Track, cluster: &Cluster) -> bool {
    track.position.distance_to(&cluster.centroid) <= track.radius_m + cluster.radius_m + BIRTH_EXCLUSION_M
}

/// `R` of a cluster centroid: the scanner's range/bearing σ through the
/// polar→Cartesian Jacobian, plus the centroid's own jitter on each axis.
fn measurement_covariance(sensor: Ned, centroid: Ned, config: &TrackingConfig) -> Matrix2<f64> {
    polar_measurement_covariance(sensor, centroid, config.range_sigma_m, config.bearing_sigma_rad)
        + Matrix2::identity() * config.centroid_sigma_m * config.centroid_sigma_m
}

/// `value ≤ limit`, false when either is NaN.
fn at_most(value: f64, limit: f64) -> bool {
    value <= limit
}

fn count_u32(n: usize) -> u32 {
    u32::try_from(n).unwrap_or(u32::MAX)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A person-sized cluster centred at `c`, seen from the origin.
    fn person(c: Ned) -> Cluster {
        Cluster {
            centroid: c,
            nearest: c,
            first: c,
            last: c,
            extent_m: 0.45,
            radius_m: 0.25,
            points: 20,
            first_point: 0,
            is_structure: false,
            outline: None,
            occluded: false,
            cut_by_field_edge: false,
        }
    }

    fn at_ms(ms: u64) -> Duration {
        Duration::from_millis(ms)
    }

    #[test]
    fn confirms_after_n_hits_then_coasts_and_is_deleted() {
        // The σ limit out of the way: this is about the timeouts.
        let config = TrackingConfig {
            max_position_sigma_m: 100.0,
            ..TrackingConfig::default()
        };
        let mut tracker = ObstacleTracker::new();
        let c = [person(Ned::new(4.0, 1.0))];
        let s = tracker.update(at_ms(0), Ned::default(), &c, &config);
        assert_eq!((s.births, s.tentative, s.confirmed), (1, 1, 0));
        let id = tracker.tracks()[0].id;
        for k in 1..config.confirm_hits as u64 {
            let s = tracker.update(at_ms(20 * k), Ned::default(), &c, &config);
            let expect_confirmed = k + 1 >= config.confirm_hits as u64;
            assert_eq!(s.confirmed == 1, expect_confirmed, "after {} hits", k + 1);
            assert_eq!(s.births, 0);
        }
        assert_eq!(tracker.tracks()[0].status, TrackStatus::Confirmed);
        assert_eq!(tracker.tracks()[0].id, id);
        tracker.update(at_ms(60), Ned::default(), &c, &config);
        let nearest = tracker.nearest_edge(Ned::default());
        assert_eq!(nearest.map(|n| n.0), Some(id));
        let edge = nearest.map_or(0.0, |n| n.1);
        assert!(
            (edge - (Ned::new(4.0, 1.0).distance_to(&Ned::default()) - 0.25)).abs() < 0.01,
            "{edge}"
        );

        // Gone: coasting after coast_s, deleted after delete_s.
        let last_seen_ms = 60;
        let mut coasting_at = None;
        let mut deleted_at = None;
        for k in 1..200u64 {
            let t = last_seen_ms + 20 * k;
            let s = tracker.update(at_ms(t), Ned::default(), &[], &config);
            if coasting_at.is_none()
                && tracker
                    .tracks()
                    .first()
                    .is_some_and(|t| t.status == TrackStatus::Coasting)
            {
                coasting_at = Some(t);
            }
            if s.deaths == 1 {
                deleted_at = Some(t);
                break;
            }
        }
        let coast_ms = (config.coast_s * 1000.0) as u64;
        let delete_ms = (config.delete_s * 1000.0) as u64;
        let coasting_at = coasting_at.map(|t| t - last_seen_ms);
        let deleted_at = deleted_at.map(|t| t - last_seen_ms);
        assert!(
            coasting_at.is_some_and(|t| t > coast_ms && t <= coast_ms + 20),
            "{coasting_at:?}"
        );
        assert!(
            deleted_at.is_some_and(|t| t > delete_ms && t <= delete_ms + 20),
            "{deleted_at:?}"
        );
        assert!(tracker.tracks().is_empty());
    }

    #[test]
    fn a_track_too_uncertain_is_deleted_before_its_timeout() {
        let config = TrackingConfig {
            max_position_sigma_m: 0.3,
            delete_s: 10.0,
            ..TrackingConfig::default()
        };
        let mut tracker = ObstacleTracker::new();
        for k in 0..10u64 {
            tracker.update(at_ms(20 * k), Ned::default(), &[person(Ned::new(3.0, 0.0))], &config);
        }
        let mut died_at = None;
        for k in 10..500u64 {
            let sigma_before = tracker.tracks().first().map_or(0.0, |t| t.position_sigma_m);
            let s = tracker.update(at_ms(20 * k), Ned::default(), &[], &config);
            if s.deaths > 0 {
                died_at = Some(k);
                assert!(sigma_before <= 0.3);
                break;
            }
            assert!(tracker.tracks()[0].position_sigma_m <= 0.3);
        }
        assert!(died_at.is_some_and(|k| k < 10 + 500 / 2), "{died_at:?}");
    }

    #[test]
    fn an_unconfirmed_track_dies_without_coasting() {
        let config = TrackingConfig::default();
        let mut tracker = ObstacleTracker::new();
        tracker.update(at_ms(0), Ned::default(), &[person(Ned::new(3.0, 0.0))], &config);
        let mut died = None;
        for k in 1..100u64 {
            let s = tracker.update(at_ms(20 * k), Ned::default(), &[], &config);
            assert!(tracker.tracks().iter().all(|t| t.status == TrackStatus::Tentative));
            if s.deaths > 0 {
                died = Some(20 * k);
                break;
            }
        }
        assert!(
            died.is_some_and(|t| t as f64 > config.coast_s * 1000.0 && (t as f64) <= config.coast_s * 1000.0 + 20.0)
        );
    }

    #[test]
    fn a_big_cluster_two_tracks_claim_updates_neither() {
        // A wide gate (σ of a coasting track) makes the point.
        let config = TrackingConfig {
            centroid_sigma_m: 0.3,
            ..TrackingConfig::default()
        };
        let mut tracker = ObstacleTracker::new();
        let (left, right) = (Ned::new(5.0, -0.3), Ned::new(5.0, 0.3));
        for k in 0..5u64 {
            tracker.update(at_ms(20 * k), Ned::default(), &[person(left), person(right)], &config);
        }
        let before: Vec<Ned> = tracker.tracks().iter().map(|t| t.position).collect();
        let mut merged = person(Ned::new(5.0, 0.05));
        merged.radius_m = 0.55;
        let s = tracker.update(at_ms(100), Ned::default(), &[merged], &config);
        assert_eq!((s.births, s.deaths), (0, 0));
        for (track, before) in tracker.tracks().iter().zip(&before) {
            assert_eq!(track.misses, 1, "{track:?}");
            assert!(track.position.distance_to(before) < 1e-9);
            assert!((track.radius_m - 0.25).abs() < 1e-12);
        }
        // The same cluster at a single track's size is that track's.
        merged.radius_m = 0.25;
        tracker.update(at_ms(120), Ned::default(), &[merged], &config);
        let misses: Vec<u32> = tracker.tracks().iter().map(|t| t.misses).collect();
        assert_eq!(misses, vec![2, 0]);
    }

    #[test]
    fn a_walker_merging_with_someone_standing_updates_neither() {
        // Default gates: the standing track is sure of its place, so the
        // merged centroid (0.55 m off it, near the walker, who hides part
        // of them) is in the walker's gate only; the cluster covers both.
        let config = TrackingConfig::default();
        let mut tracker = ObstacleTracker::new();
        let standing = Ned::new(5.0, -0.3);
        for k in 0..50u64 {
            let walker = Ned::new(5.0, 0.3 + 0.02 * (50 - k) as f64);
            tracker.update(
                at_ms(20 * k),
                Ned::default(),
                &[person(standing), person(walker)],
                &config,
            );
        }
        let before: Vec<Track> = tracker.tracks().to_vec();
        let mut merged = person(Ned::new(5.0, 0.25));
        merged.radius_m = 0.6;
        tracker.update(at_ms(1000), Ned::default(), &[merged], &config);
        for (track, before) in tracker.tracks().iter().zip(&before) {
            assert_eq!(track.misses, 1, "{track:?}");
            assert!((track.radius_m - before.radius_m).abs() < 1e-12, "{track:?}");
            let velocity_change =
                (track.vel_north_mps - before.vel_north_mps).hypot(track.vel_east_mps - before.vel_east_mps);
            assert!(velocity_change < 1e-9, "{track:?} after {before:?}");
        }
    }

    #[test]
    fn a_second_piece_of_a_tracked_person_gives_no_birth() {
        let config = TrackingConfig::default();
        let mut tracker = ObstacleTracker::new();
        let c = Ned::new(5.0, 0.0);
        for k in 0..10u64 {
            tracker.update(at_ms(20 * k), Ned::default(), &[person(c)], &config);
        }
        // The person, and beside it a sliver of the same person (off the
        // track's tight gate): no second track.
        let mut sliver = person(Ned::new(5.0, 0.35));
        sliver.radius_m = 0.06;
        let s = tracker.update(at_ms(200), Ned::default(), &[person(c), sliver], &config);
        assert_eq!(s.births, 0, "{:?}", tracker.tracks());
        // Two people side by side seen together for the first time: two tracks.
        let mut fresh = ObstacleTracker::new();
        let s = fresh.update(
            at_ms(0),
            Ned::default(),
            &[person(Ned::new(5.0, -0.3)), person(Ned::new(5.0, 0.3))],
            &config,
        );
        assert_eq!(s.births, 2);
    }

    #[test]
    fn an_occluded_cluster_keeps_a_track_but_barely_moves_it() {
        let config = TrackingConfig::default();
        let mut tracker = ObstacleTracker::new();
        let c = Ned::new(5.0, 0.0);
        for k in 0..25u64 {
            tracker.update(at_ms(20 * k), Ned::default(), &[person(c)], &config);
        }
        // Inside the gate of an ordinary update too.
        let mut sliver = person(Ned::new(4.94, 0.06));
        sliver.radius_m = 0.08;
        let mut plain = tracker.clone();
        plain.update(at_ms(500), Ned::default(), &[sliver], &config);
        sliver.occluded = true;
        let s = tracker.update(at_ms(500), Ned::default(), &[sliver], &config);
        assert_eq!(s.births, 0);
        let track = tracker.tracks()[0];
        assert_eq!(track.misses, 0);
        assert_eq!(track.radius_m, 0.25);
        let plain_moved = plain.tracks()[0].position.distance_to(&c);
        let moved = track.position.distance_to(&c);
        assert_eq!(plain.tracks().len(), 1);
        assert!(moved < 0.1 * plain_moved, "{moved} vs {plain_moved}");
    }

    /// Someone walking into the blind zone beside the body: the field's
    /// edge shows a sliver that stays where the edge is. The track keeps
    /// the person's size, does not read as standing still, and its outline
    /// goes where the filter takes it instead of staying behind.
    #[test]
    fn a_walker_seen_as_a_sliver_keeps_its_size_and_is_not_still() {
        let config = TrackingConfig::default();
        let mut tracker = ObstacleTracker::new();
        let outline_of = |c: Ned| {
            let mut fit = FitScratch::default();
            let points = [
                Ned::new(c.north_m - 0.2, c.east_m - 0.15),
                Ned::new(c.north_m - 0.25, c.east_m),
                Ned::new(c.north_m - 0.2, c.east_m + 0.15),
            ];
            Outline::fit(&mut fit, c, &points, (0.45, 0.0), |p| *p)
        };
        // Walking east at 0.4 m/s, seen whole at 50 Hz for 2 s.
        let at = |k: u64| Ned::new(3.0, 0.4 * 0.02 * k as f64);
        for k in 0..100u64 {
            let mut c = person(at(k));
            c.outline = outline_of(at(k));
            tracker.update(at_ms(20 * k), Ned::default(), &[c], &config);
        }
        let still_before = tracker.tracks()[0].still_s;
        // Then only its west edge, stuck at the field's edge, for 2 s.
        let edge = Ned::new(3.0, 0.8);
        for k in 100..200u64 {
            let mut sliver = person(edge);
            sliver.radius_m = 0.04;
            sliver.cut_by_field_edge = true;
            sliver.outline = None;
            tracker.update(at_ms(20 * k), Ned::default(), &[sliver], &config);
        }
        let track = tracker.tracks()[0];
        assert_eq!(track.radius_m, 0.25);
        assert!(track.still_s <= still_before, "{} after {still_before}", track.still_s);
        let outline = track.outline.expect("the last full view's outline");
        let offset_m = outline.distance_outside_m((0.0, 0.0));
        assert!(offset_m < 0.05, "the outline stayed behind the track by {offset_m} m");
    }

    /// Someone who stood, seen only partly (at the field's edge), starts to
    /// walk: their part leaving where they stood ends the stillness.
    #[test]
    fn a_part_leaving_where_the_object_stood_ends_its_stillness() {
        let config = TrackingConfig::default();
        let mut tracker = ObstacleTracker::new();
        let c = Ned::new(3.0, 0.0);
        let mut standing = person(c);
        let mut fit = FitScratch::default();
        let points = [Ned::new(2.8, -0.15), Ned::new(2.75, 0.0), Ned::new(2.8, 0.15)];
        standing.outline = Outline::fit(&mut fit, c, &points, (0.45, 0.0), |p| *p);
        for k in 0..100u64 {
            tracker.update(at_ms(20 * k), Ned::default(), &[standing], &config);
        }
        assert!(tracker.tracks()[0].still_s >= 1.5, "{:?}", tracker.tracks()[0]);
        // A part on where it stands proves nothing either way.
        let mut part = person(c);
        part.nearest = Ned::new(2.75, 0.0);
        part.cut_by_field_edge = true;
        tracker.update(at_ms(2000), Ned::default(), &[part], &config);
        assert!(tracker.tracks()[0].still_s >= 1.5, "{:?}", tracker.tracks()[0]);
        // Walking off east at 0.4 m/s, seen only in part.
        for k in 101..200u64 {
            let east_m = 0.4 * 0.02 * (k - 100) as f64;
            let mut part = person(Ned::new(3.0, east_m));
            part.nearest = Ned::new(2.75, east_m);
            part.cut_by_field_edge = true;
            tracker.update(at_ms(20 * k), Ned::default(), &[part], &config);
        }
        assert_eq!(tracker.tracks()[0].still_s, 0.0, "{:?}", tracker.tracks()[0]);
    }

    #[test]
    fn a_person_cut_in_two_pieces_keeps_its_velocity() {
        let config = TrackingConfig::default();
        let mut tracker = ObstacleTracker::new();
        // Walking south-east at 0.5 m/s, seen whole at 50 Hz.
        let (vn, ve) = (-0.35, 0.35);
        let at = |k: u64| Ned::new(5.0 + vn * 0.02 * k as f64, -1.0 + ve * 0.02 * k as f64);
        for k in 0..100u64 {
            tracker.update(at_ms(20 * k), Ned::default(), &[person(at(k))], &config);
        }
        let before = tracker.tracks()[0];
        assert!((before.vel_north_mps - vn).abs() < 0.05 && (before.vel_east_mps - ve).abs() < 0.05);
        // Two beams in a row without echo cut the person in two: the larger
        // piece's centroid is a few centimetres off the centre (inside the
        // track's gate), the smaller one lies beside it.
        let c = at(100);
        let mut big = person(Ned::new(c.north_m + 0.03, c.east_m - 0.08));
        big.radius_m = 0.155;
        let mut small = person(Ned::new(c.north_m - 0.19, c.east_m + 0.01));
        small.radius_m = 0.10;
        let mut plain = tracker.clone();
        plain.update(at_ms(2000), Ned::default(), &[big], &config);
        let s = tracker.update(at_ms(2000), Ned::default(), &[big, small], &config);
        assert_eq!((s.births, s.deaths), (0, 0));
        assert_eq!(tracker.tracks().len(), 1);
        let change = |t: &Track| (t.vel_north_mps - before.vel_north_mps).hypot(t.vel_east_mps - before.vel_east_mps);
        let (plain_change, pieces_change) = (change(&plain.tracks()[0]), change(&tracker.tracks()[0]));
        // What an ordinary update with the piece does to the velocity.
        assert!(plain_change > 0.2, "{plain_change}");
        assert!(pieces_change < 0.05, "{pieces_change} vs {plain_change}");
        let track = tracker.tracks()[0];
        assert_eq!(track.misses, 0);
        assert_eq!(track.radius_m, before.radius_m);
    }

    /// The cluster of the returns `points` seen from `sensor`, with its
    /// outline extended away from the sensor as the clusterer does.
    fn seen(sensor: Ned, points: &[Ned]) -> Cluster {
        let n = points.len() as f64;
        let centroid = Ned::new(
            points.iter().map(|p| p.north_m).sum::<f64>() / n,
            points.iter().map(|p| p.east_m).sum::<f64>() / n,
        );
        let nearest = *points
            .iter()
            .min_by(|a, b| sensor.distance_to(a).total_cmp(&sensor.distance_to(b)))
            .expect("points");
        let (first, last) = (points[0], points[points.len() - 1]);
        let extent_m = first.distance_to(&last);
        let (sin_b, cos_b) = sensor.bearing_to(&centroid).sin_cos();
        let outline = Outline::fit(
            &mut FitScratch::default(),
            centroid,
            points,
            (extent_m * cos_b, extent_m * sin_b),
            |p| *p,
        );
        Cluster {
            centroid,
            nearest,
            first,
            last,
            extent_m,
            radius_m: extent_m / 2.0,
            points: points.len(),
            first_point: 0,
            is_structure: false,
            outline,
            occluded: false,
            cut_by_field_edge: false,
        }
    }

    /// The faces of the 0.8 m box centred 5 m north, 2 m east that a
    /// scanner on the north axis at `north_m` sees.
    fn box_faces(north_m: f64) -> Vec<Ned> {
        let (south, north, west) = (4.6, 5.4, 1.6);
        let steps = |from: f64, to: f64| (0..=16).map(move |i| from + (to - from) * f64::from(i) / 16.0);
        let mut points = Vec::new();
        if north_m < south {
            points.extend(steps(2.4, west).map(|e| Ned::new(south, e)));
        }
        points.extend(steps(south, north).map(|n| Ned::new(n, west)));
        if north_m > north {
            points.extend(steps(west, 2.4).map(|e| Ned::new(north, e)));
        }
        points
    }

    #[test]
    fn a_box_seen_from_a_passing_scanner_stays_on_its_outline() {
        let config = TrackingConfig::default();
        let mut tracker = ObstacleTracker::new();
        let mut fastest_mps: f64 = 0.0;
        // Driving past at 1 m/s, scanned at 50 Hz.
        for k in 0..500u64 {
            let sensor = Ned::new(0.02 * k as f64, 0.0);
            tracker.update(
                at_ms(20 * k),
                sensor,
                &[seen(sensor, &box_faces(sensor.north_m))],
                &config,
            );
            assert_eq!(tracker.tracks().len(), 1);
            let track = tracker.tracks()[0];
            fastest_mps = fastest_mps.max(track.speed_mps());
            assert!(track.still_s > 1.0, "at {}: {track:?}", sensor.north_m);
        }
        // The changing view does walk the centroid: the velocity alone
        // would call the box moving.
        assert!(fastest_mps > 0.2, "{fastest_mps}");
    }

    #[test]
    fn a_box_approached_from_afar_stays_on_its_sharpening_outline() {
        // The box of `box_faces` as a 0.5° scanner sees it. From 25 m off
        // a handful of returns fall on its near face and none on the lane
        // side, so that first view's outline misses a corner; close up its
        // side face shows beyond it.
        let (south, north, west, east) = (4.6, 5.4, 1.6, 2.4);
        let faces = |sensor: Ned| -> Vec<Ned> {
            let step = 0.5_f64.to_radians();
            let mut points = Vec::new();
            for i in 0..720 {
                let (sin_b, cos_b) = (f64::from(i) * step).sin_cos();
                // The south face (north = south) and the west face (east = west).
                let t_south = (south - sensor.north_m) / cos_b;
                let t_west = (west - sensor.east_m) / sin_b;
                let hit = [(t_south, true), (t_west, false)]
                    .into_iter()
                    .filter(|(t, _)| t.is_finite() && *t > 0.0)
                    .filter(|&(t, on_south)| {
                        let p = Ned::new(sensor.north_m + t * cos_b, sensor.east_m + t * sin_b);
                        if on_south {
                            (west..=east).contains(&p.east_m)
                        } else {
                            (south..=north).contains(&p.north_m)
                        }
                    })
                    .map(|(t, _)| t)
                    .fold(f64::INFINITY, f64::min);
                if hit.is_finite() {
                    points.push(Ned::new(sensor.north_m + hit * cos_b, sensor.east_m + hit * sin_b));
                }
            }
            points
        };
        let config = TrackingConfig::default();
        let mut tracker = ObstacleTracker::new();
        // Driving up at 2 m/s from 25 m short of the box to beside it.
        for k in 0..600u64 {
            let sensor = Ned::new(-20.0 + 0.04 * k as f64, 0.0);
            if sensor.north_m > south - 0.5 {
                break;
            }
            let mut cluster = seen(sensor, &faces(sensor));
            cluster.radius_m = 0.5 * (cluster.extent_m + sensor.distance_to(&cluster.centroid) * 0.5_f64.to_radians());
            tracker.update(at_ms(20 * k), sensor, &[cluster], &config);
            assert_eq!(tracker.tracks().len(), 1);
            let track = tracker.tracks()[0];
            assert!(track.still_s > 1.0, "at {}: {track:?}", sensor.north_m);
        }
    }

    #[test]
    fn someone_walking_never_counts_as_still() {
        let config = TrackingConfig::default();
        let circle = |c: Ned| -> Vec<Ned> {
            (0..=12)
                .map(|i| {
                    let a = std::f64::consts::PI * (0.5 + f64::from(i) / 12.0);
                    Ned::new(c.north_m + 0.25 * a.cos(), c.east_m + 0.25 * a.sin())
                })
                .collect()
        };
        // Across the scanner's view at 0.5 m/s, and straight towards it.
        for (vn, ve) in [(0.0, 0.5), (-0.5, 0.0)] {
            let mut tracker = ObstacleTracker::new();
            for k in 0..150u64 {
                let t = 0.02 * k as f64;
                let c = Ned::new(6.0 + vn * t, -1.0 + ve * t);
                tracker.update(
                    at_ms(20 * k),
                    Ned::default(),
                    &[seen(Ned::default(), &circle(c))],
                    &config,
                );
                // Off its outline within a second; its centroid never rests
                // the 1.5 s the vehicle asks of a standing object (it leaves
                // a disc of its own size, 0.6 m, every 1.2 s).
                if k >= 50 {
                    let track = tracker.tracks()[0];
                    assert!(track.still_s < 1.5, "{k}: {track:?}");
                }
            }
        }
    }

    /// The faces of an 0.8 m box centred at the origin (axis-aligned) that
    /// a scanner at `sensor` sees, in bearing order.
    fn visible_faces(sensor: Ned) -> Vec<Ned> {
        let h = 0.4;
        let steps = |i: i32| -h + 2.0 * h * f64::from(i) / 16.0;
        let mut points: Vec<Ned> = Vec::new();
        for (normal, on_face) in [
            ((1.0, 0.0), &(|t: f64| Ned::new(h, t)) as &dyn Fn(f64) -> Ned),
            ((-1.0, 0.0), &|t: f64| Ned::new(-h, t)),
            ((0.0, 1.0), &|t: f64| Ned::new(t, h)),
            ((0.0, -1.0), &|t: f64| Ned::new(t, -h)),
        ] {
            if sensor.north_m * normal.0 + sensor.east_m * normal.1 > h {
                points.extend((0..=16).map(|i| on_face(steps(i))));
            }
        }
        points.sort_by(|a, b| sensor.bearing_to(a).total_cmp(&sensor.bearing_to(b)));
        points.dedup();
        points
    }

    #[test]
    fn a_box_orbited_by_two_scanners_stays_at_rest() {
        // Round a 5 m arc about the box at 1 m/s, one scanner 3.6 m ahead
        // of the reference point and one 0.8 m behind it: each sees other
        // faces, and the view turns all the time.
        let config = TrackingConfig::default();
        let mut tracker = ObstacleTracker::new();
        let mut fastest_mps: f64 = 0.0;
        for k in 0..600u64 {
            let angle = 0.2 * 0.02 * k as f64;
            let (sin_a, cos_a) = angle.sin_cos();
            // Heading along the circle (counter-clockwise in north, east).
            let (hn, he) = (-sin_a, cos_a);
            let at = |x: f64| Ned::new(5.0 * cos_a + x * hn, 5.0 * sin_a + x * he);
            let scanner = if k % 2 == 0 { at(3.6) } else { at(-0.8) };
            tracker.update(
                at_ms(20 * k),
                scanner,
                &[seen(scanner, &visible_faces(scanner))],
                &config,
            );
            assert_eq!(tracker.tracks().len(), 1);
            let track = tracker.tracks()[0];
            fastest_mps = fastest_mps.max(track.speed_mps());
            if k >= 100 {
                assert!(track.still_s > 1.5, "at {k}: {track:?}");
            }
        }
        // The velocity alone would call it walking.
        assert!(fastest_mps > 0.2, "{fastest_mps}");
    }

    #[test]
    fn structure_is_never_tracked() {
        let mut wall = person(Ned::new(5.0, 0.0));
        wall.is_structure = true;
        let mut tracker = ObstacleTracker::new();
        let s = tracker.update(at_ms(0), Ned::default(), &[wall], &TrackingConfig::default());
        assert_eq!(s.births, 0);
        assert!(tracker.tracks().is_empty());
    }

    #[test]
    fn two_scanners_at_one_instant_make_one_track_and_one_hit() {
        let config = TrackingConfig::default();
        let mut tracker = ObstacleTracker::new();
        let (front, rear) = (Ned::new(1.0, 0.0), Ned::new(-1.0, 0.0));
        let truth = Ned::new(3.0, 3.0);
        for k in 0..3u64 {
            // Each scanner's centroid is a little off, as it would be.
            let a = tracker.update(at_ms(20 * k), front, &[person(Ned::new(3.02, 3.0))], &config);
            let b = tracker.update(at_ms(20 * k), rear, &[person(Ned::new(2.98, 3.01))], &config);
            assert_eq!(a.births + b.births, if k == 0 { 1 } else { 0 });
            assert_eq!(tracker.tracks().len(), 1);
            assert_eq!(tracker.tracks()[0].hits, k as u32 + 1);
        }
        assert_eq!(tracker.tracks()[0].status, TrackStatus::Confirmed);
        assert!(tracker.tracks()[0].position.distance_to(&truth) < 0.03);
    }

    #[test]
    fn bad_input_never_panics_and_never_tracks() {
        let config = TrackingConfig::default();
        let mut tracker = ObstacleTracker::new();
        let bad = [person(Ned::new(f64::NAN, 1.0)), person(Ned::new(1.0, f64::INFINITY))];
        let s = tracker.update(at_ms(0), Ned::default(), &bad, &config);
        assert_eq!(s.births, 0);
        // A NaN sensor gives a NaN covariance: the filter refuses it.
        let s = tracker.update(
            at_ms(20),
            Ned::new(f64::NAN, 0.0),
            &[person(Ned::new(2.0, 0.0))],
            &config,
        );
        assert_eq!(s.births, 0);
        // A NaN process noise drops the track rather than poisoning it.
        tracker.update(at_ms(40), Ned::default(), &[person(Ned::new(2.0, 0.0))], &config);
        assert_eq!(tracker.tracks().len(), 1);
        let broken = TrackingConfig {
            accel_density: f64::NAN,
            ..config
        };
        let s = tracker.update(at_ms(60), Ned::default(), &[], &broken);
        assert_eq!(s.deaths, 1);
        assert!(tracker.tracks().is_empty());
    }

    #[test]
    fn late_scans_are_applied_now_and_a_clock_reset_starts_afresh() {
        let config = TrackingConfig::default();
        let mut tracker = ObstacleTracker::new();
        let c = [person(Ned::new(3.0, 0.0))];
        tracker.update(at_ms(5000), Ned::default(), &c, &config);
        tracker.update(at_ms(5020), Ned::default(), &c, &config);
        // 10 ms late: same track, its time does not go back.
        let s = tracker.update(at_ms(5010), Ned::default(), &c, &config);
        assert_eq!((s.births, s.deaths), (0, 0));
        assert!((tracker.tracks()[0].age_s - 0.02).abs() < 1e-9);
        // The clock restarts from zero: everything is forgotten.
        let s = tracker.update(at_ms(0), Ned::default(), &c, &config);
        assert_eq!((s.births, s.deaths), (1, 1));
        assert_eq!(tracker.tracks()[0].age_s, 0.0);
        assert!(tracker.tracks()[0].id > 1);
        tracker.clear();
        assert!(tracker.tracks().is_empty());
    }
}
