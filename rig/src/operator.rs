//! The person at the bench, reached through the front end (the terminal, the UI, a script): the
//! [`Operator`] a scan asks to change indenters, move a manual stage and agree to resume after a
//! watcher stopped it, and that a device moved by hand (`crate::manual`) asks for its reading.
//! The scan and the drivers both use it; it depends on neither.

/// The operator's answer to a prompt.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reply {
    Continue,
    Abort,
}

/// Why the scan asks the operator.
#[derive(Debug, Clone, PartialEq)]
pub enum Prompt {
    /// Mount another indenter.
    ChangeIndenter { shape: String },
    /// Move the manual y stage to this position.
    MoveY { y_mm: f64 },
    /// The scan is paused (by request or by a watcher whose condition has cleared): resume?
    Resume { reason: String },
}

impl Prompt {
    pub fn message(&self) -> String {
        match self {
            Prompt::ChangeIndenter { shape } => {
                format!("mount the {shape} indenter, then continue")
            }
            Prompt::MoveY { y_mm } => format!("move the y stage to {y_mm:.3} mm, then continue"),
            Prompt::Resume { reason } => format!("scan paused ({reason}): resume?"),
        }
    }
}

/// The person at the bench, reached through the front end (the terminal, the UI, a script).
pub trait Operator: Send {
    /// Asks the operator to do something and say when it is done (or to abort).
    fn ask(&mut self, prompt: &Prompt) -> Reply;

    /// Asks a question the operator answers by typing a line (a stage moved by hand asks for
    /// its reading, or for Enter once it is in place): the line, or `None` when the operator
    /// cancelled (end of input). The default, for a front end that takes no typed answers,
    /// refuses with an error of kind [`std::io::ErrorKind::Unsupported`].
    fn answer(&mut self, question: &str) -> std::io::Result<Option<String>> {
        Err(std::io::Error::new(
            std::io::ErrorKind::Unsupported,
            format!("this front end takes no typed answers (asked: {question})"),
        ))
    }
}
