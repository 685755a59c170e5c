//! Between libtorch tensors and this crate's named f32 tensors (the state dict that every
//! model file and backend of the crate reads).

use super::error::TrainError;
use crate::weights::state_dict::StateDict;
use crate::weights::tensor::Tensor as Stored;
use tch::{Kind, Tensor};

/// A libtorch tensor as a stored f32 tensor.
pub(crate) fn to_state(t: &Tensor) -> Result<Stored, TrainError> {
    let shape: Vec<usize> = t.size().iter().map(|&d| d as usize).collect();
    let flat = t.detach().to_kind(Kind::Float).contiguous().view([-1]);
    let data = Vec::<f32>::try_from(&flat).map_err(|e| TrainError::Internal(e.to_string()))?;
    Stored::new(shape, data).ok_or_else(|| TrainError::Internal("tensor size".into()))
}

/// Copies `key` of `sd` into `t` (same shape), without recording gradients.
pub(crate) fn from_state(
    t: &mut Tensor,
    sd: &StateDict,
    key: &str,
    what: &str,
) -> Result<(), TrainError> {
    let src = sd.get(key).ok_or_else(|| TrainError::Checkpoint {
        path: what.to_string(),
        message: format!("no tensor {key}"),
    })?;
    let want: Vec<usize> = t.size().iter().map(|&d| d as usize).collect();
    if src.shape != want {
        return Err(TrainError::Checkpoint {
            path: what.to_string(),
            message: format!("{key} has shape {:?}, the network {want:?}", src.shape),
        });
    }
    let value = Tensor::from_slice(&src.data).view(t.size().as_slice());
    tch::no_grad(|| t.copy_(&value));
    Ok(())
}

/// The network's state dict (parameters and batch-norm buffers, reference names), with each
/// batch norm's `num_batches_tracked` set to `batches`.
pub(crate) fn state_dict(vs: &tch::nn::VarStore, batches: u64) -> Result<StateDict, TrainError> {
    let mut vars: Vec<(String, Tensor)> = vs.variables().into_iter().collect();
    vars.sort_by(|a, b| a.0.cmp(&b.0));
    let mut sd = StateDict::new();
    for (name, t) in &vars {
        sd.insert(name, to_state(t)?);
        if let Some(prefix) = name.strip_suffix(".running_var") {
            let n = Stored::new(vec![], vec![batches as f32])
                .ok_or_else(|| TrainError::Internal("scalar".into()))?;
            sd.insert(&format!("{prefix}.num_batches_tracked"), n);
        }
    }
    Ok(sd)
}

/// Loads a state dict into the network's variables (every variable must be there).
pub(crate) fn load_state_dict(
    vs: &tch::nn::VarStore,
    sd: &StateDict,
    what: &str,
) -> Result<(), TrainError> {
    for (name, mut t) in vs.variables() {
        from_state(&mut t, sd, &name, what)?;
    }
    Ok(())
}
