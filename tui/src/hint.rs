//! Which fringe command helps with an error. The libraries say what is wrong and which file or
//! device; only the front end knows its commands, so it adds them here, for the command line and
//! the terminal UI alike.

use fringe_rig::camera::CameraError;
use fringe_rig::store::StoreError;
use fringe_rig::transport::serial::PortOpenError;
use fringe_rig::ScanError;
use fringe_sensor_models::dataset::DatasetError;
use std::error::Error;

/// The command that helps with `e` (the first error of its chain that one helps with).
pub fn for_error(e: &anyhow::Error) -> Option<String> {
    e.chain().find_map(for_cause)
}

/// `e` joined with the command that helps with it, if any.
pub fn with_hint(text: String, e: &anyhow::Error) -> String {
    match for_error(e) {
        Some(hint) => format!("{text}: {hint}"),
        None => text,
    }
}

fn for_cause(e: &(dyn Error + 'static)) -> Option<String> {
    if let Some(s) = e.downcast_ref::<ScanError>() {
        return scan(s);
    }
    if let Some(s) = e.downcast_ref::<StoreError>() {
        return store(s);
    }
    if let Some(d) = e.downcast_ref::<DatasetError>() {
        return match d {
            DatasetError::Missing(_) => Some(
                "give a run directory that `fringe scan` wrote (`fringe runs` lists them), or a \
                 dataset that `fringe export` or `fringe sim dataset` wrote"
                    .into(),
            ),
            DatasetError::Store(s) => store(s),
            _ => None,
        };
    }
    if let Some(CameraError::Open { .. }) = e.downcast_ref::<CameraError>() {
        return Some("`fringe devices` lists the cameras".into());
    }
    let port = e
        .downcast_ref::<std::io::Error>()
        .and_then(|io| io.get_ref())
        .and_then(|inner| inner.downcast_ref::<PortOpenError>());
    port.map(|_| "`fringe devices` lists the serial ports".into())
}

fn scan(e: &ScanError) -> Option<String> {
    match e {
        ScanError::Stopped { run, .. } => Some(format!("fringe scan --resume {}", run.display())),
        ScanError::Store(s) => store(s),
        _ => None,
    }
}

fn store(e: &StoreError) -> Option<String> {
    match e {
        StoreError::NotARun { .. } => Some(
            "give the directory of a run that `fringe scan` wrote (`fringe runs --root DIR` lists \
             the runs in DIR)"
                .into(),
        ),
        StoreError::Unverified { run, .. } => Some(format!(
            "see `fringe verify {}`, or export it anyway with --allow-unverified",
            run.display()
        )),
        _ => None,
    }
}
