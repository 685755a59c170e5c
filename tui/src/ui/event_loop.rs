//! The event loop: keys from the terminal, what the scan and the screens' threads published, a
//! redraw at most every [`FRAME`]. The terminal is restored on quit, on error, on the UI
//! thread's panic (ratatui's hook) and on SIGTERM / SIGHUP; a worker thread's panic is shown in
//! the UI and stops the scan, the terminal kept raw ([`worker_panics`]).

use super::app::{App, UiOptions};
use super::keys;
use super::screen::Screen;
use super::screens;
use super::view;
use super::worker_panics;
use crate::signals::{self, Again, Signal};
use crossbeam_channel::{Receiver, RecvTimeoutError};
use fringe_rig::Plan;
use ratatui::crossterm::event::{self, Event as TermEvent, KeyEventKind};
use ratatui::DefaultTerminal;
use std::io::Write;
use std::time::{Duration, Instant};

/// The longest time between redraws while something moves (30 fps).
const FRAME: Duration = Duration::from_millis(33);

/// Runs the UI until the user quits. Errors that stop the UI are returned after the terminal
/// is restored, so they are printed on the normal screen.
pub fn run(opts: UiOptions) -> anyhow::Result<()> {
    let plan = Plan::parse(&opts.plan_text, &opts.plan_origin)?;
    let limits = opts.config.limits()?;
    let program = plan.program(&limits, &opts.plan_origin)?;
    signals::catch(&[Signal::Terminate, Signal::HangUp], Again::Counts);
    let mut app = App::new(opts, &program, &limits);
    let mut screens: Vec<Box<dyn Screen>> = screens::ALL.iter().map(|s| (s.open)(&app)).collect();
    let mut terminal = ratatui::init();
    // After ratatui's hook, which it keeps for the UI thread's own panics.
    let panics = worker_panics::install();
    let result = run_loop(&mut app, &mut screens, &mut terminal);
    // A terminal that hung up cannot be restored; nothing is printed about it (stderr is that
    // terminal too).
    let _ = ratatui::try_restore();
    drop(panics);
    // A scan still running is stopped and waited for, so z retracts and the run is closed:
    // as aborted when the operator quit, as interrupted (resumable) when the terminal hung up
    // or the process was told to end.
    let interrupted = signals::stop_requested() || result.is_err();
    app.stop_scan(interrupted);
    app.close_bench();
    app.stop_stream();
    // Where this session's runs went, on the normal screen.
    let mut out = std::io::stdout();
    match app.ended.len() {
        0 => {
            let _ = writeln!(out, "fringe: no scan was run in this session");
        }
        n => {
            let _ = writeln!(
                out,
                "fringe: {n} scan{} in this session:",
                if n == 1 { "" } else { "s" }
            );
            for line in &app.ended {
                let _ = writeln!(out, "  {line}");
            }
        }
    }
    for lines in &app.streamed {
        let _ = writeln!(out, "fringe: a stream in this session:");
        for line in lines {
            let _ = writeln!(out, "  {line}");
        }
    }
    // A worker that failed while the UI ran is said again on the normal screen, and the exit
    // status says it.
    app.worker_failures.extend(worker_panics::take());
    for failure in &app.worker_failures {
        let _ = writeln!(std::io::stderr(), "fringe: while the UI ran, {failure}");
    }
    result?;
    if !app.worker_failures.is_empty() {
        anyhow::bail!(
            "a worker thread of the UI failed: a defect in fringe; please report it with the \
             lines above"
        );
    }
    Ok(())
}

/// Terminal events read on their own thread: the loop below never blocks in a read, so it sees
/// SIGTERM / SIGHUP within one frame even when the terminal has hung up under a read.
fn input_thread() -> anyhow::Result<Receiver<std::io::Result<TermEvent>>> {
    let (tx, rx) = crossbeam_channel::bounded(64);
    std::thread::Builder::new()
        .name("terminal-input".into())
        .spawn(move || loop {
            let e = event::read();
            let failed = e.is_err();
            if tx.send(e).is_err() || failed {
                return;
            }
        })?;
    Ok(rx)
}

fn run_loop(
    app: &mut App,
    screens: &mut [Box<dyn Screen>],
    terminal: &mut DefaultTerminal,
) -> anyhow::Result<()> {
    let input = input_thread()?;
    app.refresh_runs();
    if app.opts.start {
        screens::scan::run(app);
    }
    let mut last_draw = Instant::now() - FRAME;
    let mut dirty = true;
    while !app.quit {
        if signals::stop_requested() {
            break;
        }
        match input.recv_timeout(wait(dirty, last_draw.elapsed())) {
            Ok(Ok(TermEvent::Key(k))) if k.kind != KeyEventKind::Release => {
                keys::dispatch(app, screens, k.code, k.modifiers);
                dirty = true;
            }
            Ok(Ok(TermEvent::Resize(..))) => dirty = true,
            Ok(Ok(_)) | Err(RecvTimeoutError::Timeout) => {}
            // The terminal is gone (hung up) or unreadable: stop, aborting any scan.
            Ok(Err(e)) => return Err(anyhow::anyhow!("reading the terminal: {e}")),
            Err(RecvTimeoutError::Disconnected) => break,
        }
        for failure in worker_panics::take() {
            app.worker_failed(failure);
            dirty = true;
        }
        dirty |= tick(app, screens);
        let (changed, ends) = app.pump();
        dirty |= changed;
        for end in &ends {
            for s in screens.iter_mut() {
                s.scan_ended(app, end);
            }
        }
        if dirty && last_draw.elapsed() >= FRAME || last_draw.elapsed() >= 4 * FRAME {
            terminal.draw(|f| view::draw(f, &app.state))?;
            last_draw = Instant::now();
            dirty = false;
        }
    }
    Ok(())
}

/// How long the loop waits for a key before it looks at what the scan and the screens'
/// threads published: until the next redraw is due while something changed, else one
/// [`FRAME`]. Never zero with nothing to draw: a loop that polled without waiting between
/// redraws kept a core busy (the camera beside it dropped frames and paused the scan).
fn wait(dirty: bool, since_draw: Duration) -> Duration {
    if dirty {
        FRAME.saturating_sub(since_draw)
    } else {
        FRAME
    }
}

/// The screens take what their threads published (the Bench screen first opens or closes the
/// bench as it is shown or not).
fn tick(app: &mut App, screens: &mut [Box<dyn Screen>]) -> bool {
    let shown = screens::index(app.state.tab);
    let mut changed = false;
    for (i, s) in screens.iter_mut().enumerate() {
        changed |= s.tick(app, i == shown);
    }
    changed
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn with_nothing_to_draw_the_loop_waits_a_frame_however_long_since_the_last_redraw() {
        for since in [0, 10, 33, 50, 100, 1000] {
            assert_eq!(wait(false, Duration::from_millis(since)), FRAME);
        }
    }

    #[test]
    fn with_something_to_draw_the_loop_waits_until_the_next_redraw_is_due() {
        assert_eq!(
            wait(true, Duration::from_millis(13)),
            Duration::from_millis(20)
        );
        assert_eq!(wait(true, Duration::from_millis(40)), Duration::ZERO);
    }
}
