//! The manual y stage with a scripted operator (the engine's `Operator`, typed answers).

use fringe_rig::ManualStage;
use fringe_rig::Millimetres;
use fringe_rig::{Axis, AxisError, SoftLimits};
use fringe_rig::{Operator, Prompt, Reply};
use std::collections::VecDeque;
use std::io;
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// Answers from a script; records the questions.
struct Scripted {
    answers: VecDeque<&'static str>,
    asked: Arc<Mutex<Vec<String>>>,
}

impl Operator for Scripted {
    fn ask(&mut self, prompt: &Prompt) -> Reply {
        panic!("the stage asks for typed answers only, not {prompt:?}")
    }

    fn answer(&mut self, question: &str) -> io::Result<Option<String>> {
        self.asked.lock().expect("lock").push(question.to_string());
        Ok(self.answers.pop_front().map(str::to_string))
    }
}

fn stage(answers: &[&'static str]) -> (ManualStage, Arc<Mutex<Vec<String>>>) {
    let asked = Arc::new(Mutex::new(Vec::new()));
    let prompt = Scripted {
        answers: answers.iter().copied().collect(),
        asked: asked.clone(),
    };
    let limits = SoftLimits {
        min: Millimetres(0.0),
        max: Millimetres(25.0),
    };
    (ManualStage::new("y", Box::new(prompt), Some(limits)), asked)
}

#[test]
fn operator_moves_and_confirms() {
    // home: reading 3.2; move to 10: Enter; move by +2: typed reading 12.05.
    let (mut y, asked) = stage(&["3.2", "", "12.05 mm"]);
    let s = y.home(Duration::from_secs(1)).expect("home");
    assert_eq!(s.position, Millimetres(3.2));
    assert!(s.homed);
    assert_eq!(
        y.move_to(Millimetres(10.0), Duration::from_secs(1))
            .expect("move")
            .position,
        Millimetres(10.0)
    );
    assert_eq!(
        y.move_by(Millimetres(2.0), Duration::from_secs(1))
            .expect("move")
            .position,
        Millimetres(12.05)
    );
    let asked = asked.lock().expect("lock").clone();
    assert_eq!(asked.len(), 3);
    assert!(
        asked[0].contains("type the current y reading"),
        "{}",
        asked[0]
    );
    assert!(
        asked[1].starts_with("move y to 10.000 mm and press Enter"),
        "{}",
        asked[1]
    );
    assert!(asked[2].starts_with("move y to 12.000 mm"), "{}", asked[2]);
}

#[test]
fn unknown_position_is_asked_for_and_bad_answers_are_asked_again() {
    let (mut y, asked) = stage(&["abc", "4.5"]);
    assert_eq!(y.status().expect("status").position, Millimetres(4.5));
    assert!(asked.lock().expect("lock")[1].contains("\"abc\" is not a number"));
    // Known now: no further question.
    assert_eq!(y.status().expect("status").position, Millimetres(4.5));
    assert_eq!(asked.lock().expect("lock").len(), 2);
}

#[test]
fn limits_and_cancel() {
    let (mut y, asked) = stage(&["q"]);
    assert!(matches!(
        y.begin_move_to(Millimetres(30.0)),
        Err(AxisError::SoftLimit { .. })
    ));
    assert!(
        asked.lock().expect("lock").is_empty(),
        "nothing asked for a move outside the limits"
    );
    assert!(matches!(
        y.begin_move_to(Millimetres(5.0)),
        Err(AxisError::Cancelled { .. })
    ));
    // End of input cancels too.
    assert!(matches!(
        y.begin_move_to(Millimetres(5.0)),
        Err(AxisError::Cancelled { .. })
    ));
}

#[test]
fn readings_outside_the_limits_are_asked_again_and_nan_targets_refused() {
    let (mut y, asked) = stage(&["1e308", "-3", "7.25"]);
    assert_eq!(y.status().expect("status").position, Millimetres(7.25));
    let asked = asked.lock().expect("lock").clone();
    assert_eq!(asked.len(), 3, "{asked:?}");
    assert!(
        asked[1].starts_with("100000000") && asked[1].contains("outside the soft limits"),
        "{}",
        asked[1]
    );
    assert!(asked[2].contains("-3 mm is outside"), "{}", asked[2]);
    // Without soft limits a nan target is still refused before anyone is asked.
    let quiet = Scripted {
        answers: VecDeque::new(),
        asked: Arc::new(Mutex::new(Vec::new())),
    };
    let seen = quiet.asked.clone();
    let mut free = ManualStage::new("y", Box::new(quiet), None);
    assert!(matches!(
        free.begin_move_to(Millimetres(f64::NAN)),
        Err(AxisError::NotANumber { .. })
    ));
    assert!(seen.lock().expect("lock").is_empty());
}
