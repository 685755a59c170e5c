//! The paper's two networks, as the reference code's state dicts lay them out, recognised from
//! the weight keys.
//!
//! - Custom CNN ("IsoNet"): `cnn.{0..3}.block.0.{weight,bias}` (conv 3x3 pad 1, ReLU, max-pool
//!   2; channels 3 -> 16 -> 32 -> 64 -> 128), adaptive average pool, heads `force_head`
//!   (128 -> 7), `class_head` (128 -> classes), `point_head` (128 -> 2).
//! - ResNet-18 multitask: torchvision's ResNet-18 without `fc`, wrapped as
//!   `backbone = Sequential(conv1, bn1, relu, maxpool, layer1..layer4, avgpool)` (so
//!   `backbone.0` is conv1, `backbone.4` layer1 ... `backbone.7` layer4), the same heads on 512
//!   features.
//! - Keypoint CNN (fringe's own, not the paper's): the custom CNN's four convolutions
//!   (`kp.{0..3}.conv.{weight,bias}`, the same widths) without the last max-pool, so the last
//!   feature map keeps an eighth of the input's resolution (14x14 at 112 px), and [`Keypoints`]:
//!   16 maps (a 1x1 convolution, `keypoints.{weight,bias}`), each a softmax over the positions
//!   whose expected position (x, y, -1 to 1 across the map) is read out. The heads read the
//!   pooled 128 features and the 32 coordinates. Global average pooling keeps what is seen but
//!   not where: the paper's two networks can tell position only from the disc's edge within
//!   their view, and the contact point is a position.
//!
//! [`Architecture::body`] is the one description of a network: the weight layout checked here,
//! the ONNX graph (`onnx_graph`) and the libtorch network (`torch_net`) are all built from its
//! [`Layer`]s. A new architecture is a variant here with its name and its body; nothing else
//! names the variants.

use crate::weights::state_dict::StateDict;
use fringe_rig::reference_layout::NO_CONTACT;
use std::fmt;

/// A network architecture: the paper's two and fringe's keypoint CNN.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Architecture {
    /// The paper's custom CNN ("IsoNet").
    Custom,
    /// ResNet-18 with three heads.
    Resnet18,
    /// The custom CNN's convolutions with keypoints that keep where the fringes are.
    Keypoint,
}

/// Expected positions of softmax maps (spatial soft-argmax) read from the body's last feature
/// map: a 1x1 convolution `key` from `channels` to `maps` maps, a softmax over each map's
/// positions, then per map its expected x and y, from -1 at the first column's (row's) far
/// edge to 1 at the last one's (position centres at `(2 i + 1) / n - 1`), x right and y down.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Keypoints {
    pub key: String,
    pub channels: usize,
    pub maps: usize,
}

impl Keypoints {
    /// The 1x1 convolution to the maps.
    pub fn conv(&self) -> Conv {
        Conv {
            key: self.key.clone(),
            cin: self.channels,
            cout: self.maps,
            kernel: 1,
            stride: 1,
            padding: 0,
            bias: true,
        }
    }
}

