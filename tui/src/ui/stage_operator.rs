//! The operator a stage moved by hand (a manual y) is given under the UI. The UI owns the
//! terminal, so nothing here reads stdin: the scan's own prompts (move the y stage, change the
//! indenter) are the Scan screen's dialogs (`session`), and the Bench screen neither moves nor
//! polls a manual stage. A typed reading, which only the command line takes, is refused with what
//! to use instead.

use fringe_rig::{Operator, Prompt, Reply};
use std::io;

/// Answers a manual stage's questions under the UI.
pub struct UiStageOperator;

impl Operator for UiStageOperator {
    /// The stage asks only for typed readings; should anything else ask, nobody is there to say
    /// yes, so the answer is no.
    fn ask(&mut self, _prompt: &Prompt) -> Reply {
        Reply::Abort
    }

    fn answer(&mut self, question: &str) -> io::Result<Option<String>> {
        Err(io::Error::new(
            io::ErrorKind::Unsupported,
            format!(
                "the UI takes no typed readings (asked: {question}); a scan asks for the y stage on the Scan screen, and `fringe ystage --manual status` reads it from the command line"
            ),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn typed_readings_are_refused_saying_what_to_use() {
        let e = UiStageOperator
            .answer("type the current y reading")
            .expect_err("refused");
        assert_eq!(e.kind(), io::ErrorKind::Unsupported);
        assert!(e.to_string().contains("fringe ystage --manual"), "{e}");
    }
}
