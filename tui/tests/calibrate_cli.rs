//! `fringe calibrate --images DIR --sensor ID`: from a reference-pipeline folder of simulated
//! frames it finds the disc within the accuracy bounds, uses only the no-contact frames named by
//! `0.labels.csv`, writes the profile and the report PNG; bad folders give one clear line.

mod common;
use common::{coarse_sensor, fringe, scratch, text};
use fringe_calibration::Profile;
use std::path::PathBuf;

fn render(sensor: &str, shape: &str, force: &str, frame: &str, out: &std::path::Path) {
    let o = fringe(&[
        "sim",
        "render",
        "--sensor",
        sensor,
        "--shape",
        shape,
        "--force",
        force,
        "--frame",
        frame,
        "--out",
        out.to_str().expect("utf-8"),
    ]);
    assert!(o.status.success(), "{}", text(&o));
}

#[test]
fn calibrates_a_reference_pipeline_folder_and_writes_profile_and_report() {
    let root = scratch("folder");
    // A coarse fringe-field grid keeps the renders quick; the image stays full size.
    let sensor = coarse_sensor(&root, "layered");
    let sensor = sensor.to_str().expect("utf-8");
    let images = root.join("0.images");
    std::fs::create_dir_all(&images).expect("images dir");
    render(sensor, "none", "0", "0", &images.join("image_0.tiff"));
    render(sensor, "none", "0", "1", &images.join("image_1.tiff"));
    render(sensor, "pentagon", "6", "2", &images.join("image_2.tiff"));
    std::fs::write(
        root.join("0.labels.csv"),
        "New_Image_Name,Fx,Fy,Fz,Mx,My,Mz,Ft,X_Position_mm,Y_Position_mm,Indentor_Shape\n\
         image_0.tiff,0,0,-0.05,0,0,0,0.05,nan,nan,None\n\
         image_1.tiff,0,0,0.08,0,0,0,0.08,nan,nan,None\n\
         image_2.tiff,0.1,0,-6.0,0,0,0,6.0,0,0,pentagon\n",
    )
    .expect("labels");
    let out = root.join("profiles");
    let o = fringe(&[
        "calibrate",
        "--images",
        images.to_str().expect("utf-8"),
        "--sensor",
        "layered-7",
        "--out",
        out.to_str().expect("utf-8"),
    ]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(t.contains("2 of 3 frames have |Fz| < 0.2 N"), "{t}");
    assert!(
        t.contains("centre x 990.") || t.contains("centre x 989.9"),
        "{t}"
    );
    assert!(
        t.contains("shift from the image centre") && t.contains("crop radius"),
        "{t}"
    );
    let p = Profile::load(&out.join("layered-7.toml")).expect("profile");
    // Truth: centre (990, 600) px, radius 490 px (rig/sim/sensors/layered.toml).
    assert!((p.optical.centre_x_px - 990.0).abs() < 0.5, "{p:?}");
    assert!((p.optical.centre_y_px - 600.0).abs() < 0.5, "{p:?}");
    assert!((p.optical.shift_x_px - 30.0).abs() < 0.5, "{p:?}");
    assert!((p.optical.radius_px - 490.0).abs() < 1.0, "{p:?}");
    assert_eq!(
        (p.image.width, p.image.height, p.optical.frames),
        (1920, 1200, 2)
    );
    assert_eq!(p.sensor_id, "layered-7");
    let report = image::open(out.join("layered-7.png"))
        .expect("report png")
        .to_rgb8();
    assert_eq!(report.dimensions(), (1920, 1200));
    // The fitted disc is drawn in green at the rim, right of the centre.
    let rim = report.get_pixel((990.0 + 490.0f64).floor() as u32, 600);
    assert_eq!(rim.0, [0, 255, 0]);

    // Without labels all frames are used, and the run says so.
    std::fs::remove_file(root.join("0.labels.csv")).expect("remove labels");
    std::fs::remove_file(images.join("image_2.tiff")).expect("remove contact frame");
    let o = fringe(&[
        "calibrate",
        "--images",
        images.to_str().expect("utf-8"),
        "--sensor",
        "layered-7",
        "--out",
        out.to_str().expect("utf-8"),
    ]);
    let t = text(&o);
    assert!(
        o.status.success() && t.contains("using all 2 frames"),
        "{t}"
    );
    std::fs::remove_dir_all(&root).ok();
}

#[test]
fn bad_folders_give_one_clear_line() {
    let root = scratch("bad");
    let run = |dir: &PathBuf| {
        let o = fringe(&[
            "calibrate",
            "--images",
            dir.to_str().expect("utf-8"),
            "--sensor",
            "s1",
            "--out",
            root.join("profiles").to_str().expect("utf-8"),
        ]);
        assert!(!o.status.success());
        text(&o)
    };
    let empty = root.join("empty");
    std::fs::create_dir_all(&empty).expect("dir");
    let t = run(&empty);
    assert!(t.contains("empty") && t.contains("no PNG or TIFF"), "{t}");

    let broken = root.join("broken");
    std::fs::create_dir_all(&broken).expect("dir");
    std::fs::write(broken.join("a.png"), b"not a png").expect("write");
    let t = run(&broken);
    assert!(
        t.contains("a.png") && t.contains("cannot read image"),
        "{t}"
    );

    let mixed = root.join("mixed");
    std::fs::create_dir_all(&mixed).expect("dir");
    image::GrayImage::new(64, 48)
        .save(mixed.join("a.png"))
        .expect("write");
    image::GrayImage::new(32, 48)
        .save(mixed.join("b.png"))
        .expect("write");
    let t = run(&mixed);
    assert!(
        t.contains("mixed image sizes") && t.contains("b.png"),
        "{t}"
    );

    let flat = root.join("flat");
    std::fs::create_dir_all(&flat).expect("dir");
    let mut s = 1u32;
    let img = image::GrayImage::from_fn(320, 240, |_, _| {
        s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        image::Luma([30 + (s >> 28) as u8])
    });
    img.save(flat.join("f.png")).expect("write");
    let t = run(&flat);
    assert!(
        t.contains("flat") && t.contains("no sensor disc found"),
        "{t}"
    );
    assert!(!root.join("profiles").join("s1.toml").exists());
    std::fs::remove_dir_all(&root).ok();
}
