//! How the simulated F/T sensor is mounted (frames, tool length, offsets) and its imperfections
//! (noise, drift, power-up bias): configuration shared by the bench and the sensor model
//! ([`crate::physics::ft_sensor`], where the frames and the noise model are described).

use fringe_rig::{FtAxes, Wrench};
use nalgebra::{Rotation3, Vector3};

/// How the F/T sensor and the indenter are mounted.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct FtMount {
    /// Distance along the tool axis from the F/T origin to the indenter tip, mm.
    pub tool_length_mm: f64,
    /// Indenter axis offset from the F/T axis along the stage X, mm.
    pub offset_x_mm: f64,
    /// Indenter axis offset from the F/T axis along the stage Y, mm.
    pub offset_y_mm: f64,
    /// F/T x axis from the stage X, counter-clockwise seen from above, degrees.
    pub rotation_deg: f64,
    /// The F/T z axis points down at the tool (ATI tool frame); otherwise up.
    pub z_toward_tool: bool,
}

impl Default for FtMount {
    fn default() -> Self {
        FtMount {
            tool_length_mm: 35.0,
            offset_x_mm: 0.4,
            offset_y_mm: -0.25,
            rotation_deg: 0.0,
            z_toward_tool: true,
        }
    }
}

impl FtMount {
    /// Rotation taking world (stage) vectors into the F/T frame.
    pub fn world_to_sensor(&self) -> Rotation3<f64> {
        let flip = if self.z_toward_tool {
            Rotation3::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI)
        } else {
            Rotation3::identity()
        };
        // Sensor axes = flip, then a turn about the (new) z: v_s = Rz(-theta) * flip * v_world.
        let turn = Rotation3::from_axis_angle(&Vector3::z_axis(), -self.rotation_deg.to_radians());
        turn * flip
    }

    /// How the F/T's axes sit on the bench, as a rig file would say it (`[force]
    /// x_axis_deg`, `z_toward_tool`).
    pub fn axes(&self) -> FtAxes {
        FtAxes {
            x_axis_deg: self.rotation_deg,
            z_toward_tool: self.z_toward_tool,
        }
    }

    /// r from the F/T origin to the contact point, metres, in the F/T frame.
    pub fn contact_arm_m(&self) -> Vector3<f64> {
        let r_world = Vector3::new(self.offset_x_mm, self.offset_y_mm, -self.tool_length_mm) * 1e-3;
        self.world_to_sensor() * r_world
    }

    /// The wrench at the F/T origin, in the F/T frame, from a force (N) acting on the indenter tip,
    /// given in the world frame.
    pub fn wrench_from_tip_force(&self, force_world: [f64; 3]) -> Wrench {
        let f = self.world_to_sensor() * Vector3::from(force_world);
        let m = self.contact_arm_m().cross(&f);
        Wrench::from_arrays([f.x, f.y, f.z], [m.x, m.y, m.z])
    }

    /// The wrench a normal force `normal_n` (pushing the tip up, along world +Z) produces.
    pub fn wrench_from_normal_force(&self, normal_n: f64) -> Wrench {
        self.wrench_from_tip_force([0.0, 0.0, normal_n])
    }
}

/// The sensor's imperfections.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct FtNoiseConfig {
    /// Seed of noise, drift and power-up biases.
    pub seed: u64,
    /// White noise sigma per force axis, N.
    pub force_noise_n: f64,
    /// White noise sigma per torque axis, N m.
    pub torque_noise_nm: f64,
    /// Random-walk drift per force axis, N per sqrt(s).
    pub force_drift_n_per_sqrt_s: f64,
    /// Random-walk drift per torque axis, N m per sqrt(s).
    pub torque_drift_nm_per_sqrt_s: f64,
    /// Sigma of the power-up bias per force axis, N.
    pub bias_force_n: f64,
    /// Sigma of the power-up bias per torque axis, N m.
    pub bias_torque_nm: f64,
    /// Shift of the transducer's zero, N, in the F/T frame [fx, fy, fz] (an overload or a
    /// temperature change): added to the power-up bias of every power cycle (default none; a
    /// rig file's `[sim.ageing] ft_offset_n`).
    pub zero_shift_n: [f64; 3],
    /// Session of the bench (a rig file's `[sim] session`, see [`crate::session`]): salts the
    /// noise and drift, not the power-up bias (default 0: the seed as it is).
    pub session: u64,
}

impl Default for FtNoiseConfig {
    fn default() -> Self {
        FtNoiseConfig {
            seed: 1,
            force_noise_n: 0.05,
            torque_noise_nm: 0.0015,
            force_drift_n_per_sqrt_s: 0.005,
            torque_drift_nm_per_sqrt_s: 0.0001,
            bias_force_n: 2.0,
            bias_torque_nm: 0.05,
            zero_shift_n: [0.0; 3],
            session: 0,
        }
    }
}
