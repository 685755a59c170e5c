//! Bringing up an NI-DAQmx force path (`fringe daq`): streaming calibrated samples into a CSV
//! file, counting what arrived against what the elapsed time gives, and taking a bias. The
//! command parses its flags into a [`DaqSpec`](crate::rig::force::nidaqmx::DaqSpec), opens it with
//! [`open_daq`](crate::rig::force::nidaqmx::open_daq) and prints what these return.

use fringe_rig::atical::{CalibratedSensor, GaugeSource};
use fringe_rig::clock::HostTime;
use fringe_rig::force::{ForceError, ForceSample, ForceSensor, StreamStats};
use fringe_rig::units::Hertz;
use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// How long the stream may stay silent before the command stops.
pub const STALL: Duration = Duration::from_secs(1);

/// The CSV columns: `fringe ft stream`'s host time and force columns, the DAQ's sample index
/// in place of the Net F/T's sequences, and the strobe when one is read.
pub const CSV_COLUMNS: &str = "host_time_s,sample_index,fx_n,fy_n,fz_n,tx_nm,ty_nm,tz_nm";

/// Writes a DAQ's samples as CSV rows under a header.
pub struct DaqCsv<W: Write> {
    out: W,
    strobe: bool,
}

impl<W: Write> DaqCsv<W> {
    /// Writes the header; `strobe` adds the `strobe_v` column.
    pub fn new(mut out: W, strobe: bool) -> io::Result<DaqCsv<W>> {
        writeln!(
            out,
            "{CSV_COLUMNS}{}",
            if strobe { ",strobe_v" } else { "" }
        )?;
        Ok(DaqCsv { out, strobe })
    }

    /// One sample: host time (s, as `fringe ft stream` writes it), sample index, Fx Fy Fz (N),
    /// Tx Ty Tz (N m) and the strobe (V).
    pub fn row(&mut self, s: &ForceSample) -> io::Result<()> {
        let w = s.wrench.to_array();
        write!(
            self.out,
            "{:.6},{},{},{},{},{},{},{}",
            s.host_time.seconds(),
            s.device_tick,
            w[0],
            w[1],
            w[2],
            w[3],
            w[4],
            w[5]
        )?;
        if self.strobe {
            match s.strobe {
                Some(v) => write!(self.out, ",{}", v.0)?,
                None => write!(self.out, ",")?,
            }
        }
        writeln!(self.out)
    }

    pub fn flush(&mut self) -> io::Result<()> {
        self.out.flush()
    }

    pub fn into_inner(self) -> W {
        self.out
    }
}

/// Why a bring-up stream or bias failed.
#[derive(Debug, thiserror::Error)]
pub enum BringupError {
    #[error("cannot create {} ({source}); check the directory exists and is writable", path.display())]
    Create {
        path: PathBuf,
        #[source]
        source: io::Error,
    },
    #[error("cannot write {}: {source}", path.display())]
    Write {
        path: PathBuf,
        #[source]
        source: io::Error,
    },
    #[error(transparent)]
    Force(#[from] ForceError),
    #[error("{device}: no sample for {} s: the acquisition stopped; check the USB cable and power, and that no other program (NI MAX's test panel) uses the device", waited.as_secs_f64())]
    Stalled { device: String, waited: Duration },
    #[error("{device}: no sample arrived in {:.1} s; nothing written to {} (check the device's name and that its sample clock runs)", waited.as_secs_f64(), path.display())]
    NoSamples {
        device: String,
        waited: Duration,
        path: PathBuf,
    },
}

/// What a stream recorded.
#[derive(Debug)]
pub struct StreamReport {
    /// Samples written to the CSV file.
    pub samples: u64,
    /// From the first sample asked for to the end of the stream.
    pub elapsed: Duration,
    /// The DAQ's scan rate.
    pub rate: Hertz,
    /// The sensor's counters (lost samples from gaps in the sample index).
    pub stats: StreamStats,
    /// How the stream ended: the duration over, or why it stopped early.
    pub ended: Result<(), BringupError>,
}

impl StreamReport {
    /// Samples the elapsed time gives at the scan rate.
    pub fn expected(&self) -> u64 {
        (self.elapsed.as_secs_f64() * self.rate.0).round() as u64
    }
}

/// Streams `sensor` at `rate` into the CSV file `csv` for `duration` (after taking a bias when
/// `bias`), calling `progress` about once a second with the samples so far and the time; a
/// silence of [`STALL`] ends it with an error. A file this call created and would leave with
/// only its header is removed again.
pub fn stream_to_csv<G: GaugeSource>(
    sensor: &mut CalibratedSensor<G>,
    rate: Hertz,
    duration: Duration,
    csv: &Path,
    bias: bool,
    strobe: bool,
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
        path: csv.to_path_buf(),
        source,
    })?;
    let mut out = DaqCsv::new(BufWriter::new(file), strobe).map_err(write_err)?;
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
                last_arrival = Instant::now();
            }
            Ok(None) if last_arrival.elapsed() >= STALL => {
                break Err(BringupError::Stalled {
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
            device: sensor.describe(),
            waited: elapsed,
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
        rate,
        stats: sensor.stats(),
        ended,
    })
}

