//! `fringe-sensor-models`: the models of the photoelastic sensor.
//!
//! - [`tensor`], [`state_dict`]: weights by name as PyTorch's `state_dict()` holds them.
//! - [`model_file`]: [`read_weights`] for any weights file users have, by content.
//! - [`torch_file`]: `.pth` / `.pt` files written by `torch.save` (zip and legacy formats),
//!   read without Python ([`pickle`] reads the pickle, [`torch_pickle`] says what it means).
//! - [`safetensors_file`]: `.safetensors` files, read and written.
#![warn(unreachable_pub)]

mod element;
pub mod model_file;
pub mod model_file_error;
pub mod pickle;
pub mod safetensors_file;
pub mod state_dict;
pub mod tensor;
pub mod torch_file;
mod torch_pickle;

pub use model_file::{detect_format, read_weights, WeightsFormat};
pub use model_file_error::{ModelFileError, ModelFileErrorKind};
pub use safetensors_file::{read_safetensors, write_safetensors};
pub use state_dict::StateDict;
pub use tensor::{StoredType, Tensor};
pub use torch_file::read_torch;
