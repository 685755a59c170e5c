#![no_main]
//! cargo-fuzz target `fgl`: see fringe_fuzz (fuzz/harness/src).

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    fringe_fuzz::binary::fgl(data);
});
