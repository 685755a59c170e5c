//! `fringe sim render`: writes a full-size PNG; refuses bad values with one clear line.

mod common;
use common::{coarse_sensor, fringe, scratch};

#[test]
fn renders_a_full_size_frame_with_fringes_at_the_contact() {
    let out_dir = scratch("frame");
    let out = out_dir.join("frame.png");
    // A coarser fringe-field grid than the default keeps this debug-build test quick; the image
    // stays full size.
    let sensor_dir = scratch("coarse");
    let sensor = coarse_sensor(&sensor_dir, "layered");
    let o = fringe(&[
        "sim",
        "render",
        "--sensor",
        sensor.to_str().expect("utf-8"),
        "--shape",
        "rectangle",
        "--force",
        "6",
        "--x",
        "5",
        "--y",
        "-3",
        "--angle",
        "15",
        "--seed",
        "3",
        "--out",
        out.to_str().expect("utf-8"),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("1920x1200"), "{stdout}");
    let img = image::open(&out).expect("png").to_rgb8();
    assert_eq!(img.dimensions(), (1920, 1200));
    // Default layered geometry: mirror, no rotation, 18.3 px/mm, centre 30 px right of the image
    // centre: (5, -3) mm lands at (990 - 91.5, 600 + 54.9).
    let (cu, cv) = (898.5f64, 654.9f64);
    let mean = |u0: f64, v0: f64| {
        let mut sum = 0.0;
        for dv in -60..60 {
            for du in -60..60 {
                let p = img.get_pixel((u0 as i64 + du) as u32, (v0 as i64 + dv) as u32);
                sum += p.0.iter().map(|&c| f64::from(c)).sum::<f64>() / 3.0;
            }
        }
        sum / (120.0 * 120.0)
    };
    let at_contact = mean(cu, cv);
    let far = mean(990.0 + 250.0, 600.0 - 250.0);
    eprintln!("mean grey near the contact {at_contact}, far from it {far}");
    assert!(at_contact > far + 20.0, "{at_contact} vs {far}");
    std::fs::remove_file(&out).ok();
    std::fs::remove_file(&sensor).ok();
}

#[test]
fn refuses_an_unknown_shape_and_sensor_naming_the_value() {
    let out_dir = scratch("bad");
    let out = out_dir.join("bad.png");
    let path = out.to_str().expect("utf-8");
    let o = fringe(&["sim", "render", "--shape", "hexagon", "--out", path]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(
        err.contains("hexagon") && err.contains("pentagon, rectangle, sphere or none"),
        "{err}"
    );
    assert!(!out.exists());

    let o = fringe(&["sim", "render", "--sensor", "thick", "--out", path]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("thick") && err.contains("integrated"),
        "{err}"
    );

    let o = fringe(&[
        "sim",
        "render",
        "--sensor",
        "/nonexistent/s.toml",
        "--out",
        path,
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("/nonexistent/s.toml"),
        "{err}"
    );

    let o = fringe(&["sim", "render", "--x", "40", "--out", path]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("outside the sensor disc"),
        "{err}"
    );
}
