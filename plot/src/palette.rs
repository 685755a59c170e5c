//! The colours of fringe's plots: one series each, readable on white and told apart in print.

/// A colour, red, green, blue.
pub type Colour = [u8; 3];

pub const BLUE: Colour = [31, 100, 180];
pub const ORANGE: Colour = [235, 120, 10];
pub const GREEN: Colour = [40, 150, 60];
pub const RED: Colour = [210, 35, 35];
pub const PURPLE: Colour = [130, 80, 170];
pub const BLACK: Colour = [0, 0, 0];
pub const GREY: Colour = [150, 150, 150];
pub const LIGHT_GREY: Colour = [225, 225, 225];
pub const WHITE: Colour = [255, 255, 255];
pub const YELLOW: Colour = [255, 230, 0];

/// The series colours in order (a chart's n-th series takes the n-th).
pub const SERIES: [Colour; 5] = [BLUE, ORANGE, GREEN, PURPLE, BLACK];

/// A colour between green (`t` = 0) and red (`t` = 1) through amber.
pub fn green_to_red(t: f64) -> Colour {
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        1.0
    };
    let mix = |a: Colour, b: Colour, s: f64| {
        [0, 1, 2].map(|k| (f64::from(a[k]) + (f64::from(b[k]) - f64::from(a[k])) * s).round() as u8)
    };
    let amber = [240, 170, 0];
    if t < 0.5 {
        mix(GREEN, amber, 2.0 * t)
    } else {
        mix(amber, RED, 2.0 * t - 1.0)
    }
}
