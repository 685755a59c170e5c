//! Records a few `WrenchStamped` and `Classification` messages to an MCAP file as fringe's
//! stream records them, to open in Foxglove or with `rosbags` / `mcap` readers:
//! `cargo run -p fringe-ros2 --features mcap --example record_wrench -- out.mcap`

use fringe_ros2::{
    Classification, Header, ObjectHypothesis, Qos, Recorder, Time, Vector3, Wrench, WrenchStamped,
};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "wrench.mcap".into());
    let mut r = Recorder::create(std::path::Path::new(&path))?;
    let mut wrench = r.channel::<WrenchStamped>("/fringe/wrench", Qos::DEFAULT)?;
    let mut shape = r.channel::<Classification>("/fringe/shape", Qos::DEFAULT)?;
    let t0 = 1_796_500_000_000_000_000u64;
    for k in 0..50u64 {
        let t = t0 + k * 20_000_000;
        let header = Header {
            stamp: Time::from_unix_nanos(t),
            frame_id: "fringe_sensor".into(),
        };
        let fz = -4.0 * (k as f64 / 49.0 * std::f64::consts::PI).sin();
        let m = WrenchStamped {
            header: header.clone(),
            wrench: Wrench {
                force: Vector3 {
                    x: 0.0,
                    y: 0.0,
                    z: fz,
                },
                torque: Vector3 {
                    x: 0.0,
                    y: 0.0,
                    z: 0.0,
                },
            },
        };
        r.write(&mut wrench, &m, t, t)?;
        let s = Classification {
            header,
            results: vec![
                ObjectHypothesis {
                    class_id: "pentagon".into(),
                    score: 0.9,
                },
                ObjectHypothesis {
                    class_id: "rectangle".into(),
                    score: 0.1,
                },
            ],
        };
        r.write(&mut shape, &s, t, t)?;
    }
    println!("wrote {}", r.finish()?.display());
    Ok(())
}
