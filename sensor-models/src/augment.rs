//! The paper's augmentation pipelines (section 3.3), seeded: every training frame becomes
//! `copies` network inputs, each turned by a uniform angle about the optical centre (inside the
//! one preprocessing, so the crop and mask stay centred) with its contact label turned the same
//! way, then Gaussian noise of 5 grey levels on the network input (the noisy pipelines).
//!
//! The copies are made once, before training, as the paper's offline augmentation did; the
//! angles and noise come from (seed, frame index, copy) alone, so a resumed training sees the
//! same copies.

use crate::preprocess::Colour;
use fringe_rig::seeded::{mix, SplitMix64};
use std::fmt;
use std::str::FromStr;

/// Noise of the noisy pipelines: sigma 5 on 0-255.
pub(crate) const NOISE_SIGMA_DN: f64 = 5.0;

/// An augmentation pipeline, by name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Pipeline {
    /// Grey + noise, 10 copies per frame (the paper's best).
    #[serde(rename = "gray10")]
    Gray10,
    /// RGB + noise, 3 copies.
    #[serde(rename = "rgb3")]
    Rgb3,
    /// RGB without noise, 3 copies.
    #[serde(rename = "rgb3-clean")]
    Rgb3Clean,
}

impl Pipeline {
    pub const ALL: [Pipeline; 3] = [Pipeline::Gray10, Pipeline::Rgb3, Pipeline::Rgb3Clean];

    pub fn name(self) -> &'static str {
        match self {
            Pipeline::Gray10 => "gray10",
            Pipeline::Rgb3 => "rgb3",
            Pipeline::Rgb3Clean => "rgb3-clean",
        }
    }

    pub fn colour(self) -> Colour {
        match self {
            Pipeline::Gray10 => Colour::Grey,
            Pipeline::Rgb3 | Pipeline::Rgb3Clean => Colour::Rgb,
        }
    }

    /// Augmented copies per training frame.
    pub fn copies(self) -> usize {
        match self {
            Pipeline::Gray10 => 10,
            Pipeline::Rgb3 | Pipeline::Rgb3Clean => 3,
        }
    }

    /// Noise standard deviation on 0-255.
    pub fn noise_dn(self) -> f64 {
        match self {
            Pipeline::Gray10 | Pipeline::Rgb3 => NOISE_SIGMA_DN,
            Pipeline::Rgb3Clean => 0.0,
        }
    }
}

impl fmt::Display for Pipeline {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Pipeline {
    type Err = UnknownPipeline;

    fn from_str(s: &str) -> Result<Pipeline, UnknownPipeline> {
        Pipeline::ALL
            .into_iter()
            .find(|p| p.name() == s)
            .ok_or_else(|| UnknownPipeline(s.to_string()))
    }
}

/// A pipeline name that is none of the paper's.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("unknown augmentation pipeline `{0}`: use gray10, rgb3 or rgb3-clean")]
pub struct UnknownPipeline(pub String);

/// One augmented copy: its rotation and the seed of its noise.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Augmentation {
    /// Counter-clockwise on screen, degrees in [0, 360).
    pub rotation_deg: f64,
    pub noise_seed: u64,
}

/// The augmentation of copy `copy` of frame `frame` under `seed`.
pub fn augmentation(seed: u64, frame: usize, copy: usize) -> Augmentation {
    let mut rng = SplitMix64::new(mix(mix(seed, frame as u64), copy as u64));
    Augmentation {
        rotation_deg: rng.range(0.0..360.0),
        noise_seed: rng.next_u64(),
    }
}

