//! Streaming an F/T sensor into a CSV file, for the bring-up commands (`fringe ft stream`,
//! `fringe daq stream`): one writer of the rows and one loop, whatever the interface; the
//! [`Interface`] chooses the columns and the words of the errors.

use crate::bringup::error::BringupError;
use crate::bringup::interface::Interface;
use fringe_rig::Hertz;
use fringe_rig::HostTime;
use fringe_rig::{ForceSample, ForceSensor, StreamStats};
use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::Path;
use std::time::{Duration, Instant};

/// How long the stream may stay silent before the command stops.
pub(crate) const STALL: Duration = Duration::from_secs(1);

/// The CSV columns of a Net F/T: host time, the RDT and F/T sequences, the force and torque.
pub(crate) const NETFT_COLUMNS: &str =
    "host_time_s,rdt_sequence,ft_sequence,fx_n,fy_n,fz_n,tx_nm,ty_nm,tz_nm";

/// The CSV columns of a DAQ: `fringe ft stream`'s host time and force columns, the DAQ's sample
/// index in place of the Net F/T's sequences (and the strobe when one is read).
pub(crate) const DAQ_COLUMNS: &str = "host_time_s,sample_index,fx_n,fy_n,fz_n,tx_nm,ty_nm,tz_nm";

/// Writes an F/T sensor's samples as CSV rows under a header.
pub(crate) struct ForceCsv<W: Write> {
    out: W,
    interface: Interface,
}

impl<W: Write> ForceCsv<W> {
    /// Writes the header of `interface`'s columns (a DAQ's with `strobe` adds `strobe_v`).
    pub(crate) fn new(mut out: W, interface: Interface) -> io::Result<ForceCsv<W>> {
        match interface {
            Interface::NetFt => writeln!(out, "{NETFT_COLUMNS}")?,
            Interface::Daq { strobe } => writeln!(
                out,
                "{DAQ_COLUMNS}{}",
                if strobe { ",strobe_v" } else { "" }
            )?,
        }
        Ok(ForceCsv { out, interface })
    }

    /// One sample: host time (s), the sequence columns (a Net F/T's RDT and F/T sequences, a
    /// DAQ's sample index), Fx Fy Fz (N), Tx Ty Tz (N m) and a DAQ's strobe (V).
    pub(crate) fn row(&mut self, s: &ForceSample) -> io::Result<()> {
        write!(self.out, "{:.6},", s.host_time.seconds())?;
        match self.interface {
            Interface::NetFt => write!(
                self.out,
                "{},{}",
                s.transport_seq.unwrap_or(0),
                s.device_tick
            )?,
            Interface::Daq { .. } => write!(self.out, "{}", s.device_tick)?,
        }
        for v in s.wrench.to_array() {
            write!(self.out, ",{v}")?;
        }
        if let Interface::Daq { strobe: true } = self.interface {
            match s.strobe {
                Some(v) => write!(self.out, ",{}", v.0)?,
                None => write!(self.out, ",")?,
            }
        }
        writeln!(self.out)
    }

    pub(crate) fn flush(&mut self) -> io::Result<()> {
        self.out.flush()
    }

    #[cfg(test)]
    pub(crate) fn into_inner(self) -> W {
        self.out
    }
}

/// What a stream recorded.
#[derive(Debug)]
pub struct StreamReport {
    /// Samples written to the CSV file.
    pub samples: u64,
    /// From the first sample asked for to the end of the stream.
    pub elapsed: Duration,
    /// The host times of the first and the last sample.
    pub first: Option<HostTime>,
    pub last: Option<HostTime>,
    /// The sensor's counters (lost packets or samples, records out of order).
    pub stats: StreamStats,
    /// How the stream ended: the duration over, or why it stopped early.
    pub ended: Result<(), BringupError>,
}

impl StreamReport {
    /// Samples the elapsed time gives at the scan rate `rate`.
    pub fn expected(&self, rate: Hertz) -> u64 {
        (self.elapsed.as_secs_f64() * rate.0).round() as u64
    }

    /// The samples' rate from the first to the last, Hz (0 with fewer than two).
    pub fn rate(&self) -> f64 {
        let span = match (self.first, self.last) {
            (Some(a), Some(b)) => b.since(a).as_secs_f64(),
            _ => 0.0,
        };
        if self.samples > 1 && span > 0.0 {
            (self.samples - 1) as f64 / span
        } else {
            0.0
        }
    }
}

