#![no_main]
//! cargo-fuzz target `apt`: see fringe_fuzz (fuzz/harness/src).

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    fringe_fuzz::binary::apt(data);
});
