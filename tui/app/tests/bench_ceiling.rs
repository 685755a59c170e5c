//! The Bench screen's session on the simulated bench, driven as an operator drives it: z jogged
//! into the gel in 5 mm steps (the biggest step the screen offers) must never take the force
//! more than 1 N past the ceiling, and a retract must always go, over the ceiling or not.

use fringe_app::session::{AxisId, BenchCommand, BenchPhase, BenchSession, BenchState};
use fringe_app::RigConfig;
use fringe_rig::Millimetres;
use fringe_rig::{Operator, Prompt, Reply};
use std::time::{Duration, Instant};

/// The default simulated bench with small frames (the camera is not under test).
const RIG: &str = r#"
name = "bench ceiling test"
[force]
max_force = 12.0
[sim]
seed = 11
image_scale = 0.25
"#;

/// No one at a simulated bench: nothing is moved by hand there.
struct Nobody;

impl Operator for Nobody {
    fn ask(&mut self, _prompt: &Prompt) -> Reply {
        Reply::Abort
    }
}

fn wait_for(
    bench: &BenchSession,
    what: &str,
    timeout: Duration,
    done: impl Fn(&BenchState) -> bool,
) -> BenchState {
    let t0 = Instant::now();
    loop {
        let s = bench.state();
        if let BenchPhase::Failed(why) = &s.phase {
            panic!("the bench failed while waiting for {what}: {why}");
        }
        if done(&s) {
            return s;
        }
        assert!(
            t0.elapsed() < timeout,
            "{what}: not within {timeout:?}; messages: {:?}",
            s.messages
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn z(s: &BenchState) -> f64 {
    s.axes[AxisId::Z.index()].position_mm.unwrap_or(f64::NAN)
}

/// Sends a z jog and waits until z has been idle at one position for half a second (a refused
/// jog never moves it); returns the state.
fn jog_z(bench: &BenchSession, by: f64) -> BenchState {
    bench.send(BenchCommand::Jog {
        axis: AxisId::Z,
        by: Millimetres(by),
    });
    std::thread::sleep(Duration::from_millis(300));
    let mut still_since: Option<(Instant, f64)> = None;
    let t0 = Instant::now();
    loop {
        let s = bench.state();
        let here = z(&s);
        let idle = !s.axes[AxisId::Z.index()].moving;
        still_since = match still_since {
            Some((t, at)) if idle && (at - here).abs() < 1e-6 => {
                if t.elapsed() > Duration::from_millis(500) {
                    return s;
                }
                Some((t, at))
            }
            _ if idle => Some((Instant::now(), here)),
            _ => None,
        };
        assert!(
            t0.elapsed() < Duration::from_secs(30),
            "z did not come to rest: {:?}",
            s.messages
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Tares the F/T and waits for it to be done (not refused).
fn tare(bench: &BenchSession) {
    bench.send(BenchCommand::Tare);
    let s = wait_for(bench, "the tare", Duration::from_secs(10), |s| {
        s.messages
            .iter()
            .any(|m| m.contains("tared") || m.contains(" is refused"))
    });
    assert!(
        s.messages.iter().any(|m| m.contains("F/T sensor tared")),
        "{:?}",
        s.messages
    );
}

#[test]
fn jogs_into_the_gel_stop_at_the_ceiling_and_a_retract_always_goes() {
    let config = RigConfig::parse(RIG, "bench ceiling test").expect("rig");
    let bench = BenchSession::open(config, 32, Box::new(Nobody)).expect("bench");
    wait_for(&bench, "the bench open", Duration::from_secs(60), |s| {
        s.phase == BenchPhase::Ready
    });
    // z homed first: the tare waits for the F/T's no-contact reading, taken with z at home.
    bench.send(BenchCommand::Home(AxisId::Z));
    wait_for(&bench, "z homed", Duration::from_secs(60), |s| {
        let a = &s.axes[AxisId::Z.index()];
        a.homed && !a.moving
    });
    tare(&bench);
    let ceiling = bench.state().force.max_n;
    assert_eq!(ceiling, 12.0);

    // Into the gel in 5 mm steps until the ceiling stops a jog, then twice more.
    let mut stopped_at = None;
    let mut after_stop = 0;
    for _ in 0..12 {
        let s = jog_z(&bench, 5.0);
        assert!(
            s.force.peak_n <= ceiling + 1.0,
            "the force reached {:.2} N, more than 1 N past the ceiling {ceiling} N, at z {:.3} mm; messages: {:?}",
            s.force.peak_n,
            z(&s),
            s.messages
        );
        if stopped_at.is_none() && s.messages.iter().any(|m| m.contains("over the ceiling")) {
            stopped_at = Some(z(&s));
        }
        if let Some(at) = stopped_at {
            // A further 5 mm jog into the sensor is refused while the force is over the
            // ceiling, or (the gel having relaxed under it) stopped again at the ceiling.
            eprintln!(
                "after the stop: z {:.3} mm, peak {:.2} N",
                z(&s),
                s.force.peak_n
            );
            assert!(
                z(&s) < at + 0.5,
                "z went from {at:.3} to {:.3} mm against the ceiling",
                z(&s)
            );
            after_stop += 1;
            if after_stop == 3 {
                break;
            }
        }
    }
    let Some(at) = stopped_at else {
        panic!("no jog reached the ceiling: {:?}", bench.state().messages);
    };
    // Pressed at the ceiling, a retract goes the whole way.
    let from = z(&bench.state());
    assert!(
        from >= at - 0.01,
        "z left {at:.3} mm for {from:.3} mm by itself"
    );
    let s = jog_z(&bench, -2.0);
    assert!(
        (z(&s) - (from - 2.0)).abs() < 0.01,
        "retract from {from:.3} mm ended at {:.3} mm: {:?}",
        z(&s),
        s.messages
    );
    bench.close();
}
