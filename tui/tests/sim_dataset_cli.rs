//! `fringe sim dataset`: a synthetic dataset in the reference layout whose images agree with
//! their labels, reproducible from its seed, continued after an interruption, read by `fringe
//! eval` with its own profile; bad flags refused with one line naming the flag.

mod common;
use common::{arg, coarse_sensor, constant_model, fringe, scratch, text};
use fringe_calibration::Profile;
use fringe_rig::reference_layout::COLUMNS;
use fringe_sim::SensorGeometry;
use std::path::Path;

fn dataset(sensor: &Path, out: &Path, count: &str, seed: &str) -> std::process::Output {
    fringe(&[
        "sim",
        "dataset",
        "--sensor",
        arg(sensor),
        "--count",
        count,
        "--seed",
        seed,
        "--shapes",
        "pentagon,rectangle",
        "--force-max",
        "9",
        "--out",
        arg(out),
    ])
}

/// One row of 0.labels.csv.
struct Row {
    image: String,
    /// Fx Fy Fz Mx My Mz Ft.
    force: [f64; 7],
    x: f64,
    y: f64,
    shape: String,
}

fn rows(dir: &Path) -> Vec<Row> {
    let text = std::fs::read_to_string(dir.join("0.labels.csv")).expect("labels");
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some(COLUMNS.join(",").as_str()));
    lines
        .map(|line| {
            let f: Vec<&str> = line.split(',').collect();
            assert_eq!(f.len(), 11, "{line}");
            let num = |i: usize| f[i].parse::<f64>().expect("number");
            Row {
                image: f[0].to_string(),
                force: std::array::from_fn(|i| num(i + 1)),
                x: num(8),
                y: num(9),
                shape: f[10].to_string(),
            }
        })
        .collect()
}

fn rgb(path: &Path) -> image::RgbImage {
    image::open(path).expect("png").to_rgb8()
}

/// Mean absolute difference of two images over the 81 x 81 px box centred on `at`.
fn box_difference(a: &image::RgbImage, b: &image::RgbImage, at: [f64; 2]) -> f64 {
    let (u0, v0) = (at[0].round() as i64, at[1].round() as i64);
    let (mut sum, mut n) = (0.0, 0.0);
    for v in v0 - 40..=v0 + 40 {
        for u in u0 - 40..=u0 + 40 {
            let (pa, pb) = (
                a.get_pixel(u as u32, v as u32),
                b.get_pixel(u as u32, v as u32),
            );
            for c in 0..3 {
                sum += (f64::from(pa.0[c]) - f64::from(pb.0[c])).abs();
                n += 1.0;
            }
        }
    }
    sum / n
}

