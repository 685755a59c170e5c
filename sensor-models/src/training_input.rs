//! The network inputs `fringe train` trains on, one at a time: a frame through the one
//! preprocessing, turned by an augmented copy's angle about the optical centre, made noisy by
//! its pipeline, and kept as 8-bit grey levels (one plane for grey inputs, three for RGB: a
//! twelfth or a quarter of the memory of float inputs). A batch turns them back into
//! normalised floats.
//!
//! `fringe train`'s training set and the Python package's `fringe.torch.Dataset` both make
//! their inputs here, so a copy is the same bytes in both.

use crate::augment::{add_noise, Augmentation};
use crate::preprocess::{Colour, FrameRef, PreprocessError, Preprocessing, Preprocessor};

/// Planes kept per input: one for grey (the three channels are equal), three for RGB.
pub fn stored_planes(colour: Colour) -> usize {
    match colour {
        Colour::Grey => 1,
        Colour::Rgb => 3,
    }
}

/// Bytes kept per input of `colour` at `input_size` px.
pub fn stored_len(colour: Colour, input_size: u32) -> usize {
    stored_planes(colour) * (input_size as usize).pow(2)
}

/// Makes training inputs; one per thread: it keeps its preprocessor while the preprocessing
/// stays the same, and its buffer.
#[derive(Default)]
pub struct InputMaker {
    pre: Option<Preprocessor>,
    tensor: Vec<f32>,
}

impl InputMaker {
    pub fn new() -> InputMaker {
        InputMaker::default()
    }

    /// `frame` through `config`, turned by `augmentation`'s angle and made noisy by `noise_dn`
    /// grey levels with its seed (the frame as it is without one), into `out`
    /// ([`stored_len`] bytes of `config`'s colour and size).
    pub fn make(
        &mut self,
        frame: FrameRef,
        config: Preprocessing,
        augmentation: Option<Augmentation>,
        noise_dn: f64,
        out: &mut [u8],
    ) -> Result<(), PreprocessError> {
        let colour = config.colour;
        let pre = match &mut self.pre {
            Some(p) if p.config == config => p,
            slot => slot.insert(Preprocessor::new(config)),
        };
        self.tensor.resize(pre.config.tensor_len(), 0.0);
        let angle = augmentation.map_or(0.0, |a| a.rotation_deg);
        pre.run_into(frame, angle, &mut self.tensor)?;
        if let Some(a) = augmentation {
            add_noise(&mut self.tensor, colour, noise_dn, a.noise_seed);
        }
        quantise(&self.tensor, out);
        Ok(())
    }
}

/// A normalised input (-1 to 1) as 8-bit grey levels into `out` (as many values as it holds:
/// the first plane of a grey input).
fn quantise(tensor: &[f32], out: &mut [u8]) {
    for (o, v) in out.iter_mut().zip(tensor) {
        *o = ((v * 0.5 + 0.5) * 255.0).round().clamp(0.0, 255.0) as u8;
    }
}

/// Kept inputs (`stored_len` bytes each, one after another) appended to `out` as the
/// normalised floats a network takes: three CHW planes each, grey repeated.
pub fn expand_inputs(levels: &[u8], colour: Colour, input_size: u32, out: &mut Vec<f32>) {
    let stride = stored_len(colour, input_size);
    let norm = |v: u8| f32::from(v) / 127.5 - 1.0;
    out.reserve(levels.len() / stride.max(1) * 3 * (input_size as usize).pow(2));
    for px in levels.chunks_exact(stride) {
        match colour {
            Colour::Grey => {
                for _ in 0..3 {
                    out.extend(px.iter().map(|&v| norm(v)));
                }
            }
            Colour::Rgb => out.extend(px.iter().map(|&v| norm(v))),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_kept_input_comes_back_within_half_a_grey_level_and_grey_in_three_planes() {
        let tensor: Vec<f32> = (0..3 * 4)
            .map(|i| ((i % 4) as f32 * 0.37 - 0.6).clamp(-1.0, 1.0))
            .collect();
        let mut kept = vec![0u8; stored_len(Colour::Grey, 2)];
        quantise(&tensor, &mut kept);
        let mut back = Vec::new();
        expand_inputs(&kept, Colour::Grey, 2, &mut back);
        assert_eq!(back.len(), 12);
        for (b, t) in back.iter().zip(&tensor) {
            assert!((b - t).abs() <= 1.0 / 255.0 + 1e-6, "{b} from {t}");
        }
        assert_eq!(back[0..4], back[4..8]);
        assert_eq!(back[0..4], back[8..12]);
        let mut rgb = vec![0u8; stored_len(Colour::Rgb, 2)];
        quantise(&tensor, &mut rgb);
        let mut back = Vec::new();
        expand_inputs(&rgb, Colour::Rgb, 2, &mut back);
        assert_eq!(back.len(), 12);
        assert!(back.iter().all(|v| (-1.0..=1.0).contains(v)));
    }
}
