#![no_main]
//! cargo-fuzz target `sensor_file`: see fringe_fuzz (fuzz/harness/src).

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    fringe_fuzz::text::sensor_file(data);
});
