//! How a workflow (a commissioning, a health check) fails: refused before anything moves or
//! stopped with what to do, a step that failed (what it was, what to do, then why), or a
//! library's error as it said it. The chain of causes is kept whole, so a front end joins it
//! into one line and finds the command that helps in it.

/// Any error, boxed: a cause, or what a front end could not do for a workflow (a scan).
pub type BoxError = Box<dyn std::error::Error + Send + Sync>;

/// A workflow that could not go on.
#[derive(Debug, thiserror::Error)]
pub enum WorkflowError {
    /// Refused (an option, a base, a budget) or stopped, and what to do.
    #[error("{0}")]
    Refused(String),
    /// A step failed: what it was and what to do; its cause follows.
    #[error("{what}")]
    Step {
        what: String,
        #[source]
        source: BoxError,
    },
    /// A library's error, as it said it (its causes follow it; a front end that looks for a
    /// cause of a kind looks inside this one too).
    #[error(transparent)]
    Failed(BoxError),
}

impl WorkflowError {
    /// This error as the cause of a step described by `what`.
    pub(crate) fn context(self, what: String) -> WorkflowError {
        WorkflowError::Step {
            what,
            source: Box::new(self),
        }
    }
}

impl From<BoxError> for WorkflowError {
    fn from(e: BoxError) -> WorkflowError {
        WorkflowError::Failed(e)
    }
}

/// The libraries' errors a workflow passes on as they are.
macro_rules! failed_from {
    ($($t:ty),* $(,)?) => {
        $(impl From<$t> for WorkflowError {
            fn from(e: $t) -> WorkflowError {
                WorkflowError::Failed(Box::new(e))
            }
        })*
    };
}

failed_from!(
    std::io::Error,
    serde_json::Error,
    fringe_rig::ConfigError,
    crate::commission::journal::JournalError,
    crate::commission::certificate::CertificateError,
    crate::commission::press_choice::DiscError,
    crate::commission::press_plan::PressPlanError,
    crate::models::choice::ChoiceError,
    crate::models::adapted_card::AdaptedWriteError,
    fringe_sensor_models::ModelError,
    fringe_sensor_models::SpecError,
    fringe_sensor_models::adapt::AdaptError,
    fringe_sensor_models::dataset::DatasetError,
    fringe_sensor_models::eval::EvalError,
    fringe_sensor_models::report::ReportError,
    fringe_sensor_models::ModelFileError,
    fringe_calibration::ProfileError,
    fringe_rig::store::StoreError,
    crate::session::calibration_scan::CalibrationPlanError,
    crate::session::disc_cutout::RecordingError,
    crate::session::calibration_scan::CalibrationRunError,
    crate::health::check_plan::CheckPlanError,
    crate::health::history::HistoryError,
    fringe_calibration::ScanRunError,
    fringe_calibration::health::SignatureError,
    fringe_calibration::health::ChangeError,
);

#[cfg(feature = "torch")]
failed_from!(fringe_sensor_models::FineTuneError);

/// A step's description put before an error (as `anyhow::Context` does, with the same text).
pub(crate) trait Context<T> {
    fn context(self, what: &str) -> Result<T, WorkflowError>;
    fn with_context(self, what: impl FnOnce() -> String) -> Result<T, WorkflowError>;
}

impl<T, E: Into<BoxError>> Context<T> for Result<T, E> {
    fn context(self, what: &str) -> Result<T, WorkflowError> {
        self.with_context(|| what.to_string())
    }

    fn with_context(self, what: impl FnOnce() -> String) -> Result<T, WorkflowError> {
        self.map_err(|e| WorkflowError::Step {
            what: what(),
            source: e.into(),
        })
    }
}

/// Refuses with `format!`'s text (as `anyhow::bail!` did).
macro_rules! refuse {
    ($($arg:tt)*) => {
        return Err($crate::workflow_error::WorkflowError::Refused(format!($($arg)*)))
    };
}
pub(crate) use refuse;
