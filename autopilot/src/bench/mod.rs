//! Benchmarks printed by `furrow bench …`: figures, not pass/fail tests.

pub mod magnetic;
pub mod manoeuvre;
pub mod obstacles;
pub mod plot;
pub mod safety;
pub mod sitl;
pub mod tracking;
