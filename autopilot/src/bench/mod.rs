//! Benchmarks printed by `furrow bench …`: figures, not pass/fail tests.

pub mod sitl;
