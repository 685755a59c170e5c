//! `fringe camera`: grab frames from a GenICam camera (Aravis) or a recorded camera trace.

use crate::global::Global;
use anyhow::bail;
use fringe_app::bringup::{grab, open_source, CameraSource};
use fringe_rig::{Camera, CameraSettings, PixelFormat, Roi, TriggerMode};
use fringe_rig::{Decibels, Hertz, Microseconds};
use std::path::PathBuf;
use std::time::Duration;

#[derive(clap::Args)]
#[command(group(clap::ArgGroup::new("source").required(true).args(["aravis", "replay"])))]
pub struct CameraArgs {
    /// Aravis camera id or GigE address (see `fringe devices`); needs `--features aravis`.
    #[arg(long, value_name = "ID")]
    aravis: Option<String>,

    /// A recorded camera trace directory, played as fast as possible.
    #[arg(long, value_name = "TRACE_DIR")]
    replay: Option<PathBuf>,

    #[command(subcommand)]
    action: CameraAction,
}

#[derive(clap::Subcommand)]
enum CameraAction {
    /// Grab frames: lossless PNGs and frames.csv (seq, id, device timestamp, host arrival) in DIR.
    Grab(GrabArgs),
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum TriggerArg {
    FreeRun,
    Software,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum FormatArg {
    Mono8,
    Rgb8,
    Bayerrg8,
}

#[derive(clap::Args)]
struct GrabArgs {
    /// Number of frames.
    #[arg(long, default_value_t = 10)]
    count: u64,
    /// Output directory (created if needed).
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// free-run (at --frame-rate) or software (one trigger per frame).
    #[arg(long, value_enum, default_value = "free-run")]
    trigger: TriggerArg,
    /// Exposure in microseconds.
    #[arg(long, default_value_t = 2000.0)]
    exposure_us: f64,
    /// Gain in dB.
    #[arg(long, default_value_t = 0.0)]
    gain_db: f64,
    /// Frame rate in Hz.
    #[arg(long, default_value_t = 50.0)]
    frame_rate: f64,
    /// Pixel format (default: the colour camera's native bayerrg8, or the format a replayed
    /// trace holds).
    #[arg(long, value_enum)]
    pixel_format: Option<FormatArg>,
    /// Region of interest X,Y,WIDTH,HEIGHT (default: full sensor).
    #[arg(long, value_name = "X,Y,W,H", value_parser = parse_roi)]
    roi: Option<Roi>,
    /// Give up when no frame arrives for this many milliseconds.
    #[arg(long, default_value_t = 2000)]
    timeout_ms: u64,
}

fn parse_roi(text: &str) -> Result<Roi, String> {
    let v: Vec<u32> = text
        .split(',')
        .map(|p| p.trim().parse::<u32>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("bad ROI {text:?}: expected X,Y,WIDTH,HEIGHT in pixels"))?;
    match v[..] {
        [x, y, width, height] if width > 0 && height > 0 => Ok(Roi {
            x,
            y,
            width,
            height,
        }),
        _ => Err(format!(
            "bad ROI {text:?}: expected X,Y,WIDTH,HEIGHT with WIDTH and HEIGHT > 0"
        )),
    }
}

pub fn run(args: CameraArgs, global: &Global) -> anyhow::Result<()> {
    let source = match (&args.aravis, &args.replay) {
        (Some(id), _) => CameraSource::Aravis(id),
        (None, Some(dir)) => CameraSource::Replay(dir),
        (None, None) => bail!("give a camera source: --aravis ID or --replay TRACE_DIR"),
    };
    let (mut camera, offered) = open_source(&source, global.record_trace.as_deref())?;
    // Without --pixel-format: the camera's native format, or what a replayed trace holds.
    let native = offered.unwrap_or(CameraSettings::default().pixel_format);
    match args.action {
        CameraAction::Grab(grab) => run_grab(camera.as_mut(), &grab, native),
    }
}

fn run_grab(camera: &mut dyn Camera, args: &GrabArgs, native: PixelFormat) -> anyhow::Result<()> {
    let trigger = match args.trigger {
        TriggerArg::FreeRun => TriggerMode::FreeRun,
        TriggerArg::Software => TriggerMode::Software,
    };
    let settings = CameraSettings {
        exposure: Microseconds(args.exposure_us),
        gain: Decibels(args.gain_db),
        frame_rate: Hertz(args.frame_rate),
        roi: args.roi,
        pixel_format: match args.pixel_format {
            Some(FormatArg::Mono8) => PixelFormat::Mono8,
            Some(FormatArg::Rgb8) => PixelFormat::Rgb8,
            Some(FormatArg::Bayerrg8) => PixelFormat::BayerRg8,
            None => native,
        },
        trigger: trigger.clone(),
        exposure_active_line: None,
    };
    let g = grab(
        camera,
        &settings,
        &args.out,
        args.count,
        Duration::from_millis(args.timeout_ms),
    )?;
    println!(
        "camera {}: {} frames written to {} (frames.csv){}",
        g.camera,
        g.frames,
        args.out.display(),
        if g.dropped > 0 {
            format!("; {} frame ids missing (dropped frames)", g.dropped)
        } else {
            String::new()
        }
    );
    g.stopped?;
    Ok(())
}
