//! Guidance: the path to follow, the preview-point tracker that steers onto
//! it, the speed to drive at, and the navigator that ties them together for
//! the modes.

pub mod direction_count;
pub mod magnetic;
pub mod magnetic_estimate;
pub mod magnetic_slope;
pub mod magnetic_turn;
pub mod manoeuvre;
pub mod navigator;
pub mod path;
pub mod reeds_shepp;
pub mod rejoin;
pub mod speed;
pub mod tracker;
