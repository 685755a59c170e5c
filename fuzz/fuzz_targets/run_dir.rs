#![no_main]
//! cargo-fuzz target `run_dir`: see fringe_fuzz (fuzz/harness/src).

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    fringe_fuzz::files::run_dir(data);
});
