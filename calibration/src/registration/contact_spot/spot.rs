//! A located contact ([`ContactSpot`]) and why a press cannot be located ([`ContactError`]).

/// A press that cannot be located.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ContactError {
    #[error("no frames given for the {0}")]
    NoFrames(&'static str),
    #[error(
        "frame {index} of the {what} is {got_w}x{got_h} px, the background is {want_w}x{want_h} px"
    )]
    SizeMismatch {
        what: &'static str,
        index: usize,
        got_w: u32,
        got_h: u32,
        want_w: u32,
        want_h: u32,
    },
    #[error("crop circle (centre ({cu:.1}, {cv:.1}) px, radius {radius:.1} px) holds too few pixels of the {w}x{h} px frame")]
    BadCrop {
        cu: f64,
        cv: f64,
        radius: f64,
        w: u32,
        h: u32,
    },
    #[error("the background is too dark for an illumination estimate (mean {mean_dn:.1} DN above the dark level)")]
    Dark { mean_dn: f64 },
    #[error("no contact visible: {bins} bins of {bin} px above {sigmas} noise sigmas ({noise_dn:.2} DN), need {need}")]
    NoContact {
        bins: usize,
        need: usize,
        bin: usize,
        sigmas: f64,
        noise_dn: f64,
    },
    #[error("the pattern's outline about ({u:.1}, {v:.1}) px is cut on {percent:.0} % of the rays (window {window:.0} px, {room:.0} px of room to the crop edge): press closer to the optical centre")]
    OutlineCut {
        u: f64,
        v: f64,
        percent: f64,
        window: f64,
        room: f64,
    },
    #[error("contact at ({u:.1}, {v:.1}) px is too close to the crop edge: {room:.0} px of room inside the crop circle, the pattern needs {need:.0} px; press within about {limit:.0} px of the optical centre")]
    NearCropEdge {
        u: f64,
        v: f64,
        room: f64,
        need: f64,
        limit: f64,
    },
}

/// A located contact: image px (x right, y down, pixel (i, j) centred at (i + 0.5, j + 0.5)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactSpot {
    pub u_px: f64,
    pub v_px: f64,
    /// 1-sigma from the image noise, px.
    pub sigma_u_px: f64,
    pub sigma_v_px: f64,
    /// Radius of the centroid window, px.
    pub window_px: f64,
    /// Radius holding 90 % of the pattern's weight, px.
    pub r90_px: f64,
    /// Bins above the threshold inside the window.
    pub bins: usize,
    /// Summed weight over its noise (a signal-to-noise ratio of the whole pattern).
    pub snr: f64,
    /// Pressed frames averaged.
    pub frames: usize,
}

impl ContactSpot {
    /// The larger of the two axis sigmas, px.
    pub fn sigma_px(&self) -> f64 {
        self.sigma_u_px.max(self.sigma_v_px)
    }
}