/// Streams `sensor` into the CSV file `csv` for `duration` (after taking a bias when `bias`),
/// calling `progress` about once a second with the samples so far and the time; a silence of
/// `STALL` ends it with an error. A file this call created and would leave with only its
/// header is removed again (never a device such as /dev/null, nor a file that was there before).
pub fn stream_to_csv<S: ForceSensor + ?Sized>(
    sensor: &mut S,
    interface: Interface,
    duration: Duration,
    csv: &Path,
    bias: bool,
    progress: &mut dyn FnMut(u64, Duration),
) -> Result<StreamReport, BringupError> {
    let created = !csv.exists();
    let discard_empty = || {
        if created && csv.metadata().is_ok_and(|m| m.is_file()) {
            let _ = std::fs::remove_file(csv);
        }
    };
    let write_err = |source| BringupError::Write {
        path: csv.to_path_buf(),
        source,
    };
    let file = File::create(csv).map_err(|source| BringupError::Create {
        interface,
        path: csv.to_path_buf(),
        source,
    })?;
    let mut out = ForceCsv::new(BufWriter::new(file), interface).map_err(write_err)?;
    let started = sensor
        .start()
        .and_then(|()| if bias { sensor.bias() } else { Ok(()) });
    if let Err(e) = started {
        let _ = sensor.stop();
        drop(out);
        discard_empty();
        return Err(e.into());
    }
    let begun = Instant::now();
    let mut samples = 0u64;
    let (mut first, mut last) = (None, None);
    let mut last_arrival = Instant::now();
    let mut next_progress = Duration::from_secs(1);
    let ended = loop {
        let elapsed = begun.elapsed();
        if elapsed >= duration {
            break Ok(());
        }
        if elapsed >= next_progress {
            progress(samples, elapsed);
            next_progress += Duration::from_secs(1);
        }
        match sensor.next_sample(Duration::from_millis(50)) {
            Ok(Some(s)) => {
                if let Err(e) = out.row(&s) {
                    break Err(write_err(e));
                }
                samples += 1;
                first.get_or_insert(s.host_time);
                last = Some(s.host_time);
                last_arrival = Instant::now();
            }
            Ok(None) if last_arrival.elapsed() >= STALL => {
                break Err(BringupError::Stalled {
                    interface,
                    device: sensor.describe(),
                    waited: STALL,
                })
            }
            Ok(None) => {}
            Err(e) => break Err(e.into()),
        }
    };
    let elapsed = begun.elapsed();
    let stopped = sensor.stop();
    let flushed = out.flush().map_err(write_err);
    drop(out);
    let ended = ended.and(flushed);
    let ended = match ended {
        Ok(()) if samples == 0 => Err(BringupError::NoSamples {
            interface,
            device: sensor.describe(),
            // `fringe ft` has always said the time it was asked to stream.
            waited: match interface {
                Interface::NetFt => duration,
                Interface::Daq { .. } => elapsed,
            },
            path: csv.to_path_buf(),
        }),
        Ok(()) => stopped.map_err(BringupError::from),
        Err(e) => Err(e),
    };
    if samples == 0 {
        // A CSV of only the header would pass for a recording; leave nothing instead.
        discard_empty();
    }
    Ok(StreamReport {
        samples,
        elapsed,
        first,
        last,
        stats: sensor.stats(),
        ended,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use fringe_rig::atical::{CalibratedSensor, Calibration, GaugeReading, GaugeSource};
    use fringe_rig::ForceError;
    use fringe_rig::{Volts, Wrench};

    fn sample(tick: u64, strobe: Option<f64>) -> ForceSample {
        ForceSample {
            device_tick: tick,
            transport_seq: None,
            host_time: HostTime(1_500_000_000),
            wrench: Wrench::from_array([1.5, -2.0, 10.25, 0.125, 0.0, -0.5]),
            status: 0,
            strobe: strobe.map(Volts),
        }
    }

    #[test]
    fn the_csv_has_ft_streams_force_columns_the_sample_index_and_the_strobe() {
        let mut csv = ForceCsv::new(Vec::new(), Interface::Daq { strobe: true }).expect("header");
        csv.row(&sample(41, Some(4.75))).expect("row");
        csv.row(&sample(42, None)).expect("row");
        let text = String::from_utf8(csv.into_inner()).expect("utf-8");
        assert_eq!(
            text,
            "host_time_s,sample_index,fx_n,fy_n,fz_n,tx_nm,ty_nm,tz_nm,strobe_v\n\
             1.500000,41,1.5,-2,10.25,0.125,0,-0.5,4.75\n\
             1.500000,42,1.5,-2,10.25,0.125,0,-0.5,\n"
        );
        let mut csv = ForceCsv::new(Vec::new(), Interface::Daq { strobe: false }).expect("header");
        csv.row(&sample(7, Some(1.0))).expect("row");
        let text = String::from_utf8(csv.into_inner()).expect("utf-8");
        assert_eq!(
            text,
            "host_time_s,sample_index,fx_n,fy_n,fz_n,tx_nm,ty_nm,tz_nm\n1.500000,7,1.5,-2,10.25,0.125,0,-0.5\n"
        );
    }

    /// Scans at 1 kHz in 10 ms blocks, paced in real time, with constant gauge volts; then
    /// silence.
    struct Paced {
        started: Option<Instant>,
        next: u64,
        scans: u64,
    }

    impl GaugeSource for Paced {
        fn describe(&self) -> String {
            "paced DAQ".into()
        }
        fn start(&mut self) -> Result<(), ForceError> {
            self.started = Some(Instant::now());
            Ok(())
        }
        fn next_reading(&mut self, timeout: Duration) -> Result<Option<GaugeReading>, ForceError> {
            let Some(t0) = self.started else {
                return Err(ForceError::Device {
                    device: self.describe(),
                    message: "not started".into(),
                });
            };
            let due = t0 + Duration::from_millis(self.next / 10 * 10 + 10);
            if self.next >= self.scans || due > Instant::now() + timeout {
                std::thread::sleep(timeout);
                return Ok(None);
            }
            std::thread::sleep(due.saturating_duration_since(Instant::now()));
            let r = GaugeReading {
                index: self.next,
                host_time: HostTime::from_instant(due),
                gauges: [Volts(0.5); 6],
                strobe: None,
                lost_before: 0,
            };
            self.next += 1;
            Ok(Some(r))
        }
        fn stop(&mut self) -> Result<(), ForceError> {
            Ok(())
        }
    }

    fn calibration() -> Calibration {
        Calibration::parse(
            include_str!("../../../../tests/data/mini40-v1.1.cal"),
            "mini40-v1.1.cal",
        )
        .expect("the Mini40 .cal parses")
    }

    #[test]
    fn a_stream_counts_samples_against_the_elapsed_time_and_a_bias_zeroes_the_rows() {
        let dir = std::env::temp_dir().join(format!("fringe-daq-bringup-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("scratch");
        let csv = dir.join("daq.csv");
        let source = Paced {
            started: None,
            next: 0,
            scans: u64::MAX,
        };
        let mut sensor = CalibratedSensor::new(source, calibration()).with_bias_scans(20);
        let mut ticks = 0;
        let report = stream_to_csv(
            &mut sensor,
            Interface::Daq { strobe: false },
            Duration::from_millis(1500),
            &csv,
            true,
            &mut |_, _| ticks += 1,
        )
        .expect("streams");
        report.ended.as_ref().expect("ran its time");
        assert_eq!(ticks, 1, "progress once a second");
        let expected = report.expected(Hertz(1000.0)) as f64;
        assert!(
            (report.samples as f64 - expected).abs() <= 0.03 * expected,
            "{} samples, {expected} expected",
            report.samples
        );
        let text = std::fs::read_to_string(&csv).expect("csv");
        let rows: Vec<&str> = text.lines().skip(1).collect();
        assert_eq!(rows.len() as u64, report.samples);
        // Constant volts after a bias: every force is zero.
        assert!(rows[0].ends_with(",0,0,0,0,0,0"), "{}", rows[0]);

        // The source falls silent after 300 scans: the stream stops within the stall time.
        let mut silent = CalibratedSensor::new(
            Paced {
                started: None,
                next: 0,
                scans: 300,
            },
            calibration(),
        );
        let t0 = Instant::now();
        let report = stream_to_csv(
            &mut silent,
            Interface::Daq { strobe: false },
            Duration::from_secs(10),
            &csv,
            false,
            &mut |_, _| {},
        )
        .expect("streams");
        let e = report.ended.expect_err("stalled").to_string();
        assert!(e.contains("no sample for 1 s"), "{e}");
        assert_eq!(report.samples, 300);
        assert!(t0.elapsed() < Duration::from_secs(3), "{:?}", t0.elapsed());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
