//! Arbitrary missions a ground station could upload, flown in AUTO for
//! simulated minutes by the executor and the navigator on a kinematic
//! bicycle, with the vehicle's guidance parameters fuzzed within their
//! declared ranges. Properties (see `furrow_fuzz::flight`): no panic,
//! outputs finite and within limits, the vehicle never leaves the fence, a
//! stop always ends in HOLD or the next item.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    // Too few bytes to build a vehicle and a plan: nothing to fly.
    let _ = furrow_fuzz::flight::fly(data);
});
