//! The tests' unit that did not change: the figures of a check of a unit like the ones repeated
//! checks of an unchanged simulated unit give (BENCHMARKS.md, "Unit health").

use fringe_calibration::health::Change;

/// The no-contact figures of an unchanged unit (the camera's drift in the brightness).
pub(crate) fn unchanged() -> Change {
    Change {
        centre_shift_px: [0.05, -0.02],
        centre_sigma_px: [0.02, 0.02],
        radius_change_px: 0.03,
        brightness_ratio: 0.97,
        turn_deg: 0.0,
        darkest_rim_deg: 40.0,
        darkest_rim_ratio: 0.97,
        darkest_side_deg: 90.0,
        darkest_side_ratio: 0.99,
        surface_cells: 0,
        cells_compared: 1400,
        surface_peak_dn: 0.9,
        surface_noise_dn: 0.2,
    }
}
