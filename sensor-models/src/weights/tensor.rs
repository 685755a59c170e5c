//! A dense f32 tensor: a shape and its values in row-major (C) order.

/// Element type a tensor had in its file (values are always held as f32 here).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StoredType {
    F32,
    F16,
    BF16,
    F64,
    /// Integer tensors (BatchNorm's `num_batches_tracked`), converted to f32.
    I64,
}

impl StoredType {
    pub fn name(self) -> &'static str {
        match self {
            StoredType::F32 => "f32",
            StoredType::F16 => "f16",
            StoredType::BF16 => "bf16",
            StoredType::F64 => "f64",
            StoredType::I64 => "i64",
        }
    }
}

/// A dense tensor of f32 values.
#[derive(Debug, Clone, PartialEq)]
pub struct Tensor {
    pub shape: Vec<usize>,
    pub data: Vec<f32>,
    /// The element type in the file it came from.
    pub stored: StoredType,
}

impl Tensor {
    /// A tensor of `shape` holding `data` (row-major); `None` when the sizes disagree.
    pub fn new(shape: Vec<usize>, data: Vec<f32>) -> Option<Tensor> {
        (shape.iter().product::<usize>() == data.len()).then_some(Tensor {
            shape,
            data,
            stored: StoredType::F32,
        })
    }

    /// Number of elements.
    pub fn len(&self) -> usize {
        self.data.len()
    }

    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }
}