impl Architecture {
    /// Every architecture, in the order weights are recognised.
    pub const ALL: [Architecture; 3] = [
        Architecture::Custom,
        Architecture::Resnet18,
        Architecture::Keypoint,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Architecture::Custom => "custom",
            Architecture::Resnet18 => "resnet18",
            Architecture::Keypoint => "keypoint",
        }
    }

    /// The architecture of a name ([`Architecture::name`]).
    pub fn from_name(name: &str) -> Option<Architecture> {
        Architecture::ALL.into_iter().find(|a| a.name() == name)
    }

    /// The network's body, from the input image to the features the heads read: the one
    /// description that the weight layout, the ONNX graph and the libtorch network are built from.
    pub fn body(self) -> Vec<Layer> {
        match self {
            Architecture::Custom => (0..4)
                .flat_map(|i| [conv3(format!("cnn.{i}.block.0"), i), Layer::Relu, pool2()])
                .collect(),
            Architecture::Keypoint => (0..4)
                .flat_map(|i| {
                    let pool = (i < 3).then(pool2);
                    [conv3(format!("kp.{i}.conv"), i), Layer::Relu]
                        .into_iter()
                        .chain(pool)
                })
                .collect(),
            Architecture::Resnet18 => {
                let mut body = vec![
                    Layer::Conv(Conv {
                        key: "backbone.0".into(),
                        cin: 3,
                        cout: 64,
                        kernel: 7,
                        stride: 2,
                        padding: 3,
                        bias: false,
                    }),
                    Layer::BatchNorm {
                        key: "backbone.1".into(),
                        channels: 64,
                    },
                    Layer::Relu,
                    Layer::MaxPool {
                        kernel: 3,
                        stride: 2,
                        padding: 1,
                    },
                ];
                let widths = [64, 128, 256, 512];
                for (layer, &width) in widths.iter().enumerate() {
                    let input = if layer == 0 { 64 } else { widths[layer - 1] };
                    for block in 0..2 {
                        let key = format!("backbone.{}.{block}", layer + 4);
                        let (cin, stride) = match (layer, block) {
                            (0, _) => (input, 1),
                            (_, 0) => (input, 2),
                            _ => (width, 1),
                        };
                        body.extend(basic_block(&key, cin, width, stride));
                    }
                }
                body
            }
        }
    }

    /// The keypoints read beside the pooled features, for the architectures that have them.
    pub fn keypoints(self) -> Option<Keypoints> {
        match self {
            Architecture::Keypoint => Some(Keypoints {
                key: "keypoints".into(),
                channels: channels_out(&self.body()).unwrap_or(0),
                maps: 16,
            }),
            Architecture::Custom | Architecture::Resnet18 => None,
        }
    }

    /// Whether its last convolution block can be trained again with the heads when a unit is
    /// adapted (commissioning's `--last-block`, `adapt/last_block.rs`): the custom CNN's
    /// only, whose block that training knows.
    pub fn trains_last_block(self) -> bool {
        match self {
            Architecture::Custom => true,
            Architecture::Resnet18 | Architecture::Keypoint => false,
        }
    }

    /// Features the heads read: the body's output channels (pooled), then each keypoint's x
    /// and y.
    pub fn features(self) -> usize {
        channels_out(&self.body()).unwrap_or(0) + self.keypoints().map_or(0, |k| 2 * k.maps)
    }

    /// Every weight key with its shape, for `classes` shape classes.
    pub fn layout(self, classes: usize) -> Vec<(String, Vec<usize>)> {
        let mut keys = Vec::new();
        for layer in &self.body() {
            layer.weights(&mut keys);
        }
        if let Some(k) = self.keypoints() {
            Layer::Conv(k.conv()).weights(&mut keys);
        }
        let f = self.features();
        for (head, out) in [
            ("force_head", 7),
            ("class_head", classes),
            ("point_head", 2),
        ] {
            keys.push((format!("{head}.weight"), vec![out, f]));
            keys.push((format!("{head}.bias"), vec![out]));
        }
        keys
    }
}

/// A 2-D convolution with a square kernel; `key` is the prefix of its weights.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Conv {
    pub key: String,
    pub cin: usize,
    pub cout: usize,
    pub kernel: usize,
    pub stride: usize,
    pub padding: usize,
    pub bias: bool,
}

/// One step of a network's body, in the order the input goes through it. After the body, every
/// architecture has the same end: global average pooling (with the [`Keypoints`] beside it, for
/// the architectures that have them), then three linear heads on the features (`force_head` 7
/// outputs, `class_head` one per shape class, `point_head` 2).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Layer {
    Conv(Conv),
    /// Batch normalisation (PyTorch's defaults: eps 1e-5) with its running statistics.
    BatchNorm {
        key: String,
        channels: usize,
    },
    Relu,
    /// Max pooling with a square kernel.
    MaxPool {
        kernel: usize,
        stride: usize,
        padding: usize,
    },
    /// The sum of `main` and `skip` applied to the same input (an empty `skip`: the input).
    Residual {
        main: Vec<Layer>,
        skip: Vec<Layer>,
    },
}

impl Layer {
    /// Appends this step's weight keys and shapes.
    fn weights(&self, keys: &mut Vec<(String, Vec<usize>)>) {
        match self {
            Layer::Conv(c) => {
                keys.push((
                    format!("{}.weight", c.key),
                    vec![c.cout, c.cin, c.kernel, c.kernel],
                ));
                if c.bias {
                    keys.push((format!("{}.bias", c.key), vec![c.cout]));
                }
            }
            Layer::BatchNorm { key, channels } => {
                for name in ["weight", "bias", "running_mean", "running_var"] {
                    keys.push((format!("{key}.{name}"), vec![*channels]));
                }
                keys.push((format!("{key}.num_batches_tracked"), vec![]));
            }
            Layer::Relu | Layer::MaxPool { .. } => {}
            Layer::Residual { main, skip } => {
                for l in main.iter().chain(skip) {
                    l.weights(keys);
                }
            }
        }
    }
}

/// The widths of the custom CNN's four convolutions (the keypoint CNN's too).
const SMALL_WIDTHS: [usize; 5] = [3, 16, 32, 64, 128];

