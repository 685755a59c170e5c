//! Indenter outlines and the contact pressure they press into the sensor.
//!
//! Pressure laws (docs/photoelastic-sim.md, "Stress seen by the camera"):
//! - circular rigid flat punch of radius a: p = F / (2 pi a sqrt(a^2 - r^2)) (Johnson, *Contact
//!   Mechanics*, 1985, section 5.2; Boussinesq's rigid punch);
//! - rectangle and pentagon flat punches: p proportional to (distance to edge + eps)^(-1/2), the
//!   square-root edge singularity of a rigid punch, with eps = half a grid cell so the edge stays
//!   finite;
//! - sphere: Hertz, p proportional to sqrt(1 - r^2 / a^2) with contact radius
//!   a = (3 F R / (4 E*))^(1/3) (Johnson, section 4.2).
//!
//! Every map is normalised so that the sum of p times cell area equals the requested force.
//! Coordinates are millimetres in the indenter frame, origin at the indenter centre; the pentagon has
//! a vertex on the +y axis.

use std::f64::consts::PI;

/// Sub-samples per cell side when rasterising a pressure map (anti-aliases the outline).
pub(crate) const SUBSAMPLES: usize = 3;

/// An indenter tip.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    /// Regular pentagon flat punch, vertex on +y.
    Pentagon {
        /// Distance from centre to vertex, mm.
        circumradius_mm: f64,
    },
    /// Rectangular flat punch, `width_mm` along x.
    Rectangle { width_mm: f64, height_mm: f64 },
    /// Circular flat punch.
    Circle { radius_mm: f64 },
    /// Sphere pressing with a Hertzian contact of radius `contact_radius_mm`.
    Sphere {
        radius_mm: f64,
        contact_radius_mm: f64,
    },
}

impl Shape {
    /// Pentagon with circumradius 5 mm.
    pub const DEFAULT_PENTAGON: Shape = Shape::Pentagon {
        circumradius_mm: 5.0,
    };
    /// 10 mm x 6 mm rectangle.
    pub const DEFAULT_RECTANGLE: Shape = Shape::Rectangle {
        width_mm: 10.0,
        height_mm: 6.0,
    };

    /// A sphere of `radius_mm` pressed with `force_n` into a half-space of effective modulus
    /// `effective_modulus_mpa` (E* = E / (1 - nu^2) for a rigid sphere), Hertz contact radius.
    pub fn sphere_hertz(radius_mm: f64, force_n: f64, effective_modulus_mpa: f64) -> Shape {
        Shape::Sphere {
            radius_mm,
            contact_radius_mm: hertz_contact_radius_mm(radius_mm, force_n, effective_modulus_mpa),
        }
    }

    /// Pentagon vertices, counter-clockwise from the +y vertex.
    fn pentagon_vertices(circumradius_mm: f64) -> [(f64, f64); 5] {
        let mut v = [(0.0, 0.0); 5];
        for (k, p) in v.iter_mut().enumerate() {
            let a = PI / 2.0 + 2.0 * PI * k as f64 / 5.0;
            *p = (circumradius_mm * a.cos(), circumradius_mm * a.sin());
        }
        v
    }

    /// Signed distance inside the outline: positive inside (distance to the nearest edge), negative
    /// or zero outside.
    pub fn inside_distance_mm(&self, x: f64, y: f64) -> f64 {
        match *self {
            Shape::Pentagon { circumradius_mm } => {
                let v = Self::pentagon_vertices(circumradius_mm);
                // Convex and counter-clockwise: distance to each edge line, positive on the inside.
                (0..5)
                    .map(|i| {
                        let (ax, ay) = v[i];
                        let (bx, by) = v[(i + 1) % 5];
                        let (ex, ey) = (bx - ax, by - ay);
                        let len = (ex * ex + ey * ey).sqrt();
                        (ex * (y - ay) - ey * (x - ax)) / len
                    })
                    .fold(f64::INFINITY, f64::min)
            }
            Shape::Rectangle {
                width_mm,
                height_mm,
            } => (0.5 * width_mm - x.abs()).min(0.5 * height_mm - y.abs()),
            Shape::Circle { radius_mm } => radius_mm - x.hypot(y),
            Shape::Sphere {
                contact_radius_mm, ..
            } => contact_radius_mm - x.hypot(y),
        }
    }

