//! The operator on the command line's terminal: questions on stderr, answers typed on stdin. A
//! stage moved by hand (`fringe ystage --manual`, a rig file's `y.driver = "manual"`) asks
//! through it; the scan's own prompts go through `scan::TerminalOperator`.

use fringe_rig::{Operator, Prompt, Reply};
use std::io::{self, BufRead, Write};

/// A prompt on a terminal: writes the question, reads one line.
pub struct TerminalPrompt<R, W> {
    input: R,
    output: W,
}

impl TerminalPrompt<io::BufReader<io::Stdin>, io::Stderr> {
    /// Questions on stderr, answers from stdin.
    pub fn stdio() -> Self {
        TerminalPrompt::new(io::BufReader::new(io::stdin()), io::stderr())
    }
}

impl<R: BufRead + Send, W: Write + Send> TerminalPrompt<R, W> {
    /// A prompt on any reader and writer.
    pub fn new(input: R, output: W) -> Self {
        TerminalPrompt { input, output }
    }

    fn line(&mut self, question: &str) -> io::Result<Option<String>> {
        write!(self.output, "{question} ")?;
        self.output.flush()?;
        let mut line = String::new();
        if self.input.read_line(&mut line)? == 0 {
            return Ok(None);
        }
        Ok(Some(line.trim().to_string()))
    }
}

impl<R: BufRead + Send, W: Write + Send> Operator for TerminalPrompt<R, W> {
    /// Enter continues, `a` (or the end of input) aborts.
    fn ask(&mut self, prompt: &Prompt) -> Reply {
        let question = format!("{} (Enter to continue, a to abort):", prompt.message());
        match self.line(&question) {
            Ok(Some(answer)) if !answer.eq_ignore_ascii_case("a") => Reply::Continue,
            _ => Reply::Abort,
        }
    }

    fn answer(&mut self, question: &str) -> io::Result<Option<String>> {
        self.line(question)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_lines_and_reports_end_of_input() {
        let mut out = Vec::new();
        {
            let mut p = TerminalPrompt::new(io::Cursor::new(b"  12.5 \n".to_vec()), &mut out);
            assert_eq!(p.answer("where?").expect("ask"), Some("12.5".to_string()));
            assert_eq!(p.answer("again?").expect("ask"), None);
        }
        assert_eq!(String::from_utf8(out).expect("utf8"), "where? again? ");
        let mut p = TerminalPrompt::new(io::Cursor::new(b"\na\n".to_vec()), io::sink());
        let prompt = Prompt::MoveY { y_mm: 1.0 };
        assert_eq!(p.ask(&prompt), Reply::Continue);
        assert_eq!(p.ask(&prompt), Reply::Abort);
        assert_eq!(p.ask(&prompt), Reply::Abort, "end of input");
    }
}
