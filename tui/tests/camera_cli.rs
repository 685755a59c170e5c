//! `fringe camera ... grab`: against the committed camera trace, and (feature `aravis`) against
//! the Aravis fake GigE Vision camera.

mod common;
use common::{fringe, scratch};

use std::path::Path;

/// The CSV rows (header dropped), split into fields.
fn csv_rows(dir: &Path) -> Vec<Vec<String>> {
    let text = std::fs::read_to_string(dir.join("frames.csv")).expect("frames.csv");
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("seq,id,device_timestamp,host_arrival_ns,width,height,format,file")
    );
    lines
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect()
}

fn pngs(dir: &Path) -> usize {
    std::fs::read_dir(dir)
        .expect("out dir")
        .filter(|e| {
            e.as_ref()
                .map(|e| e.path().extension().is_some_and(|x| x == "png"))
                .unwrap_or(false)
        })
        .count()
}

#[test]
fn camera_replay_grab_writes_frames_csv_and_reports_dropped_ids() {
    let trace = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/traces/camera");
    let out = scratch("replay");
    let rec = scratch("replay-rec");
    let o = fringe(&[
        "--record-trace",
        rec.to_str().expect("utf8"),
        "camera",
        "--replay",
        trace.to_str().expect("utf8"),
        "grab",
        "--count",
        "5",
        "--pixel-format",
        "mono8",
        "--out",
        out.to_str().expect("utf8"),
    ]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(stdout.contains("1 frame ids missing"), "{stdout}");
    let rows = csv_rows(&out);
    let ids: Vec<&str> = rows.iter().map(|r| r[1].as_str()).collect();
    assert_eq!(ids, ["1", "2", "3", "5", "6"]);
    assert_eq!(rows[0][2], "1000000000");
    assert_eq!(pngs(&out), 5);
    // --record-trace wrote a camera trace of what was grabbed.
    let index =
        std::fs::read_to_string(rec.join("camera/index.trace")).expect("recorded camera trace");
    assert!(
        index.starts_with("# fringe-camera-trace 1\n# device: camera\n"),
        "{index}"
    );
    assert_eq!(index.lines().filter(|l| l.ends_with(".png")).count(), 5);
    std::fs::remove_dir_all(&out).ok();
    std::fs::remove_dir_all(&rec).ok();
}

#[test]
fn camera_grab_fails_with_a_clear_message_when_frames_run_out() {
    let trace = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/traces/camera");
    let out = scratch("short");
    let o = fringe(&[
        "camera",
        "--replay",
        trace.to_str().expect("utf8"),
        "grab",
        "--count",
        "7",
        "--timeout-ms",
        "100",
        "--out",
        out.to_str().expect("utf8"),
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(
        stderr.contains("no frame within 100 ms after 5 of 7 frames"),
        "{stderr}"
    );
    std::fs::remove_dir_all(&out).ok();
}

#[cfg(not(feature = "aravis"))]
#[test]
fn camera_aravis_without_the_feature_says_how_to_rebuild() {
    let out = scratch("nofeature");
    let o = fringe(&[
        "camera",
        "--aravis",
        "Aravis-Fake-GV01",
        "grab",
        "--out",
        out.to_str().expect("utf8"),
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
    assert!(
        stderr.contains("--features aravis") && stderr.contains("apt install libaravis-dev"),
        "{stderr}"
    );
}

#[cfg(feature = "aravis")]
mod aravis_fake {
    use super::*;
    use std::process::{Child, Command, Stdio};

    struct FakeGvCamera(Child);

    impl Drop for FakeGvCamera {
        fn drop(&mut self) {
            let _ = self.0.kill();
            let _ = self.0.wait();
        }
    }

    #[test]
    fn aravis_cli_grab_writes_pngs_and_csv_from_the_fake_camera() {
        let fake = FakeGvCamera(
            Command::new("arv-fake-gv-camera-0.8")
                .args(["-i", "127.0.0.1"])
                .stdout(Stdio::null())
                .stderr(Stdio::null())
                .spawn()
                .expect("arv-fake-gv-camera-0.8 not found: apt install aravis-tools"),
        );
        // Let the fake bind its port.
        std::thread::sleep(std::time::Duration::from_millis(1000));
        let out = scratch("aravis");
        // Opened by address so Aravis streams over loopback (see tests/tests/aravis_fake.rs).
        let o = fringe(&[
            "camera",
            "--aravis",
            "127.0.0.1",
            "grab",
            "--count",
            "4",
            "--pixel-format",
            "mono8",
            "--roi",
            "0,0,32,24",
            "--frame-rate",
            "25",
            "--trigger",
            "software",
            "--out",
            out.to_str().expect("utf8"),
        ]);
        drop(fake);
        let stdout = String::from_utf8_lossy(&o.stdout);
        assert!(
            o.status.success(),
            "{stdout}{}",
            String::from_utf8_lossy(&o.stderr)
        );
        assert!(stdout.contains("Aravis-Fake-GV01: 4 frames"), "{stdout}");
        let rows = csv_rows(&out);
        assert_eq!(rows.len(), 4);
        let ids: Vec<u64> = rows.iter().map(|r| r[1].parse().expect("id")).collect();
        assert!(ids.windows(2).all(|w| w[1] > w[0]), "{ids:?}");
        assert!(
            rows.iter()
                .all(|r| r[4] == "32" && r[5] == "24" && r[6] == "mono8"),
            "{rows:?}"
        );
        assert_eq!(pngs(&out), 4);
        std::fs::remove_dir_all(&out).ok();
    }
}