    /// Whether (x, y) lies strictly inside the contact outline.
    pub fn contains(&self, x: f64, y: f64) -> bool {
        self.inside_distance_mm(x, y) > 0.0
    }

    /// Unnormalised pressure at (x, y) with edge regularisation `eps_mm`; 0 outside.
    fn relative_pressure(&self, x: f64, y: f64, eps_mm: f64) -> f64 {
        let d = self.inside_distance_mm(x, y);
        if d <= 0.0 {
            return 0.0;
        }
        match *self {
            Shape::Pentagon { .. } | Shape::Rectangle { .. } => 1.0 / (d + eps_mm).sqrt(),
            Shape::Circle { radius_mm } => {
                // sqrt(a^2 - r^2) = sqrt((a - r)(a + r)) with a - r = d.
                1.0 / ((d + eps_mm) * (2.0 * radius_mm - d)).sqrt()
            }
            Shape::Sphere {
                contact_radius_mm, ..
            } => {
                let r = x.hypot(y) / contact_radius_mm;
                (1.0 - r * r).max(0.0).sqrt()
            }
        }
    }
}

/// Hertz contact radius a = (3 F R / (4 E*))^(1/3) in mm, for F in N, R in mm, E* in MPa (N/mm^2).
pub(crate) fn hertz_contact_radius_mm(
    radius_mm: f64,
    force_n: f64,
    effective_modulus_mpa: f64,
) -> f64 {
    (3.0 * force_n.max(0.0) * radius_mm / (4.0 * effective_modulus_mpa)).cbrt()
}

/// A square grid of contact pressure centred on the indenter.
///
/// Cell (i, j) (column i, row j) has its centre at x = (i - n/2) cell, y = (j - n/2) cell, so cell
/// (n/2, n/2) sits on the indenter centre. Values are N/mm^2 (MPa), row-major.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct PressureMap {
    n: usize,
    cell_mm: f64,
    values: Vec<f64>,
}

impl PressureMap {
    /// Rasterise `shape` on an `n` x `n` grid of `cell_mm` cells carrying total force `force_n`.
    ///
    /// Each cell averages the pressure law over 3 x 3 sub-samples. Returns an all-zero map when the
    /// outline misses every sub-sample (an indenter smaller than a cell). `n` below 2 is raised to 2.
    pub(crate) fn new(shape: &Shape, n: usize, cell_mm: f64, force_n: f64) -> PressureMap {
        let n = n.max(2);
        let eps = 0.5 * cell_mm;
        let half = (n / 2) as f64;
        let mut values = vec![0.0; n * n];
        for j in 0..n {
            for i in 0..n {
                let mut sum = 0.0;
                for sj in 0..SUBSAMPLES {
                    for si in 0..SUBSAMPLES {
                        let fx = (si as f64 + 0.5) / SUBSAMPLES as f64 - 0.5;
                        let fy = (sj as f64 + 0.5) / SUBSAMPLES as f64 - 0.5;
                        let x = (i as f64 - half + fx) * cell_mm;
                        let y = (j as f64 - half + fy) * cell_mm;
                        sum += shape.relative_pressure(x, y, eps);
                    }
                }
                values[j * n + i] = sum;
            }
        }
        let total: f64 = values.iter().sum::<f64>() * cell_mm * cell_mm;
        if total > 0.0 {
            let scale = force_n / total;
            values.iter_mut().for_each(|v| *v *= scale);
        }
        PressureMap { n, cell_mm, values }
    }

    /// A map whose whole force sits in the single cell (i, j): the discrete point load.
    /// Panics if (i, j) lies outside the `n` x `n` grid.
    #[cfg(test)]
    pub(crate) fn point(n: usize, cell_mm: f64, i: usize, j: usize, force_n: f64) -> PressureMap {
        let mut values = vec![0.0; n * n];
        values[j * n + i] = force_n / (cell_mm * cell_mm);
        PressureMap { n, cell_mm, values }
    }

