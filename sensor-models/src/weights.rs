//! Weights by name, and the files they come in.
//!
//! - [`tensor`], [`state_dict`]: weights by name as PyTorch's `state_dict()` holds them.
//! - [`format`]: [`format::read_weights`] for any weights file users have, told apart by
//!   content; [`error`]: what is wrong with a file, naming it.
//! - [`torch_file`]: `.pth` / `.pt` files written by `torch.save` (zip and legacy formats),
//!   read without Python ([`pickle`] reads the pickle, `torch_pickle` says what it means,
//!   `element` decodes the stored numbers).
//! - [`safetensors_file`]: `.safetensors` files, read and written (with the model card in the
//!   header's metadata).
//! - `file_start`: a file's first bytes, read and described for messages.

mod element;
pub(crate) mod error;
mod file_start;
pub(crate) mod format;
pub(crate) mod pickle;
pub(crate) mod safetensors_file;
pub(crate) mod state_dict;
pub(crate) mod tensor;
pub(crate) mod torch_file;
mod torch_pickle;
