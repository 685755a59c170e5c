//! Adam as `torch.optim.Adam` computes it (defaults: betas 0.9 / 0.999, eps 1e-8, no weight
//! decay), with its state kept by parameter name so that a checkpoint holds it and a resumed
//! training continues exactly.

use super::error::TrainError;
use crate::torch_net::state::{from_state, to_state};
use crate::weights::state_dict::StateDict;
use tch::Tensor;

const BETA1: f64 = 0.9;
const BETA2: f64 = 0.999;
const EPS: f64 = 1e-8;

/// The optimiser over the trainable parameters of a var store.
pub(crate) struct Adam {
    lr: f64,
    step: i64,
    /// (name, parameter, exp_avg, exp_avg_sq), in name order.
    params: Vec<(String, Tensor, Tensor, Tensor)>,
}

impl Adam {
    pub(crate) fn new(vs: &tch::nn::VarStore, lr: f64) -> Adam {
        let mut vars: Vec<(String, Tensor)> = vs
            .variables()
            .into_iter()
            .filter(|(_, t)| t.requires_grad())
            .collect();
        vars.sort_by(|a, b| a.0.cmp(&b.0));
        let params = vars
            .into_iter()
            .map(|(name, p)| {
                let m = p.zeros_like();
                let v = p.zeros_like();
                (name, p, m, v)
            })
            .collect();
        Adam {
            lr,
            step: 0,
            params,
        }
    }

    /// The rate of the steps that follow (a schedule's).
    pub(crate) fn set_lr(&mut self, lr: f64) {
        self.lr = lr;
    }

    pub(crate) fn zero_grad(&mut self) {
        for (_, p, _, _) in &mut self.params {
            p.zero_grad();
        }
    }

    /// One update from the gradients of the last backward pass.
    pub(crate) fn step(&mut self) {
        self.step += 1;
        let bc1 = 1.0 - BETA1.powi(self.step as i32);
        let bc2 = 1.0 - BETA2.powi(self.step as i32);
        let step_size = self.lr / bc1;
        tch::no_grad(|| {
            for (_, p, m, v) in &mut self.params {
                let g = p.grad();
                if !g.defined() {
                    continue;
                }
                let new_m = &*m * BETA1 + &g * (1.0 - BETA1);
                m.copy_(&new_m);
                let new_v = &*v * BETA2 + &g * &g * (1.0 - BETA2);
                v.copy_(&new_v);
                let denom = v.sqrt() / bc2.sqrt() + EPS;
                let new_p = &*p - (&*m / denom) * step_size;
                p.copy_(&new_p);
            }
        });
    }

    /// The state as named tensors: `exp_avg.<param>`, `exp_avg_sq.<param>`, `step`.
    pub(crate) fn state(&self) -> Result<StateDict, TrainError> {
        let mut sd = StateDict::new();
        for (name, _, m, v) in &self.params {
            sd.insert(&format!("exp_avg.{name}"), to_state(m)?);
            sd.insert(&format!("exp_avg_sq.{name}"), to_state(v)?);
        }
        let step = crate::weights::tensor::Tensor::new(vec![1], vec![self.step as f32])
            .ok_or_else(|| TrainError::Internal("step tensor".into()))?;
        sd.insert("step", step);
        Ok(sd)
    }

    /// Restores a state written by [`Adam::state`]; `what` names the file for messages.
    pub(crate) fn restore(&mut self, sd: &StateDict, what: &str) -> Result<(), TrainError> {
        let step = sd
            .get("step")
            .and_then(|t| t.data.first().copied())
            .ok_or_else(|| TrainError::Checkpoint {
                path: what.to_string(),
                message: "no optimiser step count".into(),
            })?;
        self.step = step as i64;
        for (name, _, m, v) in &mut self.params {
            from_state(m, sd, &format!("exp_avg.{name}"), what)?;
            from_state(v, sd, &format!("exp_avg_sq.{name}"), what)?;
        }
        Ok(())
    }
}