/// The `i`-th convolution of the custom CNN's widths (3x3, padding 1, with bias) under `key`.
fn conv3(key: String, i: usize) -> Layer {
    Layer::Conv(Conv {
        key,
        cin: SMALL_WIDTHS[i],
        cout: SMALL_WIDTHS[i + 1],
        kernel: 3,
        stride: 1,
        padding: 1,
        bias: true,
    })
}

/// Max pooling 2x2, stride 2.
fn pool2() -> Layer {
    Layer::MaxPool {
        kernel: 2,
        stride: 2,
        padding: 0,
    }
}

/// The channels that come out of `layers` (None if no step sets them).
fn channels_out(layers: &[Layer]) -> Option<usize> {
    layers.iter().rev().find_map(|l| match l {
        Layer::Conv(c) => Some(c.cout),
        Layer::BatchNorm { channels, .. } => Some(*channels),
        Layer::Relu | Layer::MaxPool { .. } => None,
        Layer::Residual { main, .. } => channels_out(main),
    })
}

/// torchvision's BasicBlock under `key`: conv 3x3 (stride), batch norm, ReLU, conv 3x3, batch
/// norm, plus the input (through a 1x1 conv and batch norm, `downsample`, when the stride or the
/// width changes), then ReLU.
fn basic_block(key: &str, cin: usize, cout: usize, stride: usize) -> [Layer; 2] {
    let conv = |name: &str, cin, kernel, stride, padding| {
        Layer::Conv(Conv {
            key: format!("{key}.{name}"),
            cin,
            cout,
            kernel,
            stride,
            padding,
            bias: false,
        })
    };
    let bn = |name: &str| Layer::BatchNorm {
        key: format!("{key}.{name}"),
        channels: cout,
    };
    let skip = if stride != 1 || cin != cout {
        vec![conv("downsample.0", cin, 1, stride, 0), bn("downsample.1")]
    } else {
        Vec::new()
    };
    [
        Layer::Residual {
            main: vec![
                conv("conv1", cin, 3, stride, 1),
                bn("bn1"),
                Layer::Relu,
                conv("conv2", cout, 3, 1, 1),
                bn("bn2"),
            ],
            skip,
        },
        Layer::Relu,
    ]
}

impl fmt::Display for Architecture {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Architecture::Custom => "custom CNN",
            Architecture::Resnet18 => "ResNet-18 multitask",
            Architecture::Keypoint => "keypoint CNN",
        })
    }
}

/// Why weights are not one of the paper's networks.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ArchError {
    #[error(
        "the weights are none of the custom CNN (cnn.N.block.0.*), the ResNet-18 multitask \
         (backbone.*) and the keypoint CNN (kp.N.conv.*, keypoints.*) with force_head, \
         class_head and point_head; found {found}"
    )]
    Unknown { found: String },
    #[error("{arch} weights: missing {missing}{extra}")]
    Missing {
        arch: Architecture,
        missing: String,
        extra: String,
    },
    #[error("{arch} weights: unexpected keys {extra}")]
    Extra { arch: Architecture, extra: String },
    #[error("{arch} weights: {key} has shape {got:?}, expected {want:?}")]
    Shape {
        arch: Architecture,
        key: String,
        got: Vec<usize>,
        want: Vec<usize>,
    },
    #[error(
        "class_head has {0} outputs: a model needs at least 2 shape classes (None and one shape)"
    )]
    Classes(usize),
}

/// Lists at most 6 names, then how many more.
fn list<'a>(names: impl Iterator<Item = &'a str>) -> String {
    let all: Vec<&str> = names.collect();
    let shown = all.iter().take(6).copied().collect::<Vec<_>>().join(", ");
    match all.len() {
        0..=6 => shown,
        n => format!("{shown} and {} more", n - 6),
    }
}

