#![no_main]
//! cargo-fuzz target `force_log`: see fringe_fuzz (fuzz/harness/src).

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    fringe_fuzz::binary::force_log(data);
});
