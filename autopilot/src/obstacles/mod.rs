//! Obstacles (docs/architecture.md §Obstacles, seed 004 §III): a 2D laser scan turned into
//! points in the local frame, clusters, and one Kalman filter per tracked
//! object; collision prediction against the vehicle's footprint; and the
//! policy that stops (or passes first) and resumes.
//!
//! Pure and deterministic like the rest of the core: every function takes
//! its inputs and time explicitly and returns a status.
//!
//! - [`cluster`], [`kalman`], [`tracking`]: perception (scan → tracks);
//! - [`outline`]: the shape of what is not a walking person;
//! - [`swept`]: the outline swept along the path ahead;
//! - [`prediction`], [`field`], [`policy`], [`detour`]: decisions.
//!
//! Sources: docs/references.md §Seed 004.

pub mod cluster;
pub mod detour;
pub mod field;
pub mod kalman;
pub mod outline;
pub mod params;
pub mod policy;
pub mod prediction;
pub mod swept;
pub mod tracking;

use crate::geo::Ned;

/// Where the scanner sits on the vehicle: body frame (x forward, y right)
/// from the reference point (the rear axle centre), and its forward axis's
/// yaw from the vehicle's (clockwise positive).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ScannerMount {
    pub x_m: f64,
    pub y_m: f64,
    pub yaw_rad: f64,
}

/// The vehicle's pose when a scan was taken, in the local frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Pose {
    pub position: Ned,
    pub yaw_rad: f64,
}

/// The vehicle's outline as a rectangle about the reference point (rear
/// axle centre): how far the body reaches forward and backward, and half
/// its width.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Footprint {
    pub front_m: f64,
    pub rear_m: f64,
    pub half_width_m: f64,
}

/// Whether a track has been seen often enough to act on.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TrackStatus {
    /// Just born: not yet acted on.
    #[default]
    Tentative,
    Confirmed,
    /// Not seen for a while: predicted only, about to be deleted.
    Coasting,
}

/// One tracked object, in the local frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Track {
    pub id: u32,
    pub status: TrackStatus,
    pub position: Ned,
    pub vel_north_mps: f64,
    pub vel_east_mps: f64,
    /// 1-σ of position and of velocity (largest axis).
    pub position_sigma_m: f64,
    pub velocity_sigma_mps: f64,
    /// Half the extent of the cluster it was last fitted to: the object's
    /// size for clearance checks.
    pub radius_m: f64,
    /// The shape of its last full view, about `position`: the true shape of
    /// a standing object (see [`outline`]).
    pub outline: Option<outline::Outline>,
    /// Seconds since birth, and since the last associated cluster.
    pub age_s: f64,
    pub unseen_s: f64,
    /// How many scans associated and missed in a row.
    pub hits: u32,
    pub misses: u32,
    /// How long (s) its returns have stayed on the outline fitted when they
    /// last left one (infinite: they never have since the track was born;
    /// 0 without an outline). A standing object's centroid walks as the view
    /// of it changes (a box's corner as the vehicle drives past); its
    /// returns stay on its outline. Or, if longer, how long its centroid
    /// has stayed within the object's extent of one place (its view
    /// turning, as in a turn round it, moves the centroid only within the
    /// object). Both as of its last full view: partial views and time out
    /// of sight add nothing.
    pub still_s: f64,
}

impl Track {
    pub fn speed_mps(&self) -> f64 {
        self.vel_north_mps.hypot(self.vel_east_mps)
    }
}
