//! The paper's two networks in libtorch, with the reference code's parameter names (the names
//! the [`crate::arch`] layout lists), so that a trained state dict maps 1:1 onto the reference
//! classes and onto every backend of this crate.

use crate::arch::Architecture;
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

fn bn(path: nn::Path<'_>, n: i64) -> nn::BatchNorm {
    // PyTorch's BatchNorm2d defaults (weight 1, bias 0, eps 1e-5, momentum 0.1).
    nn::batch_norm2d(
        path,
        n,
        nn::BatchNormConfig {
            ws_init: nn::Init::Const(1.0),
            ..Default::default()
        },
    )
}

fn conv(path: nn::Path<'_>, cin: i64, cout: i64, k: i64, stride: i64, bias: bool) -> nn::Conv2D {
    nn::conv2d(
        path,
        cin,
        cout,
        k,
        nn::ConvConfig {
            stride,
            padding: k / 2,
            bias,
            ..Default::default()
        },
    )
}

/// torchvision's BasicBlock.
#[derive(Debug)]
struct BasicBlock {
    conv1: nn::Conv2D,
    bn1: nn::BatchNorm,
    conv2: nn::Conv2D,
    bn2: nn::BatchNorm,
    downsample: Option<(nn::Conv2D, nn::BatchNorm)>,
}

impl BasicBlock {
    fn new(p: nn::Path<'_>, cin: i64, cout: i64, stride: i64) -> BasicBlock {
        let downsample = (stride != 1 || cin != cout).then(|| {
            let d = &p / "downsample";
            (
                nn::conv2d(
                    &d / 0,
                    cin,
                    cout,
                    1,
                    nn::ConvConfig {
                        stride,
                        bias: false,
                        ..Default::default()
                    },
                ),
                bn(&d / 1, cout),
            )
        });
        BasicBlock {
            conv1: conv(&p / "conv1", cin, cout, 3, stride, false),
            bn1: bn(&p / "bn1", cout),
            conv2: conv(&p / "conv2", cout, cout, 3, 1, false),
            bn2: bn(&p / "bn2", cout),
            downsample,
        }
    }

    fn forward_t(&self, x: &Tensor, train: bool) -> Tensor {
        let y = x
            .apply(&self.conv1)
            .apply_t(&self.bn1, train)
            .relu()
            .apply(&self.conv2)
            .apply_t(&self.bn2, train);
        let identity = match &self.downsample {
            Some((c, b)) => x.apply(c).apply_t(b, train),
            None => x.shallow_clone(),
        };
        (y + identity).relu()
    }
}

#[derive(Debug)]
enum Body {
    Custom(Vec<nn::Conv2D>),
    Resnet18 {
        conv1: nn::Conv2D,
        bn1: Box<nn::BatchNorm>,
        blocks: Vec<BasicBlock>,
    },
}

/// A network of the paper on a [`nn::VarStore`].
#[derive(Debug)]
pub(crate) struct Net {
    body: Body,
    force_head: nn::Linear,
    class_head: nn::Linear,
    point_head: nn::Linear,
}

impl Net {
    pub(crate) fn new(root: &nn::Path<'_>, arch: Architecture, classes: usize) -> Net {
        let body = match arch {
            Architecture::Custom => {
                let ch = [3, 16, 32, 64, 128];
                Body::Custom(
                    (0..4)
                        .map(|i| conv(root / "cnn" / i / "block" / 0, ch[i], ch[i + 1], 3, 1, true))
                        .collect(),
                )
            }
            Architecture::Resnet18 => {
                let b = root / "backbone";
                let mut blocks = Vec::new();
                let widths = [64, 128, 256, 512];
                for (layer, &width) in widths.iter().enumerate() {
                    let input = if layer == 0 { 64 } else { widths[layer - 1] };
                    for block in 0..2 {
                        let p = &b / (layer + 4) / block;
                        let (cin, stride) = if block == 0 {
                            (input, if layer == 0 { 1 } else { 2 })
                        } else {
                            (width, 1)
                        };
                        blocks.push(BasicBlock::new(p, cin, width, stride));
                    }
                }
                Body::Resnet18 {
                    conv1: nn::conv2d(
                        &b / 0,
                        3,
                        64,
                        7,
                        nn::ConvConfig {
                            stride: 2,
                            padding: 3,
                            bias: false,
                            ..Default::default()
                        },
                    ),
                    bn1: Box::new(bn(&b / 1, 64)),
                    blocks,
                }
            }
        };
        let f = arch.features() as i64;
        Net {
            body,
            force_head: nn::linear(root / "force_head", f, 7, Default::default()),
            class_head: nn::linear(root / "class_head", f, classes as i64, Default::default()),
            point_head: nn::linear(root / "point_head", f, 2, Default::default()),
        }
    }

    /// The heads' outputs for an NCHW batch; `train` switches batch norm to batch statistics.
    pub(crate) fn forward(&self, x: &Tensor, train: bool) -> Outputs {
        let features = match &self.body {
            Body::Custom(convs) => {
                let mut y = x.shallow_clone();
                for c in convs {
                    y = y.apply(c).relu().max_pool2d_default(2);
                }
                y
            }
            Body::Resnet18 { conv1, bn1, blocks } => {
                let mut y = x
                    .apply(conv1)
                    .apply_t(bn1.as_ref(), train)
                    .relu()
                    .max_pool2d([3, 3], [2, 2], [1, 1], [1, 1], false);
                for b in blocks {
                    y = b.forward_t(&y, train);
                }
                y
            }
        };
        let features = features.adaptive_avg_pool2d([1, 1]).flatten(1, -1);
        Outputs {
            force: features.apply(&self.force_head),
            logits: features.apply(&self.class_head),
            point: features.apply(&self.point_head),
        }
    }
}
