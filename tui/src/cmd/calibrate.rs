//! `fringe calibrate --images DIR --sensor ID [--out profiles/]`: the optical part of the sensor
//! calibration from existing image files (PNG or TIFF): centre, shift from the image centre,
//! radius and crop radius, written to `OUT/<sensor-id>.toml` with a report PNG beside it.

use anyhow::{bail, Context};
use fringe_calibration::optical::{self, grey::GreyImage, DiscFit};
use fringe_calibration::profile::{profile_path, Profile};
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct CalibrateArgs {
    /// Folder of no-contact frames (PNG or TIFF), for example a reference-pipeline `0.images/`.
    #[arg(long, value_name = "DIR")]
    images: PathBuf,
    /// Sensor build id: names the profile file (`OUT/<ID>.toml`).
    #[arg(long, value_name = "ID")]
    sensor: String,
    /// Folder for the profile and its report PNG.
    #[arg(long, value_name = "DIR", default_value = "profiles")]
    out: PathBuf,
    /// Average at most this many frames (spread evenly over the chosen ones).
    #[arg(long, value_name = "N", default_value_t = 50)]
    max_frames: usize,
}

/// |Fz| below this is no contact (the F/T noise floor of the reference pipeline).
const NO_CONTACT_FZ_N: f64 = 0.2;

pub fn run(args: CalibrateArgs) -> anyhow::Result<()> {
    if args.max_frames == 0 {
        bail!("--max-frames 0: use at least 1");
    }
    let profile_file = profile_path(&args.out, &args.sensor)?;
    let dir = &args.images;
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .with_context(|| format!("cannot read image folder {}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| is_image(p))
        .collect();
    files.sort();
    if files.is_empty() {
        bail!(
            "image folder {} holds no PNG or TIFF files (.png, .tif, .tiff)",
            dir.display()
        );
    }
    let (chosen, how) = choose_no_contact(dir, &files)?;
    if chosen.is_empty() {
        bail!("{how}: no frame to use in {}", dir.display());
    }
    println!("{how}");
    let step = chosen.len().div_ceil(args.max_frames);
    let used: Vec<&PathBuf> = chosen.iter().step_by(step.max(1)).collect();
    let mut frames = Vec::with_capacity(used.len());
    for path in &used {
        let img = image::open(path).with_context(|| {
            format!(
                "cannot read image {} (not a readable PNG or TIFF)",
                path.display()
            )
        })?;
        let g = GreyImage::from_image(&img);
        if let Some(first) = frames.first() {
            let first: &GreyImage = first;
            if (g.width, g.height) != (first.width, first.height) {
                bail!(
                    "mixed image sizes in {}: {} is {}x{} px but {} is {}x{} px; calibrate one camera setting at a time",
                    dir.display(),
                    path.display(),
                    g.width,
                    g.height,
                    used[0].display(),
                    first.width,
                    first.height
                );
            }
        }
        frames.push(g);
    }
    let average = optical::grey::average(&frames)?
        .with_context(|| format!("no frames read from {}", dir.display()))?;
    let fit = optical::find_disc_in(&average)
        .with_context(|| format!("{} ({} frames averaged)", dir.display(), frames.len()))?;
    print_fit(&fit);

    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create profile folder {}", args.out.display()))?;
    let profile = Profile::from_fit(&args.sensor, &dir.display().to_string(), &fit);
    profile.save(&profile_file)?;
    let report = profile_file.with_extension("png");
    write_report(&average, &fit, &report)?;
    println!("wrote {}", profile_file.display());
    println!(
        "wrote {} (fitted disc green, crop circle yellow, centre red)",
        report.display()
    );
    Ok(())
}

fn is_image(p: &Path) -> bool {
    p.is_file()
        && p.extension()
            .and_then(|e| e.to_str())
            .map(|e| matches!(e.to_ascii_lowercase().as_str(), "png" | "tif" | "tiff"))
            .unwrap_or(false)
}

/// The no-contact frames: from a `0.labels.csv` in DIR or beside it (|Fz| < 0.2 N) when there is
/// one, else all of them. Also a line saying which.
fn choose_no_contact(dir: &Path, files: &[PathBuf]) -> anyhow::Result<(Vec<PathBuf>, String)> {
    let candidates = [
        dir.join("0.labels.csv"),
        dir.parent()
            .map(|p| p.join("0.labels.csv"))
            .unwrap_or_default(),
    ];
    let Some(labels) = candidates.iter().find(|p| p.is_file()) else {
        return Ok((
            files.to_vec(),
            format!(
                "no 0.labels.csv in or beside {}: using all {} frames, assumed free of contact",
                dir.display(),
                files.len()
            ),
        ));
    };
    let text = std::fs::read_to_string(labels)
        .with_context(|| format!("cannot read {}", labels.display()))?;
    let mut lines = text.lines();
    let header: Vec<&str> = lines
        .next()
        .unwrap_or("")
        .split(',')
        .map(str::trim)
        .collect();
    let col = |name: &str| {
        header
            .iter()
            .position(|h| *h == name)
            .with_context(|| format!("{}: no `{name}` column in the header", labels.display()))
    };
    let (name_col, fz_col) = (col("New_Image_Name")?, col("Fz")?);
    let mut quiet = std::collections::HashSet::new();
    for (n, line) in lines.enumerate() {
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        if cells.len() <= name_col.max(fz_col) {
            continue;
        }
        let fz: f64 = cells[fz_col].parse().with_context(|| {
            format!(
                "{} line {}: Fz `{}` is not a number",
                labels.display(),
                n + 2,
                cells[fz_col]
            )
        })?;
        if fz.abs() < NO_CONTACT_FZ_N {
            quiet.insert(cells[name_col].to_string());
        }
    }
    let chosen: Vec<PathBuf> = files
        .iter()
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| quiet.contains(n))
        })
        .cloned()
        .collect();
    let how = format!(
        "{}: {} of {} frames have |Fz| < {NO_CONTACT_FZ_N} N (no contact)",
        labels.display(),
        chosen.len(),
        files.len()
    );
    Ok((chosen, how))
}

