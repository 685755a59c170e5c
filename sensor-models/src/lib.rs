//! `fringe-sensor-models`: the models of the photoelastic sensor.
//!
//! - [`tensor`], [`state_dict`]: weights by name as PyTorch's `state_dict()` holds them.
//! - [`torch_file`]: `.pth` / `.pt` files written by `torch.save` (zip and legacy formats),
//!   read without Python.
#![warn(unreachable_pub)]

pub mod state_dict;
pub mod tensor;
pub mod torch_file;

pub use state_dict::StateDict;
pub use tensor::{StoredType, Tensor};
