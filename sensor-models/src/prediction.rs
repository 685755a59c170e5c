//! A network's outputs for one image, in units: the force vector, the shape with its
//! probabilities, the contact point.

use crate::backend::RawOutputs;
use fringe_rig::{Millimetres, NewtonMetres, Newtons};

/// The force vector the networks predict: magnitudes, as the reference post-processing trains
/// them (every column replaced by its absolute value), except Fx and Fy of a model with shear
/// heads (its card's `shear`), which are the signed tangential force ([`Prediction::shear`]).
/// Torques are in the unit of the training labels (N m for fringe's runs).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ForceVector {
    pub fx: Newtons,
    pub fy: Newtons,
    pub fz: Newtons,
    pub mx: NewtonMetres,
    pub my: NewtonMetres,
    pub mz: NewtonMetres,
    /// |F|, the total force.
    pub ft: Newtons,
}

impl ForceVector {
    pub fn from_array(v: [f32; 7]) -> ForceVector {
        let f = |i: usize| v[i] as f64;
        ForceVector {
            fx: Newtons(f(0)),
            fy: Newtons(f(1)),
            fz: Newtons(f(2)),
            mx: NewtonMetres(f(3)),
            my: NewtonMetres(f(4)),
            mz: NewtonMetres(f(5)),
            ft: Newtons(f(6)),
        }
    }
}

/// One image's prediction.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Prediction {
    pub force: ForceVector,
    /// The most probable shape class ("None" = no contact).
    pub shape: String,
    /// Every class with its probability (softmax of the logits), in class order.
    pub probabilities: Vec<(String, f64)>,
    /// Contact x, y in mm from the sensor centre (+x right, +y up in the camera view); `None`
    /// when the shape head says no contact.
    pub contact: Option<[Millimetres; 2]>,
    /// The contact head's output whatever the shape head says.
    pub contact_raw: [Millimetres; 2],
    /// The tangential force the indenter applies to the surface, x and y in the sensor's frame
    /// (the contact's axes), signed: a model with shear heads only (its card's `shear`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub shear: Option<[Newtons; 2]>,
    /// How the contact holds, from this frame and the ones before it: a model with a slip head
    /// (its card's `slip`), run over a sequence of frames, and only where it says contact.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub slip: Option<fringe_rig::Slip>,
}

impl Prediction {
    /// Probability of the predicted shape.
    pub fn confidence(&self) -> f64 {
        self.probabilities
            .iter()
            .find(|(n, _)| *n == self.shape)
            .map_or(0.0, |(_, p)| *p)
    }
}

/// Softmax, computed stably.
pub(crate) fn softmax(logits: &[f32]) -> Vec<f64> {
    let max = logits.iter().copied().fold(f32::NEG_INFINITY, f32::max) as f64;
    let e: Vec<f64> = logits.iter().map(|&l| (l as f64 - max).exp()).collect();
    let sum: f64 = e.iter().sum();
    e.iter().map(|v| v / sum).collect()
}

/// The predictions of a batch, with `classes` naming the shape classes in order ("None" first);
/// `shear`: the force head's Fx and Fy are the signed shear (the card's `shear`).
pub(crate) fn predictions(raw: &RawOutputs, classes: &[String], shear: bool) -> Vec<Prediction> {
    raw.force
        .iter()
        .zip(&raw.shape_logits)
        .zip(&raw.contact)
        .map(|((force, logits), contact)| {
            let p = softmax(logits);
            let best = p
                .iter()
                .enumerate()
                .max_by(|a, b| a.1.total_cmp(b.1))
                .map_or(0, |(i, _)| i);
            let name = |i: usize| {
                classes
                    .get(i)
                    .cloned()
                    .unwrap_or_else(|| format!("class {i}"))
            };
            let contact_raw = [
                Millimetres(contact[0] as f64),
                Millimetres(contact[1] as f64),
            ];
            Prediction {
                force: ForceVector::from_array(*force),
                shape: name(best),
                probabilities: p.iter().enumerate().map(|(i, &v)| (name(i), v)).collect(),
                contact: (best != 0).then_some(contact_raw),
                contact_raw,
                shear: shear.then(|| [Newtons(f64::from(force[0])), Newtons(f64::from(force[1]))]),
                slip: None,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn softmax_sums_to_one_and_picks_the_largest_logit() {
        let raw = RawOutputs {
            force: vec![[0.1, 0.2, 3.0, 0.0, 0.0, 0.0, 3.1]],
            shape_logits: vec![vec![-1.0, 4.0, 1000.0]],
            contact: vec![[1.5, -2.0]],
        };
        let names: Vec<String> = ["None", "pentagon", "rectangle"].map(String::from).into();
        let p = &predictions(&raw, &names, false)[0];
        assert_eq!(p.shear, None);
        let signed = &predictions(&raw, &names, true)[0];
        assert_eq!(
            signed.shear,
            Some([Newtons(0.1f32 as f64), Newtons(0.2f32 as f64)])
        );
        assert_eq!(p.shape, "rectangle");
        let total: f64 = p.probabilities.iter().map(|(_, v)| v).sum();
        assert!((total - 1.0).abs() < 1e-12);
        assert_eq!(p.contact, Some([Millimetres(1.5), Millimetres(-2.0)]));
        assert!((p.force.fz.value() - 3.0).abs() < 1e-6);
        let none = RawOutputs {
            shape_logits: vec![vec![5.0, 0.0, 0.0]],
            ..raw
        };
        assert_eq!(predictions(&none, &names, false)[0].contact, None);
    }
}
