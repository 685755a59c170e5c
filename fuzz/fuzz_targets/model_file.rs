#![no_main]
//! cargo-fuzz target `model_file`: see fringe_fuzz (fuzz/harness/src).

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    fringe_fuzz::files::model_file(data);
});
