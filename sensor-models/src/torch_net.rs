//! The networks of [`crate::arch`] in libtorch (cargo feature `torch`), built from each
//! architecture's one description ([`Architecture::body`]) with the reference code's parameter
//! names, so that a trained state dict maps 1:1 onto the reference classes and onto every
//! backend of this crate. Training (`train`) and the `torch` inference backend both run them.
//!
//! - [`state`]: between libtorch variables and this crate's named tensors.

pub(crate) mod state;

use crate::arch::{Architecture, Conv, Layer};
use tch::nn;
use tch::Tensor;

/// The three heads' outputs for a batch.
pub(crate) struct Outputs {
    /// [N, 7]: Fx Fy Fz Mx My Mz Ft (magnitudes).
    pub force: Tensor,
    /// [N, classes] shape logits.
    pub logits: Tensor,
    /// [N, 2] contact x, y in mm.
    pub point: Tensor,
}

/// One step of the body with its variables.
#[derive(Debug)]
enum Step {
    Conv(nn::Conv2D),
    BatchNorm(nn::BatchNorm),
    Relu,
    MaxPool {
        kernel: i64,
        stride: i64,
        padding: i64,
    },
    Residual {
        main: Vec<Step>,
        skip: Vec<Step>,
    },
}

/// The variable path of a dotted state-dict key (`backbone.4.0.conv1`).
fn path<'a>(root: &nn::Path<'a>, key: &str) -> nn::Path<'a> {
    let mut parts = key.split('.');
    let first = root / parts.next().unwrap_or_default();
    parts.fold(first, |p, part| &p / part)
}

fn steps(root: &nn::Path<'_>, layers: &[Layer]) -> Vec<Step> {
    layers
        .iter()
        .map(|layer| match layer {
            Layer::Conv(c) => Step::Conv(conv(root, c)),
            Layer::BatchNorm { key, channels } => Step::BatchNorm(nn::batch_norm2d(
                path(root, key),
                *channels as i64,
                // PyTorch's BatchNorm2d defaults (weight 1, bias 0, eps 1e-5, momentum 0.1).
                nn::BatchNormConfig {
                    ws_init: nn::Init::Const(1.0),
                    ..Default::default()
                },
            )),
            Layer::Relu => Step::Relu,
            Layer::MaxPool {
                kernel,
                stride,
                padding,
            } => Step::MaxPool {
                kernel: *kernel as i64,
                stride: *stride as i64,
                padding: *padding as i64,
            },
            Layer::Residual { main, skip } => Step::Residual {
                main: steps(root, main),
                skip: steps(root, skip),
            },
        })
        .collect()
}

fn conv(root: &nn::Path<'_>, c: &Conv) -> nn::Conv2D {
    nn::conv2d(
        path(root, &c.key),
        c.cin as i64,
        c.cout as i64,
        c.kernel as i64,
        nn::ConvConfig {
            stride: c.stride as i64,
            padding: c.padding as i64,
            bias: c.bias,
            ..Default::default()
        },
    )
}

fn forward(steps: &[Step], x: &Tensor, train: bool) -> Tensor {
    let mut y = x.shallow_clone();
    for step in steps {
        y = match step {
            Step::Conv(c) => y.apply(c),
            Step::BatchNorm(b) => y.apply_t(b, train),
            Step::Relu => y.relu(),
            Step::MaxPool {
                kernel,
                stride,
                padding,
            } => y.max_pool2d(
                [*kernel, *kernel],
                [*stride, *stride],
                [*padding, *padding],
                [1, 1],
                false,
            ),
            Step::Residual { main, skip } => forward(main, &y, train) + forward(skip, &y, train),
        };
    }
    y
}

/// A network on a [`nn::VarStore`].
#[derive(Debug)]
pub(crate) struct Net {
    body: Vec<Step>,
    keypoints: Option<nn::Conv2D>,
    force_head: nn::Linear,
    class_head: nn::Linear,
    point_head: nn::Linear,
    /// Batch norm keeps its running statistics in training too.
    batch_norm_frozen: bool,
}

impl Net {
    pub(crate) fn new(root: &nn::Path<'_>, arch: Architecture, classes: usize) -> Net {
        let f = arch.features() as i64;
        Net {
            body: steps(root, &arch.body()),
            keypoints: arch.keypoints().map(|k| conv(root, &k.conv())),
            force_head: nn::linear(root / "force_head", f, 7, Default::default()),
            class_head: nn::linear(root / "class_head", f, classes as i64, Default::default()),
            point_head: nn::linear(root / "point_head", f, 2, Default::default()),
            batch_norm_frozen: false,
        }
    }

    /// Batch norm normalises with the running statistics it has, in training too, and no longer
    /// updates them (fine-tuning on a small set from a trained model, whose heads were fitted
    /// to features normalised with them).
    pub(crate) fn freeze_batch_norm(&mut self) {
        self.batch_norm_frozen = true;
    }

    /// The heads' outputs for an NCHW batch; `train` switches batch norm to batch statistics
    /// (unless it is frozen).
    pub(crate) fn forward(&self, x: &Tensor, train: bool) -> Outputs {
        let map = forward(&self.body, x, train && !self.batch_norm_frozen);
        let pooled = map.adaptive_avg_pool2d([1, 1]).flatten(1, -1);
        let features = match &self.keypoints {
            Some(k) => Tensor::cat(&[pooled, keypoints(&map.apply(k))], 1),
            None => pooled,
        };
        Outputs {
            force: features.apply(&self.force_head),
            logits: features.apply(&self.class_head),
            point: features.apply(&self.point_head),
        }
    }
}

/// The expected positions of the softmax maps [N, K, H, W] as [N, 2 K] (x0, y0, x1, y1, ...;
/// `arch::Keypoints`).
fn keypoints(maps: &Tensor) -> Tensor {
    let (n, k, h, w) = maps.size4().unwrap_or((0, 0, 0, 0));
    let p = maps
        .view([n, k, h * w])
        .softmax(-1, tch::Kind::Float)
        .view([n, k, h, w]);
    let positions = |len: i64| {
        (Tensor::arange(len, (tch::Kind::Float, maps.device())) * 2.0 + 1.0) / len as f64 - 1.0
    };
    let x = (p.sum_dim_intlist(2, false, tch::Kind::Float) * positions(w)).sum_dim_intlist(
        -1,
        true,
        tch::Kind::Float,
    );
    let y = (p.sum_dim_intlist(3, false, tch::Kind::Float) * positions(h)).sum_dim_intlist(
        -1,
        true,
        tch::Kind::Float,
    );
    Tensor::cat(&[x, y], -1).flatten(1, -1)
}