/// What a bias left: the bias voltages and the mean reading after it.
#[derive(Debug, Clone, PartialEq)]
pub struct BiasReport {
    /// The gauge voltages subtracted from now on, V.
    pub volts: [f64; 6],
    /// Mean of the samples in the 100 ms after the bias: Fx Fy Fz (N), Tx Ty Tz (N m).
    pub mean_after: [f64; 6],
    /// Samples averaged.
    pub samples: u64,
}

/// Takes a bias at the current load and reads 100 ms after it.
pub fn bias<G: GaugeSource>(sensor: &mut CalibratedSensor<G>) -> Result<BiasReport, BringupError> {
    sensor.start()?;
    let result = bias_started(sensor);
    let stopped = sensor.stop();
    let report = result?;
    stopped?;
    Ok(report)
}

fn bias_started<G: GaugeSource>(
    sensor: &mut CalibratedSensor<G>,
) -> Result<BiasReport, BringupError> {
    sensor.bias()?;
    let mut sum = [0.0; 6];
    let mut n = 0u64;
    let mut first: Option<HostTime> = None;
    loop {
        let Some(s) = sensor.next_sample(STALL)? else {
            return Err(BringupError::Stalled {
                device: sensor.describe(),
                waited: STALL,
            });
        };
        let t0 = *first.get_or_insert(s.host_time);
        for (a, v) in sum.iter_mut().zip(s.wrench.to_array()) {
            *a += v;
        }
        n += 1;
        if s.host_time.since(t0) >= Duration::from_millis(100) {
            break;
        }
    }
    Ok(BiasReport {
        volts: sensor.bias_volts(),
        mean_after: sum.map(|v| v / n as f64),
        samples: n,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use fringe_rig::atical::{Calibration, GaugeReading};
    use fringe_rig::units::{Volts, Wrench};

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
        let mut csv = DaqCsv::new(Vec::new(), true).expect("header");
        csv.row(&sample(41, Some(4.75))).expect("row");
        csv.row(&sample(42, None)).expect("row");
        let text = String::from_utf8(csv.into_inner()).expect("utf-8");
        assert_eq!(
            text,
            "host_time_s,sample_index,fx_n,fy_n,fz_n,tx_nm,ty_nm,tz_nm,strobe_v\n\
             1.500000,41,1.5,-2,10.25,0.125,0,-0.5,4.75\n\
             1.500000,42,1.5,-2,10.25,0.125,0,-0.5,\n"
        );
        let mut csv = DaqCsv::new(Vec::new(), false).expect("header");
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
            Hertz(1000.0),
            Duration::from_millis(1500),
            &csv,
            true,
            false,
            &mut |_, _| ticks += 1,
        )
        .expect("streams");
        report.ended.as_ref().expect("ran its time");
        assert_eq!(ticks, 1, "progress once a second");
        let expected = report.expected() as f64;
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
            Hertz(1000.0),
            Duration::from_secs(10),
            &csv,
            false,
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
