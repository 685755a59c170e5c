//! Between libtorch tensors and this crate's named f32 tensors (the state dict that every
//! model file and backend of the crate reads).

use crate::weights::state_dict::StateDict;
use crate::weights::tensor::Tensor as Stored;
use tch::{Kind, Tensor};

/// Why a network's variables and a state dict do not go together.
#[derive(Debug, thiserror::Error)]
pub enum StateError {
    #[error("{what}: no tensor {key}")]
    Missing { what: String, key: String },
    #[error("{what}: {key} has shape {got:?}, the network {want:?}")]
    Shape {
        what: String,
        key: String,
        got: Vec<usize>,
        want: Vec<usize>,
    },
    #[error("libtorch tensor of shape {shape:?}: {detail}")]
    Convert { shape: Vec<usize>, detail: String },
}

/// A libtorch tensor as a stored f32 tensor.
pub(crate) fn to_state(t: &Tensor) -> Result<Stored, StateError> {
    let shape: Vec<usize> = t.size().iter().map(|&d| d as usize).collect();
    let flat = t.detach().to_kind(Kind::Float).contiguous().view([-1]);
    let data = Vec::<f32>::try_from(&flat).map_err(|e| StateError::Convert {
        shape: shape.clone(),
        detail: e.to_string(),
    })?;
    Stored::new(shape.clone(), data).ok_or_else(|| StateError::Convert {
        shape,
        detail: "its element count does not match its shape".into(),
    })
}

/// Copies `key` of `sd` into `t` (same shape), without recording gradients.
pub(crate) fn from_state(
    t: &mut Tensor,
    sd: &StateDict,
    key: &str,
    what: &str,
) -> Result<(), StateError> {
    let src = sd.get(key).ok_or_else(|| StateError::Missing {
        what: what.to_string(),
        key: key.to_string(),
    })?;
    let want: Vec<usize> = t.size().iter().map(|&d| d as usize).collect();
    if src.shape != want {
        return Err(StateError::Shape {
            what: what.to_string(),
            key: key.to_string(),
            got: src.shape.clone(),
            want,
        });
    }
    let value = Tensor::from_slice(&src.data).view(t.size().as_slice());
    tch::no_grad(|| t.copy_(&value));
    Ok(())
}

/// The network's state dict (parameters and batch-norm buffers, reference names), with each
/// batch norm's `num_batches_tracked` set to `batches`.
pub(crate) fn state_dict(vs: &tch::nn::VarStore, batches: u64) -> Result<StateDict, StateError> {
    let mut vars: Vec<(String, Tensor)> = vs.variables().into_iter().collect();
    vars.sort_by(|a, b| a.0.cmp(&b.0));
    let mut sd = StateDict::new();
    for (name, t) in &vars {
        sd.insert(name, to_state(t)?);
        if let Some(prefix) = name.strip_suffix(".running_var") {
            let n =
                Stored::new(vec![], vec![batches as f32]).ok_or_else(|| StateError::Convert {
                    shape: vec![],
                    detail: "a scalar".into(),
                })?;
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
) -> Result<(), StateError> {
    for (name, mut t) in vs.variables() {
        from_state(&mut t, sd, &name, what)?;
    }
    Ok(())
}
