//! The fuzz targets of fringe: every decoder and reader of bytes or text a user or a device can
//! hand it, each as one function of arbitrary bytes that must return (an `Err` is fine) without
//! panicking, hanging or allocating without bound.
//!
//! `fuzz/` (cargo-fuzz, nightly) drives these functions with libFuzzer; the test in
//! `tests/replay.rs` runs every file of `fuzz/corpus/<target>/` and `fuzz/regressions/<target>/`
//! through them on stable, so a crash once found stays fixed. `scripts/fuzz` runs the fuzzers.

pub mod binary;
pub mod files;
pub mod text;

/// A fuzz target: its name (the directory of its corpus) and what it does with the bytes.
pub struct Target {
    pub name: &'static str,
    pub run: fn(&[u8]),
}

/// Every target, by name.
pub static TARGETS: &[Target] = &[
    Target {
        name: "apt",
        run: binary::apt,
    },
    Target {
        name: "rdt",
        run: binary::rdt,
    },
    Target {
        name: "modbus",
        run: binary::modbus,
    },
    Target {
        name: "fgl",
        run: binary::fgl,
    },
    Target {
        name: "force_log",
        run: binary::force_log,
    },
    Target {
        name: "pickle",
        run: binary::pickle,
    },
    Target {
        name: "netft_xml",
        run: text::netft_xml,
    },
    Target {
        name: "cal_file",
        run: text::cal_file,
    },
    Target {
        name: "register_map",
        run: text::register_map,
    },
    Target {
        name: "plan",
        run: text::plan,
    },
    Target {
        name: "rig_file",
        run: text::rig_file,
    },
    Target {
        name: "sensor_file",
        run: text::sensor_file,
    },
    Target {
        name: "profile",
        run: text::profile,
    },
    Target {
        name: "trace",
        run: text::trace,
    },
    Target {
        name: "model_file",
        run: files::model_file,
    },
    Target {
        name: "run_dir",
        run: files::run_dir,
    },
];

/// The target called `name`.
pub fn target(name: &str) -> Option<&'static Target> {
    TARGETS.iter().find(|t| t.name == name)
}