fn print_fit(f: &DiscFit) {
    let [sx, sy] = f.shift();
    println!(
        "image {}x{} px, {} frames averaged, noise {:.2} DN",
        f.width, f.height, f.frames, f.noise_dn
    );
    println!(
        "centre x {:.2} +- {:.3} px, y {:.2} +- {:.3} px",
        f.centre_x, f.sigma_x, f.centre_y, f.sigma_y
    );
    println!("shift from the image centre x {sx:+.2} px, y {sy:+.2} px");
    println!("radius {:.2} +- {:.3} px", f.radius, f.sigma_radius);
    println!("crop radius {:.0} px", f.crop_radius);
    println!(
        "fit residual {:.3} px RMS over {} of {} edge rays",
        f.residual_rms_px, f.inliers, f.rays
    );
}

/// The averaged frame with the fitted disc (green), the crop circle (yellow) and the centre (red
/// cross) drawn on it.
fn write_report(g: &GreyImage, f: &DiscFit, path: &Path) -> anyhow::Result<()> {
    let (w, h) = (g.width as u32, g.height as u32);
    let mut img = image::RgbImage::from_fn(w, h, |i, j| {
        let v = g.at(i as usize, j as usize).clamp(0.0, 255.0) as u8;
        image::Rgb([v, v, v])
    });
    let mut put = |x: f64, y: f64, c: [u8; 3]| {
        let (i, j) = (x.floor(), y.floor());
        if i >= 0.0 && j >= 0.0 && (i as u32) < w && (j as u32) < h {
            img.put_pixel(i as u32, j as u32, image::Rgb(c));
        }
    };
    for (r, c) in [(f.radius, [0, 255, 0]), (f.crop_radius, [255, 220, 0])] {
        let n = (8.0 * std::f64::consts::TAU * r).ceil() as usize;
        for k in 0..n {
            let a = std::f64::consts::TAU * k as f64 / n as f64;
            for dr in [-0.5, 0.5] {
                put(
                    f.centre_x + (r + dr) * a.cos(),
                    f.centre_y + (r + dr) * a.sin(),
                    c,
                );
            }
        }
    }
    for d in -20..=20 {
        for t in [-0.5, 0.5] {
            put(f.centre_x + d as f64, f.centre_y + t, [255, 0, 0]);
            put(f.centre_x + t, f.centre_y + d as f64, [255, 0, 0]);
        }
    }
    img.save(path)
        .with_context(|| format!("cannot write report {}", path.display()))
}
