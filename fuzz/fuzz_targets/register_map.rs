#![no_main]
//! cargo-fuzz target `register_map`: see fringe_fuzz (fuzz/harness/src).

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    fringe_fuzz::text::register_map(data);
});
