//! The `torch` backend (cargo feature `torch`): libtorch through tch, on the CPU with `threads`
//! intra-op threads. It runs the paper's networks from their weights (the same libtorch modules
//! that `fringe train` trains, `crate::torch_net`, in eval mode) and TorchScript archives (`torch.jit.script` /
//! `torch.jit.trace` saves) whose forward returns (force, shape logits, contact).

use super::{Backend, InferenceError, RawOutputs};
use crate::arch::Architecture;
use crate::torch_net::state::load_state_dict;
use crate::torch_net::Net;
use crate::weights::state_dict::StateDict;
use std::path::Path;
use tch::{nn, Device, Kind, Tensor};

const NAME: &str = "torch";

fn load_err(e: impl std::fmt::Display) -> InferenceError {
    InferenceError::Load {
        backend: NAME,
        detail: e.to_string(),
    }
}

fn run_err(e: impl std::fmt::Display) -> InferenceError {
    InferenceError::Run {
        backend: NAME,
        detail: e.to_string(),
    }
}

enum Network {
    /// One of the paper's networks on its variable store.
    Weights { vs: nn::VarStore, net: Box<Net> },
    /// A TorchScript module.
    Script(tch::CModule),
}

/// libtorch running one model.
pub(crate) struct TorchBackend {
    network: Network,
    classes: usize,
    threads: usize,
}

impl TorchBackend {
    /// The paper's network `arch` with `classes` shape classes, its weights from `sd` (every
    /// parameter and batch-norm buffer under the reference names).
    pub(crate) fn from_weights(
        arch: Architecture,
        classes: usize,
        sd: &StateDict,
        threads: usize,
    ) -> Result<TorchBackend, InferenceError> {
        let vs = nn::VarStore::new(Device::Cpu);
        let net = Net::new(&vs.root(), arch, classes);
        load_state_dict(&vs, sd, "the weights").map_err(load_err)?;
        Ok(TorchBackend {
            network: Network::Weights {
                vs,
                net: Box::new(net),
            },
            classes,
            threads: threads.max(1),
        })
    }

    /// A TorchScript archive; its number of shape classes is found by running it once on a
    /// blank image of `size` (and checked against `classes` when that is known).
    pub(crate) fn from_script(
        path: &Path,
        classes: Option<usize>,
        size: u32,
        threads: usize,
    ) -> Result<TorchBackend, InferenceError> {
        let mut module = tch::CModule::load(path).map_err(load_err)?;
        module.set_eval();
        let mut b = TorchBackend {
            network: Network::Script(module),
            classes: classes.unwrap_or(0),
            threads: threads.max(1),
        };
        let s = size as i64;
        let probe = b.forward(&Tensor::zeros([1, 3, s, s], (Kind::Float, Device::Cpu)))?;
        let found = probe.1.size().get(1).copied().unwrap_or(0).max(0) as usize;
        match classes {
            Some(n) if n != found => {
                return Err(InferenceError::Outputs(format!(
                    "the module gives {found} shape logits but {n} classes are named"
                )))
            }
            _ => b.classes = found,
        }
        Ok(b)
    }

    /// The number of trainable parameters.
    pub(crate) fn parameters(&self) -> usize {
        let tensors = match &self.network {
            Network::Weights { vs, .. } => vs.trainable_variables(),
            Network::Script(m) => m
                .named_parameters()
                .map(|v| v.into_iter().map(|(_, t)| t).collect())
                .unwrap_or_default(),
        };
        tensors.iter().map(|t| t.numel()).sum()
    }

    /// The number of shape classes the network gives logits for.
    pub(crate) fn classes(&self) -> usize {
        self.classes
    }

    fn forward(&self, x: &Tensor) -> Result<(Tensor, Tensor, Tensor), InferenceError> {
        tch::set_num_threads(self.threads as i32);
        tch::no_grad(|| match &self.network {
            Network::Weights { net, .. } => {
                let out = net.forward(x, false);
                Ok((out.force, out.logits, out.point))
            }
            Network::Script(m) => {
                let out = m
                    .forward_is(&[tch::IValue::Tensor(x.shallow_clone())])
                    .map_err(run_err)?;
                let parts = match out {
                    tch::IValue::Tuple(v) | tch::IValue::GenericList(v) => v,
                    other => {
                        return Err(InferenceError::Outputs(format!(
                            "the module returns {}, not a tuple (force, shape_logits, contact)",
                            ivalue_kind(&other)
                        )))
                    }
                };
                let mut tensors = parts.into_iter().map(|v| match v {
                    tch::IValue::Tensor(t) => Ok(t),
                    other => Err(InferenceError::Outputs(format!(
                        "an output is {}, not a tensor",
                        ivalue_kind(&other)
                    ))),
                });
                match (
                    tensors.next(),
                    tensors.next(),
                    tensors.next(),
                    tensors.next(),
                ) {
                    (Some(f), Some(l), Some(c), None) => Ok((f?, l?, c?)),
                    _ => Err(InferenceError::Outputs(
                        "the module returns a tuple that is not (force, shape_logits, contact)"
                            .into(),
                    )),
                }
            }
        })
    }
}

fn ivalue_kind(v: &tch::IValue) -> &'static str {
    match v {
        tch::IValue::None => "None",
        tch::IValue::Tensor(_) => "one tensor",
        tch::IValue::Double(_) | tch::IValue::Int(_) | tch::IValue::Bool(_) => "a number",
        tch::IValue::GenericDict(_) => "a dict",
        tch::IValue::String(_) => "a string",
        _ => "another value",
    }
}

fn flat(t: &Tensor) -> Result<Vec<f32>, InferenceError> {
    let t = t.to_kind(Kind::Float).contiguous().view([-1]);
    Vec::<f32>::try_from(&t).map_err(|e| InferenceError::Outputs(e.to_string()))
}

impl Backend for TorchBackend {
    fn name(&self) -> &'static str {
        NAME
    }

    fn run(
        &mut self,
        input: &[f32],
        batch: usize,
        size: u32,
    ) -> Result<RawOutputs, InferenceError> {
        super::check_input(input, batch, size)?;
        let s = size as usize;
        let x = Tensor::from_slice(input).view([batch as i64, 3, s as i64, s as i64]);
        let (force, logits, contact) = self.forward(&x)?;
        RawOutputs::from_flat(
            &flat(&force)?,
            &flat(&logits)?,
            self.classes,
            &flat(&contact)?,
            batch,
        )
    }
}
