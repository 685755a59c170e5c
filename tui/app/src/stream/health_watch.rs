//! The unit's health, watched with no bench: the figures of a health check that need no press
//! (`fringe check`'s optics and light), measured on frames the model calls free of contact, and
//! the force the model reads on them (the stream's no-contact baseline). A drift is said once,
//! as a warning, with what to do; the stream goes on.
//!
//! The worker hands a free frame at most every [`SAMPLE_EVERY`]; every [`MEASURE_EVERY`], once
//! [`FRAMES`] have come, their signature (`fringe_calibration::health::Signature`, the one
//! measurement a check makes) is set against the unit's profile (optical centre) and against
//! the stream's first measurement (brightness), with the thresholds of `fringe check`.

use crate::health::figures::Thresholds;
use fringe_calibration::health::Signature;
use fringe_calibration::{GreyImage, Profile};
use fringe_rig::Frame;
use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// A free frame kept at most this often.
pub(crate) const SAMPLE_EVERY: Duration = Duration::from_millis(250);
/// The figures are measured this often.
pub(crate) const MEASURE_EVERY: Duration = Duration::from_secs(30);
/// Free frames a measurement averages (as a check's signature): the last 6 s of free frames.
pub(crate) const FRAMES: usize = 24;
/// A frame counts as free when the model gives no contact at least this probability.
pub(crate) const FREE_CONFIDENCE: f64 = 0.95;

/// The latest health figures of a stream.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StreamHealth {
    /// Optical centre minus the profile's, px.
    pub centre_shift_px: [f64; 2],
    /// The shift that counts as moved, px.
    pub centre_limit_px: f64,
    /// Brightness against the stream's first measurement.
    pub brightness_ratio: f64,
    /// The median Fz the model reads on the free frames, N.
    pub free_fz_n: f64,
    /// Seconds since the stream started.
    pub at_s: f64,
}

/// What the watch tells the stream.
pub(crate) enum Said {
    Figures(StreamHealth),
    Warning(String),
}

/// A free frame and the normal force the model read on it.
pub(crate) struct FreeFrame {
    pub frame: Frame,
    pub fz_n: f64,
}

/// The watch's thread.
pub(crate) struct HealthWatch {
    tx: crossbeam_channel::Sender<FreeFrame>,
    thread: Option<JoinHandle<()>>,
    last_sent: Option<Instant>,
}

/// A frame as grey values: the optics' measurements read grey.
fn grey(frame: &Frame) -> Option<GreyImage> {
    let image = fringe_rig::store::pixels_to_image(
        frame.width,
        frame.height,
        frame.format,
        frame.data.clone(),
    )?;
    Some(GreyImage::from_image(&image))
}

impl HealthWatch {
    /// Starts the watch of the unit calibrated as `profile`; its figures and warnings go to
    /// `say`.
    pub(crate) fn start(
        profile: Profile,
        say: Box<dyn Fn(Said) + Send>,
        stop: Arc<AtomicBool>,
        started: Instant,
    ) -> std::io::Result<HealthWatch> {
        let (tx, rx) = crossbeam_channel::bounded::<FreeFrame>(2);
        let thread = std::thread::Builder::new()
            .name("stream-health".into())
            .spawn(move || {
                let t = Thresholds::default();
                let mut frames: VecDeque<GreyImage> = VecDeque::new();
                let mut fz: VecDeque<f64> = VecDeque::new();
                let mut first_brightness: Option<f64> = None;
                let mut measured = Instant::now();
                let mut warned = (false, false, false);
                while !stop.load(Ordering::Relaxed) {
                    let Ok(free) = rx.recv_timeout(Duration::from_millis(200)) else {
                        continue;
                    };
                    let Some(g) = grey(&free.frame) else {
                        continue;
                    };
                    frames.push_back(g);
                    fz.push_back(free.fz_n);
                    while frames.len() > FRAMES {
                        frames.pop_front();
                        fz.pop_front();
                    }
                    let due = first_brightness.is_none() || measured.elapsed() >= MEASURE_EVERY;
                    if frames.len() < FRAMES || !due {
                        continue;
                    }
                    measured = Instant::now();
                    let all: Vec<GreyImage> = frames.iter().cloned().collect();
                    let sig = match Signature::of_frames("stream".into(), &all) {
                        Ok(s) => s,
                        Err(e) => {
                            say(Said::Warning(format!(
                                "health watch: the disc was not found on frames the model calls free ({e})"
                            )));
                            continue;
                        }
                    };
                    let brightness = sig.brightness_dn;
                    let first = *first_brightness.get_or_insert(brightness);
                    let o = &profile.optical;
                    let shift = [sig.fit.centre_x - o.centre_x_px, sig.fit.centre_y - o.centre_y_px];
                    let sigma = sig.fit.sigma_x.hypot(sig.fit.sigma_y).hypot(o.sigma_x_px.hypot(o.sigma_y_px));
                    let limit = (5.0 * sigma).max(t.centre_share * o.radius_px);
                    let mut sorted: Vec<f64> = fz.iter().copied().collect();
                    sorted.sort_by(f64::total_cmp);
                    let free_fz = sorted[sorted.len() / 2];
                    let health = StreamHealth {
                        centre_shift_px: shift,
                        centre_limit_px: limit,
                        brightness_ratio: brightness / first.max(1e-9),
                        free_fz_n: free_fz,
                        at_s: started.elapsed().as_secs_f64(),
                    };
                    say(Said::Figures(health));
                    if shift[0].hypot(shift[1]) > limit && !warned.0 {
                        warned.0 = true;
                        say(Said::Warning(format!(
                            "the optical centre is ({:+.1}, {:+.1}) px from the unit's profile (more than {limit:.1} px): the camera or the disc moved, and contact points are off by as much; calibrate the unit again (`fringe calibrate`) or check it (`fringe check`)",
                            shift[0], shift[1]
                        )));
                    }
                    let ratio = health.brightness_ratio;
                    if !(t.dimmer..=t.brighter).contains(&ratio) && !warned.1 {
                        warned.1 = true;
                        say(Said::Warning(format!(
                            "the light changed: the disc is {:.0} % as bright as when the stream started; forces read from the fringes drift with it: check the LED ring and its supply (`fringe check`)",
                            100.0 * ratio
                        )));
                    }
                    if free_fz.abs() > t.force_offset_n && !warned.2 {
                        warned.2 = true;
                        say(Said::Warning(format!(
                            "on frames it calls free of contact the model reads Fz {free_fz:+.3} N (median of the last {}): its no-contact baseline moved; check the unit (`fringe check`)",
                            fz.len()
                        )));
                    }
                }
            })?;
        Ok(HealthWatch {
            tx,
            thread: Some(thread),
            last_sent: None,
        })
    }

    /// Offers a frame the model called free, read as `fz_n` (kept at most every
    /// [`SAMPLE_EVERY`]; never waits).
    pub(crate) fn offer(&mut self, frame: &Frame, fz_n: f64) {
        if self.last_sent.is_some_and(|t| t.elapsed() < SAMPLE_EVERY) {
            return;
        }
        if self
            .tx
            .try_send(FreeFrame {
                frame: frame.clone(),
                fz_n,
            })
            .is_ok()
        {
            self.last_sent = Some(Instant::now());
        }
    }

    /// Waits for the thread (after the stream's stop flag is set).
    pub(crate) fn join(&mut self) {
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}
