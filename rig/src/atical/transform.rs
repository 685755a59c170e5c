//! Tool transforms: expressing a wrench measured at the sensor origin at another point and in a
//! rotated frame.

use nalgebra::{Matrix3, Matrix6, Rotation3, Vector3, Vector6};

/// A tool frame relative to the sensor frame.
///
/// The tool frame's origin is at `translation` (metres, in sensor coordinates) and its axes are
/// the sensor axes rotated by `rotation` (ATI's convention: Rx about x, then Ry about the new y,
/// then Rz about the new z). A wrench (F, T) at the sensor origin becomes
/// F' = Rᵀ F and T' = Rᵀ (T − d × F) in the tool frame; with no rotation and d = (0, 0, Dz) this
/// gives Tx' = Tx + Dz·Fy.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ToolTransform {
    pub translation: Vector3<f64>,
    pub rotation: Rotation3<f64>,
}

impl Default for ToolTransform {
    fn default() -> Self {
        ToolTransform {
            translation: Vector3::zeros(),
            rotation: Rotation3::identity(),
        }
    }
}

impl ToolTransform {
    /// A pure translation (metres).
    pub fn translation(dx: f64, dy: f64, dz: f64) -> ToolTransform {
        ToolTransform {
            translation: Vector3::new(dx, dy, dz),
            ..ToolTransform::default()
        }
    }

    /// ATI's six numbers: displacement in metres and angles in radians (Rx, then Ry about the
    /// new y, then Rz about the new z).
    pub fn from_ati(d: [f64; 3], r: [f64; 3]) -> ToolTransform {
        let rx = Rotation3::from_axis_angle(&Vector3::x_axis(), r[0]);
        let ry = Rotation3::from_axis_angle(&Vector3::y_axis(), r[1]);
        let rz = Rotation3::from_axis_angle(&Vector3::z_axis(), r[2]);
        ToolTransform {
            translation: Vector3::new(d[0], d[1], d[2]),
            rotation: rx * ry * rz,
        }
    }

    /// The 6x6 matrix mapping a sensor-frame wrench `[F; T]` to the tool frame.
    pub fn matrix(&self) -> Matrix6<f64> {
        let rt: Matrix3<f64> = self.rotation.matrix().transpose();
        let d = self.translation;
        // -(d x F) = skew(-d) F
        let minus_d_cross = Matrix3::new(0.0, d.z, -d.y, -d.z, 0.0, d.x, d.y, -d.x, 0.0);
        let mut m = Matrix6::zeros();
        m.fixed_view_mut::<3, 3>(0, 0).copy_from(&rt);
        m.fixed_view_mut::<3, 3>(3, 3).copy_from(&rt);
        m.fixed_view_mut::<3, 3>(3, 0)
            .copy_from(&(rt * minus_d_cross));
        m
    }

    /// Applies the transform to `[Fx, Fy, Fz, Tx, Ty, Tz]`.
    pub fn apply(&self, w: [f64; 6]) -> [f64; 6] {
        let out = self.matrix() * Vector6::from_row_slice(&w);
        std::array::from_fn(|i| out[i])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn translation_along_z_moves_torque_by_dz_times_force() {
        let t = ToolTransform::translation(0.0, 0.0, 0.05);
        let w = t.apply([0.0, 10.0, 0.0, 0.0, 0.0, 0.0]);
        assert!((w[3] - 0.5).abs() < 1e-12, "Tx' = Tx + Dz*Fy: {w:?}");
        let w = t.apply([4.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        assert!((w[4] + 0.2).abs() < 1e-12, "Ty' = Ty - Dz*Fx: {w:?}");
        let w = ToolTransform::translation(0.0, 0.02, 0.0).apply([0.0, 0.0, 5.0, 0.0, 0.0, 0.0]);
        assert!((w[3] + 0.1).abs() < 1e-12, "Tx' = Tx - Dy*Fz: {w:?}");
    }

    #[test]
    fn rotation_about_z_rotates_force_and_torque() {
        let t = ToolTransform::from_ati([0.0; 3], [0.0, 0.0, std::f64::consts::FRAC_PI_2]);
        // The tool x axis is the sensor y axis: a force along sensor y reads along tool x.
        let w = t.apply([0.0, 3.0, 0.0, 0.0, 1.0, 0.0]);
        assert!((w[0] - 3.0).abs() < 1e-12 && w[1].abs() < 1e-12, "{w:?}");
        assert!((w[3] - 1.0).abs() < 1e-12, "{w:?}");
    }
}