    /// Cells per side.
    pub(crate) fn size(&self) -> usize {
        self.n
    }

    /// Cell side, mm.
    pub(crate) fn cell_mm(&self) -> f64 {
        self.cell_mm
    }

    /// Pressure of cell (i, j), N/mm^2.
    pub(crate) fn at(&self, i: usize, j: usize) -> f64 {
        self.values[j * self.n + i]
    }

    /// Sum of pressure times cell area, N.
    #[cfg(test)]
    pub(crate) fn total_force_n(&self) -> f64 {
        self.values.iter().sum::<f64>() * self.cell_mm * self.cell_mm
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pentagon_contains_centre_and_vertex_region_but_not_outside_edges() {
        let p = Shape::DEFAULT_PENTAGON;
        assert!(p.contains(0.0, 0.0));
        assert!(p.contains(0.0, 4.9));
        assert!(!p.contains(0.0, 5.1));
        // The bottom edge lies at the inradius R cos 36 deg = 4.045 mm below the centre.
        assert!(p.contains(0.0, -4.0));
        assert!(!p.contains(0.0, -4.1));
        assert!((p.inside_distance_mm(0.0, 0.0) - 5.0 * (PI / 5.0).cos()).abs() < 1e-12);
    }

    #[test]
    fn rectangle_outline_is_ten_by_six() {
        let r = Shape::DEFAULT_RECTANGLE;
        assert!(r.contains(4.9, 2.9));
        assert!(!r.contains(5.1, 0.0));
        assert!(!r.contains(0.0, 3.1));
    }

    #[test]
    fn pressure_map_carries_the_requested_force_only_inside_the_outline() {
        let cell = 0.25;
        for shape in [
            Shape::DEFAULT_PENTAGON,
            Shape::DEFAULT_RECTANGLE,
            Shape::Circle { radius_mm: 4.0 },
            Shape::sphere_hertz(5.0, 9.0, 0.66),
        ] {
            let map = PressureMap::new(&shape, 128, cell, 9.0);
            assert!((map.total_force_n() - 9.0).abs() < 1e-9, "{shape:?}");
            for j in 0..128 {
                for i in 0..128 {
                    let (x, y) = ((i as f64 - 64.0) * cell, (j as f64 - 64.0) * cell);
                    // Cells wholly outside (by more than a cell diagonal) carry no pressure.
                    if shape.inside_distance_mm(x, y) < -cell {
                        assert_eq!(map.at(i, j), 0.0, "{shape:?} at ({x}, {y})");
                    }
                }
            }
        }
    }

    #[test]
    fn flat_punch_pressure_peaks_at_the_edge_and_sphere_at_the_centre() {
        let rect = PressureMap::new(&Shape::DEFAULT_RECTANGLE, 128, 0.25, 1.0);
        // Centre (64, 64) versus just inside the x = +5 mm edge (cell at 4.75 mm).
        assert!(rect.at(83, 64) > 2.0 * rect.at(64, 64));
        let sphere = PressureMap::new(&Shape::sphere_hertz(5.0, 9.0, 0.66), 128, 0.25, 1.0);
        assert!(sphere.at(64, 64) > sphere.at(70, 64));
    }

    #[test]
    fn hertz_radius_grows_with_the_cube_root_of_force() {
        let a1 = hertz_contact_radius_mm(5.0, 1.0, 0.66);
        let a8 = hertz_contact_radius_mm(5.0, 8.0, 0.66);
        assert!((a8 / a1 - 2.0).abs() < 1e-12);
        // 9 N on a 5 mm sphere in a 0.5 MPa gel (E* about 0.66 MPa): a few millimetres.
        let a9 = hertz_contact_radius_mm(5.0, 9.0, 0.66);
        assert!(a9 > 3.0 && a9 < 4.5, "{a9}");
    }
}
