//! Inference backends: one trait, the same outputs whatever runs the network.
//!
//! The default backend is [`tract`] (pure Rust ONNX: nothing to install); cargo feature
//! `onnxruntime` adds [`onnxruntime`] (ONNX Runtime loaded from the PyPI wheel's library),
//! cargo feature `torch` adds [`torch`] (libtorch through tch: the paper's networks from their
//! weights, and TorchScript modules).

#[cfg(feature = "onnxruntime")]
pub(crate) mod onnxruntime;
#[cfg(feature = "torch")]
pub(crate) mod torch;
pub(crate) mod tract;

/// Which backend runs a model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BackendKind {
    /// tract: pure Rust, always built in.
    #[default]
    Tract,
    /// ONNX Runtime (cargo feature `onnxruntime`).
    OnnxRuntime,
    /// libtorch through tch (cargo feature `torch`).
    Torch,
}

impl BackendKind {
    /// Every backend, whether this build has it or not.
    pub const ALL: [BackendKind; 3] = [
        BackendKind::Tract,
        BackendKind::OnnxRuntime,
        BackendKind::Torch,
    ];

    /// Its name on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            BackendKind::Tract => "tract",
            BackendKind::OnnxRuntime => "onnxruntime",
            BackendKind::Torch => "torch",
        }
    }

    /// Whether this build can run it.
    pub fn built_in(self) -> bool {
        match self {
            BackendKind::Tract => true,
            BackendKind::OnnxRuntime => cfg!(feature = "onnxruntime"),
            BackendKind::Torch => cfg!(feature = "torch"),
        }
    }
}

impl std::fmt::Display for BackendKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// A backend name that is not one of [`BackendKind::ALL`].
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown backend \"{0}\" (tract, onnxruntime, torch)")]
pub struct UnknownBackend(pub String);

impl std::str::FromStr for BackendKind {
    type Err = UnknownBackend;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        BackendKind::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| UnknownBackend(s.to_string()))
    }
}

/// What a network gives for a batch, as it gives it.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RawOutputs {
    /// [Fx Fy Fz Mx My Mz Ft] per image (magnitudes, as the reference trains them).
    pub force: Vec<[f32; 7]>,
    /// Shape class logits per image.
    pub shape_logits: Vec<Vec<f32>>,
    /// Contact x, y in mm per image.
    pub contact: Vec<[f32; 2]>,
}

/// Why inference failed.
#[derive(Debug, thiserror::Error)]
pub enum InferenceError {
    #[error(
        "this fringe was built without the {0} backend: rebuild with \
         `cargo build --release --features {0}` (README.md, Models)"
    )]
    NotBuilt(BackendKind),
    #[error("the {backend} backend could not load the model: {detail}")]
    Load {
        backend: &'static str,
        detail: String,
    },
    #[error("the {backend} backend failed to run the model: {detail}")]
    Run {
        backend: &'static str,
        detail: String,
    },
    #[error("the input holds {got} values but {batch} images of 3x{size}x{size} need {want}")]
    InputSize {
        got: usize,
        want: usize,
        batch: usize,
        size: u32,
    },
    #[error("the model's outputs are not force [N,7], shape logits [N,C] and contact [N,2]: {0}")]
    Outputs(String),
}

/// Runs a network on batches of preprocessed images.
pub trait Backend: Send {
    /// The backend's name (`tract`, `onnxruntime`, `torch`).
    fn name(&self) -> &'static str;
    /// Runs `batch` images of 3 x `size` x `size` (CHW, concatenated).
    fn run(&mut self, input: &[f32], batch: usize, size: u32)
        -> Result<RawOutputs, InferenceError>;
}

/// Checks that `input` holds `batch` (at least one) images of 3 x `size` x `size`, as
/// [`Backend::run`] takes them.
pub(crate) fn check_input(input: &[f32], batch: usize, size: u32) -> Result<(), InferenceError> {
    let s = size as usize;
    let want = batch * 3 * s * s;
    if input.len() != want || batch == 0 {
        return Err(InferenceError::InputSize {
            got: input.len(),
            want,
            batch,
            size,
        });
    }
    Ok(())
}

/// Splits a row-major `[batch, width]` output into rows.
pub(crate) fn rows(
    values: &[f32],
    batch: usize,
    width: usize,
    what: &str,
) -> Result<Vec<Vec<f32>>, InferenceError> {
    if width == 0 || values.len() != batch * width {
        return Err(InferenceError::Outputs(format!(
            "{what} holds {} values for {batch} images of width {width}",
            values.len()
        )));
    }
    Ok(values.chunks_exact(width).map(<[f32]>::to_vec).collect())
}

impl RawOutputs {
    /// From the three outputs' values, row-major, checking their widths.
    pub(crate) fn from_flat(
        force: &[f32],
        logits: &[f32],
        classes: usize,
        contact: &[f32],
        batch: usize,
    ) -> Result<RawOutputs, InferenceError> {
        let fix = |v: Vec<f32>| -> [f32; 7] { std::array::from_fn(|i| v[i]) };
        Ok(RawOutputs {
            force: rows(force, batch, 7, "force")?
                .into_iter()
                .map(fix)
                .collect(),
            shape_logits: rows(logits, batch, classes, "shape_logits")?,
            contact: rows(contact, batch, 2, "contact")?
                .into_iter()
                .map(|v| [v[0], v[1]])
                .collect(),
        })
    }
}