/// Recognises the architecture and the number of shape classes from the keys, and checks every
/// key and shape (missing and unexpected keys are named).
pub fn recognise(sd: &StateDict) -> Result<(Architecture, usize), ArchError> {
    // Each architecture is told by its first weight (the first convolution's).
    let first_key = |a: Architecture| a.layout(2).into_iter().next().map(|(k, _)| k);
    let arch = if let Some(arch) = Architecture::ALL
        .into_iter()
        .find(|&a| first_key(a).is_some_and(|k| sd.contains(&k)))
    {
        arch
    } else {
        let mut prefixes: Vec<&str> = sd
            .keys()
            .map(|k| k.split('.').next().unwrap_or(k))
            .collect();
        prefixes.dedup();
        let found = if sd.is_empty() {
            "no tensors".to_string()
        } else {
            format!("{} tensors under {}", sd.len(), list(prefixes.into_iter()))
        };
        return Err(ArchError::Unknown { found });
    };
    let classes = sd
        .get("class_head.weight")
        .and_then(|t| t.shape.first().copied())
        .unwrap_or(0);
    let layout = arch.layout(classes.max(2));
    let missing: Vec<&str> = layout
        .iter()
        .map(|(k, _)| k.as_str())
        .filter(|k| !sd.contains(k))
        .collect();
    let extra: Vec<&str> = sd
        .keys()
        .filter(|k| !layout.iter().any(|(l, _)| l == k))
        .collect();
    if !missing.is_empty() {
        return Err(ArchError::Missing {
            arch,
            missing: list(missing.into_iter()),
            extra: if extra.is_empty() {
                String::new()
            } else {
                format!("; unexpected {}", list(extra.into_iter()))
            },
        });
    }
    if !extra.is_empty() {
        return Err(ArchError::Extra {
            arch,
            extra: list(extra.into_iter()),
        });
    }
    if classes < 2 {
        return Err(ArchError::Classes(classes));
    }
    for (key, want) in &layout {
        if let Some(t) = sd.get(key) {
            // Scalars may be stored as [] or [1].
            let ok = &t.shape == want || (want.is_empty() && t.len() == 1);
            if !ok {
                return Err(ArchError::Shape {
                    arch,
                    key: key.clone(),
                    got: t.shape.clone(),
                    want: want.clone(),
                });
            }
        }
    }
    Ok((arch, classes))
}

/// Shape class names for `n` classes: "None" first, then the shapes in sorted order. Without a
/// model card, three classes are the paper's (None, pentagon, rectangle).
pub(crate) fn default_class_names(n: usize) -> Vec<String> {
    if n == 3 {
        return [NO_CONTACT, "pentagon", "rectangle"]
            .map(String::from)
            .to_vec();
    }
    std::iter::once(NO_CONTACT.to_string())
        .chain((1..n).map(|i| format!("shape {i}")))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::weights::tensor::Tensor;

    pub(crate) fn zeros(arch: Architecture, classes: usize) -> StateDict {
        StateDict::from_pairs(arch.layout(classes).into_iter().map(|(k, s)| {
            let n = s.iter().product();
            (k, Tensor::new(s, vec![0.0; n]).expect("tensor"))
        }))
    }

    #[test]
    fn parameter_counts_are_the_networks() {
        // About 99k for the custom CNN (paper); torchvision's ResNet-18 has 11 176 512
        // parameters without fc.
        let c = zeros(Architecture::Custom, 3).parameter_count();
        assert_eq!(c, 97_440 + 1_548);
        let r = zeros(Architecture::Resnet18, 3).parameter_count();
        assert_eq!(r, 11_176_512 + 512 * 12 + 12);
        // The custom CNN's convolutions, 16 keypoint maps on 128 channels, heads on 160.
        let k = zeros(Architecture::Keypoint, 3).parameter_count();
        assert_eq!(k, 97_440 + (128 * 16 + 16) + 160 * 12 + 12);
    }

    #[test]
    fn architecture_and_classes_come_from_the_keys() {
        assert_eq!(
            recognise(&zeros(Architecture::Custom, 3)),
            Ok((Architecture::Custom, 3))
        );
        assert_eq!(
            recognise(&zeros(Architecture::Resnet18, 5)),
            Ok((Architecture::Resnet18, 5))
        );
        assert_eq!(
            recognise(&zeros(Architecture::Keypoint, 3)),
            Ok((Architecture::Keypoint, 3))
        );
        for a in Architecture::ALL {
            assert_eq!(Architecture::from_name(a.name()), Some(a));
        }
    }

    #[test]
    fn missing_extra_and_misshapen_keys_are_named() {
        let mut sd = zeros(Architecture::Custom, 3);
        let mut pairs: Vec<(String, Tensor)> = sd
            .iter()
            .filter(|(k, _)| *k != "point_head.bias")
            .map(|(k, t)| (k.to_string(), t.clone()))
            .collect();
        pairs.push((
            "extra.weight".into(),
            Tensor::new(vec![1], vec![0.0]).expect("t"),
        ));
        let e = recognise(&StateDict::from_pairs(pairs)).expect_err("missing");
        let msg = e.to_string();
        assert!(msg.contains("missing point_head.bias"), "{msg}");
        assert!(msg.contains("unexpected extra.weight"), "{msg}");
        sd.insert(
            "force_head.weight",
            Tensor::new(vec![6, 128], vec![0.0; 768]).expect("t"),
        );
        let msg = recognise(&sd).expect_err("shape").to_string();
        assert!(
            msg.contains("force_head.weight has shape [6, 128]"),
            "{msg}"
        );
        let msg = recognise(&StateDict::new()).expect_err("empty").to_string();
        assert!(msg.contains("no tensors"), "{msg}");
    }
}