#[test]
fn writes_a_dataset_whose_images_agree_with_their_labels_and_continues_after_an_interruption() {
    let dir = scratch("main");
    let sensor = coarse_sensor(&dir, "layered");
    let out = dir.join("data");
    let o = dataset(&sensor, &out, "24", "7");
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("wrote 24 frames"), "{}", text(&o));

    let rows = rows(&out);
    assert_eq!(rows.len(), 24);
    let profile = Profile::load(&out.join("profile.toml")).expect("profile");
    assert_eq!(profile.sensor_id, "layered-1");
    assert_eq!((profile.image.width, profile.image.height), (1920, 1200));
    let r = profile.registration.expect("registration");
    assert_eq!(r.contact_origin_stage_mm, [0.0, 0.0]);
    let geometry = SensorGeometry {
        centre_px: r.offset_px,
        px_per_mm: r.px_per_mm,
        rotation_deg: r.rotation_deg,
        mirror: r.mirror,
    };
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("dataset.json")).expect("json"))
            .expect("dataset.json");
    assert_eq!(doc["seed"], 7);
    assert_eq!(doc["count"], 24);
    assert_eq!(doc["no_contact_fraction"], 0.1);

    let disc_mm = profile.optical.radius_px / r.px_per_mm;
    let (mut none, mut pressed) = (Vec::new(), Vec::new());
    for (k, row) in rows.iter().enumerate() {
        assert_eq!(row.image, format!("image_{k}.png"));
        let path = out.join("0.images").join(&row.image);
        assert_eq!(
            image::image_dimensions(&path).expect("image"),
            (1920, 1200),
            "{}",
            path.display()
        );
        let [fx, fy, fz] = [row.force[0], row.force[1], row.force[2]];
        assert!((row.force[6] - (fx * fx + fy * fy + fz * fz).sqrt()).abs() < 1e-9);
        // Forces up to 9 N plus the F/T noise (sigma 0.05 N).
        assert!(fz.abs() <= 9.0 + 0.25 && fx.abs() < 0.25 && fy.abs() < 0.25);
        if row.shape == "None" {
            assert!(row.x.is_nan() && row.y.is_nan());
            assert!(fz.abs() < 0.2, "no-contact Fz {fz}");
            none.push(k);
        } else {
            assert!(["pentagon", "rectangle"].contains(&row.shape.as_str()));
            assert!(fz < 0.0, "pressing gives negative Fz: {fz}");
            assert!(row.x.hypot(row.y) < disc_mm - 5.0, "{} {}", row.x, row.y);
            pressed.push(k);
        }
    }
    assert!(
        !none.is_empty() && pressed.len() >= 15,
        "{none:?} {pressed:?}"
    );

    // The image agrees with its label: against a no-contact frame, the pressed frame differs
    // most around the labelled contact (mapped to px through the profile's registration), not
    // across the disc from it.
    let images = out.join("0.images");
    let unloaded = rgb(&images.join(&rows[none[0]].image));
    let mut checked = 0;
    for &k in &pressed {
        let row = &rows[k];
        if row.force[2].abs() < 1.0 {
            continue;
        }
        let img = rgb(&images.join(&row.image));
        let near = box_difference(&img, &unloaded, geometry.to_pixel(row.x, row.y));
        let r = row.x.hypot(row.y).max(0.1);
        let k_far = -r.max(12.0) / r;
        let far_mm = [row.x * k_far, row.y * k_far];
        let far = box_difference(&img, &unloaded, geometry.to_pixel(far_mm[0], far_mm[1]));
        eprintln!(
            "image_{k}: {} {:.2} N at ({:.1}, {:.1}) mm: near {near:.1}, far {far:.1}",
            row.shape, -row.force[2], row.x, row.y
        );
        assert!(
            near > 2.0 * far && near > far + 5.0,
            "image_{k}: {near} vs {far}"
        );
        checked += 1;
    }
    assert!(checked >= 10, "{checked}");

    // Interrupted: two images gone, one half-written file left. The re-run renders only those
    // two, byte for byte the same, and writes the same labels.
    let labels = std::fs::read(out.join("0.labels.csv")).expect("labels");
    let gone = [3, 17].map(|k| images.join(format!("image_{k}.png")));
    let before = gone.clone().map(|p| std::fs::read(p).expect("image"));
    for p in &gone {
        std::fs::remove_file(p).expect("remove");
    }
    std::fs::write(images.join("image_3.png.partial"), b"torn").expect("partial");
    std::fs::remove_file(out.join("0.labels.csv")).expect("remove labels");
    let o = dataset(&sensor, &out, "24", "7");
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(
        t.contains("continuing: 22 of 24 frames already rendered"),
        "{t}"
    );
    assert!(t.contains("2 rendered"), "{t}");
    assert_eq!(
        std::fs::read(out.join("0.labels.csv")).expect("labels"),
        labels
    );
    for (p, bytes) in gone.iter().zip(before) {
        assert_eq!(std::fs::read(p).expect("image back"), bytes);
    }
    assert!(!images.join("image_3.png.partial").exists());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn the_same_seed_gives_the_same_dataset_and_eval_reads_its_profile() {
    let dir = scratch("seed");
    let sensor = coarse_sensor(&dir, "layered");
    let (a, b, c) = (dir.join("a"), dir.join("b"), dir.join("c"));
    for (out, seed) in [(&a, "5"), (&b, "5"), (&c, "6")] {
        let o = dataset(&sensor, out, "6", seed);
        assert!(o.status.success(), "{}", text(&o));
    }
    let labels = |d: &Path| std::fs::read(d.join("0.labels.csv")).expect("labels");
    assert_eq!(labels(&a), labels(&b));
    assert_ne!(labels(&a), labels(&c));
    for k in 0..6 {
        let image =
            |d: &Path| std::fs::read(d.join(format!("0.images/image_{k}.png"))).expect("png");
        assert_eq!(image(&a), image(&b), "image_{k}");
    }

    // Another spec in an existing dataset is refused, naming dataset.json and what differs.
    let before = common::snapshot(&a);
    let o = dataset(&sensor, &a, "7", "5");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(
        err.contains("dataset.json") && err.contains("count: 6 there, 7 here"),
        "{err}"
    );
    assert_eq!(common::snapshot(&a), before);

    // `fringe eval` preprocesses the dataset with its profile.toml: no --profile needed.
    let model = constant_model(&dir);
    let o = fringe(&["eval", "--model", arg(&model), arg(&a)]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(t.contains("frames:         6 ("), "{t}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bad_flags_are_refused_with_one_line_naming_the_flag() {
    let dir = scratch("bad");
    let out = dir.join("never");
    let file = dir.join("a-file");
    std::fs::write(&file, "x").expect("file");
    let cases: &[(&[&str], &str, &str)] = &[
        (&["--count", "0"], "--count 0", "1 to 1000000"),
        (&["--count", "2000000"], "--count 2000000", "1 to 1000000"),
        (&["--force-max", "nan"], "--force-max NaN", "at most 12 N"),
        (&["--force-max", "0.3"], "--force-max 0.3", "above 0.3 N"),
        (&["--force-max", "-2"], "--force-max -2", "above 0.3 N"),
        (&["--force-max", "13"], "--force-max 13", "safe maximum"),
        (
            &["--shapes", "pentagon,hexagon"],
            "--shapes \"hexagon\"",
            "pentagon, rectangle",
        ),
        (
            &["--no-contact-fraction", "1.5"],
            "--no-contact-fraction 1.5",
            "0 to 1",
        ),
        (&["--workers", "0"], "--workers 0", "1 to 64"),
        (&["--sensor", "thick"], "--sensor `thick`", "integrated"),
    ];
    for (extra, flag, hint) in cases {
        let mut args: Vec<&str> = vec!["sim", "dataset"];
        if extra[0] != "--count" {
            args.extend(["--count", "4"]);
        }
        args.extend_from_slice(extra);
        args.extend(["--out", arg(&out)]);
        let o = fringe(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{args:?}");
        assert_eq!(err.trim().lines().count(), 1, "{args:?}: {err}");
        assert!(err.contains(flag) && err.contains(hint), "{args:?}: {err}");
        assert!(!out.exists(), "{args:?} created the directory");
    }
    // A million full-size frames (3.5 TB) do not fit on the test machine's disk: refused before
    // anything is written, saying how much is needed and how much is free.
    let o = fringe(&["sim", "dataset", "--count", "1000000", "--out", arg(&out)]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(
        err.contains("1000000 frames need about 3.5 TB") && err.contains("free"),
        "{err}"
    );
    assert!(!out.exists(), "the directory was created");
    let o = fringe(&["sim", "dataset", "--count", "4", "--out", arg(&file)]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(
        err.contains("--out") && err.contains("a-file") && err.contains("not a directory"),
        "{err}"
    );
    // A directory holding something else is not written into.
    let other = dir.join("other");
    std::fs::create_dir_all(&other).expect("dir");
    std::fs::write(other.join("notes.txt"), "mine").expect("file");
    let o = fringe(&["sim", "dataset", "--count", "4", "--out", arg(&other)]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("not empty") && err.contains("dataset.json"),
        "{err}"
    );
    assert_eq!(std::fs::read_dir(&other).expect("dir").count(), 1);
    std::fs::remove_dir_all(&dir).ok();
}

/// Frames of the integrated design are never read silently by the layered model: `fringe eval`
/// without `--model` takes the model that ships for the dataset's design, and a model of the
/// other design is refused naming both.
#[test]
fn eval_takes_the_model_of_the_datasets_sensor_design() {
    let dir = scratch("design");
    let sensor = coarse_sensor(&dir, "integrated");
    let data = dir.join("data");
    let o = dataset(&sensor, &data, "4", "3");
    assert!(o.status.success(), "{}", text(&o));
    let o = fringe(&["eval", arg(&data)]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(
        t.contains(
            "builtin:integrated-two-stage (keypoint CNN, then keypoint CNN on a 24 mm window placing the contact)"
        ),
        "{t}"
    );
    let o = fringe(&["eval", "--model", "default", arg(&data)]);
    let t = text(&o);
    assert!(!o.status.success(), "{t}");
    assert!(
        t.contains(
            "builtin:layered: the model is for the layered sensor design and the data's sensor is integrated"
        ),
        "{t}"
    );
    // A model of the dataset's design is run.
    let model = constant_model(&dir);
    std::fs::write(
        model.with_extension("json"),
        r#"{"classes": ["None", "pentagon", "rectangle"], "variant": "integrated"}"#,
    )
    .expect("card");
    let o = fringe(&["eval", "--model", arg(&model), arg(&data)]);
    assert!(o.status.success(), "{}", text(&o));
    std::fs::remove_dir_all(&dir).ok();
}