/// Adds Gaussian noise of `sigma_dn` grey levels to a normalised network input (mean 0.5,
/// std 0.5: one grey level is 2/255). A grey input gets the same noise in its three
/// channels, as a grey image repeated to three channels would.
pub fn add_noise(tensor: &mut [f32], colour: Colour, sigma_dn: f64, seed: u64) {
    if sigma_dn <= 0.0 {
        return;
    }
    let sigma = (sigma_dn * 2.0 / 255.0) as f32;
    let mut rng = SplitMix64::new(seed);
    let plane = tensor.len() / 3;
    match colour {
        Colour::Grey => {
            for i in 0..plane {
                let n = sigma * rng.normal() as f32;
                for c in 0..3 {
                    let v = &mut tensor[c * plane + i];
                    *v = (*v + n).clamp(-1.0, 1.0);
                }
            }
        }
        Colour::Rgb => {
            for v in tensor.iter_mut() {
                *v = (*v + sigma * rng.normal() as f32).clamp(-1.0, 1.0);
            }
        }
    }
}

/// A contact label turned with its image by `rotation_deg` counter-clockwise on screen. Labels
/// are in the stage frame; when the profile's registration says the camera sees that frame
/// mirror-reversed, an image turned counter-clockwise turns the label clockwise.
pub fn rotate_label(contact_mm: [f64; 2], rotation_deg: f64, mirror: bool) -> [f64; 2] {
    let angle = if mirror { -rotation_deg } else { rotation_deg };
    crate::preprocess::rotate_contact(contact_mm, angle)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pipelines_by_name_and_their_settings() {
        for p in Pipeline::ALL {
            assert_eq!(p.name().parse::<Pipeline>(), Ok(p));
        }
        assert_eq!(Pipeline::Gray10.copies(), 10);
        assert_eq!(Pipeline::Gray10.colour(), Colour::Grey);
        assert_eq!(Pipeline::Rgb3Clean.noise_dn(), 0.0);
        let e = "grey10".parse::<Pipeline>().expect_err("unknown");
        assert!(e.to_string().contains("gray10, rgb3 or rgb3-clean"), "{e}");
    }

    #[test]
    fn copies_are_seeded_and_spread_over_the_circle() {
        assert_eq!(augmentation(42, 3, 1), augmentation(42, 3, 1));
        assert_ne!(augmentation(42, 3, 1), augmentation(42, 3, 2));
        assert_ne!(augmentation(42, 3, 1), augmentation(43, 3, 1));
        let angles: Vec<f64> = (0..4000)
            .map(|k| augmentation(1, k, 0).rotation_deg)
            .collect();
        assert!(angles.iter().all(|a| (0.0..360.0).contains(a)));
        for q in 0..4 {
            let n = angles.iter().filter(|a| (**a / 90.0) as usize == q).count();
            assert!((900..1100).contains(&n), "quadrant {q}: {n}");
        }
    }

    #[test]
    fn noise_has_five_grey_levels_and_grey_channels_stay_equal() {
        let plane = 100_000;
        let mut t = vec![0.0f32; 3 * plane];
        add_noise(&mut t, Colour::Grey, 5.0, 9);
        assert_eq!(&t[..plane], &t[plane..2 * plane]);
        let sd = (t[..plane].iter().map(|v| (v * v) as f64).sum::<f64>() / plane as f64).sqrt();
        let sd_dn = sd * 255.0 / 2.0;
        assert!((sd_dn - 5.0).abs() < 0.1, "{sd_dn}");
        let mut rgb = vec![0.0f32; 3 * plane];
        add_noise(&mut rgb, Colour::Rgb, 5.0, 9);
        assert_ne!(&rgb[..plane], &rgb[plane..2 * plane]);
        let mut clean = vec![0.25f32; 30];
        add_noise(&mut clean, Colour::Rgb, 0.0, 9);
        assert!(clean.iter().all(|v| *v == 0.25));
    }

    #[test]
    fn a_mirrored_view_turns_the_label_the_other_way() {
        let a = rotate_label([1.0, 0.0], 90.0, false);
        assert!((a[0]).abs() < 1e-12 && (a[1] - 1.0).abs() < 1e-12, "{a:?}");
        let b = rotate_label([1.0, 0.0], 90.0, true);
        assert!((b[0]).abs() < 1e-12 && (b[1] + 1.0).abs() < 1e-12, "{b:?}");
    }
}
