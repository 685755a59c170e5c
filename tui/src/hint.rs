//! Which fringe command helps with an error. The libraries say what is wrong and which file or
//! device; only the front end knows its commands, so it adds them here, for the command line and
//! the terminal UI alike.

use fringe_app::workflow_error::WorkflowError;
use fringe_rig::store::StoreError;
use fringe_rig::CameraError;
use fringe_rig::PortOpenError;
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

/// A library error as the UI shows it: its text with the command that helps.
pub fn describe(e: impl Into<anyhow::Error>) -> String {
    let e = e.into();
    with_hint(e.to_string(), &e)
}

fn for_cause(e: &(dyn Error + 'static)) -> Option<String> {
    // A workflow passes a library's error on as it is: that error is the one that helps.
    if let Some(WorkflowError::Failed(inner)) = e.downcast_ref::<WorkflowError>() {
        return for_cause(inner.as_ref());
    }
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

#[cfg(test)]
mod tests {
    use super::*;
    use fringe_rig::{SerialLink, SerialSettings};
    use std::path::PathBuf;

    #[test]
    fn a_stopped_scan_is_resumed_and_a_wrong_directory_pointed_to_the_run_list() {
        let run = PathBuf::from("runs/2026-11-26-main");
        let stopped = ScanError::Store(StoreError::NotARun { dir: run.clone() }).stopped(&run);
        let e = anyhow::Error::from(stopped).context("the scan stopped");
        assert_eq!(
            for_error(&e).as_deref(),
            Some("fringe scan --resume runs/2026-11-26-main")
        );
        let missing = anyhow::Error::from(DatasetError::Store(StoreError::NotARun {
            dir: "runs".into(),
        }));
        let text = describe(missing);
        assert!(
            text.starts_with("runs is not a run") && text.contains("`fringe runs --root DIR`"),
            "{text}"
        );
        let plain = anyhow::anyhow!("something else");
        assert_eq!(for_error(&plain), None);
    }

    #[test]
    fn a_port_that_will_not_open_points_to_the_device_list() {
        let Err(e) = SerialLink::open("/dev/ttyFRINGE-ABSENT", &SerialSettings::plain(115_200))
        else {
            panic!("an absent port opened");
        };
        let e = anyhow::Error::from(e).context("axis x");
        let text = with_hint(format!("{e:#}"), &e);
        assert!(
            text.contains("/dev/ttyFRINGE-ABSENT")
                && text.contains("dialout")
                && text.ends_with("`fringe devices` lists the serial ports"),
            "{text}"
        );
    }
}
