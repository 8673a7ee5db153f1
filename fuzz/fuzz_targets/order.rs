//! VDA 5050 orders, order updates and instant actions fed to the vehicle's
//! agent and stepped while a point vehicle drives what it commands.
//! Properties: see `furrow_fuzz::order`.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    // Too few bytes for the next payload: the input ends there.
    let _ = furrow_fuzz::order::run(data);
});
