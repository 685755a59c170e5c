#![no_main]
//! cargo-fuzz target `modbus`: see fringe_fuzz (fuzz/harness/src).

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    fringe_fuzz::binary::modbus(data);
});
