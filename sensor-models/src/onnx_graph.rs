//! The ONNX graph of a network, built from its weights: what the default backend runs and what
//! `fringe model export --onnx` writes.
//!
//! Input `image` [N, 3, S, S] (N and S free); outputs `force` [N, 7], `shape_logits` [N, C] and
//! `contact` [N, 2]. Operators of opset 17: Conv, Relu, MaxPool, BatchNormalization (inference),
//! Add, GlobalAveragePool, Flatten, Gemm; the keypoints add Shape, Gather, Range, Cast,
//! Reshape, Softmax, ReduceSum, Mul, Div, Sub, Concat and work out their positions from the
//! feature map's size, so the graph takes any input size as the others do. Weights are stored
//! as f32 initialisers under their state-dict names, so the graph's weights can be read back by
//! name.

use crate::arch::{Architecture, Conv, Keypoints, Layer};
use crate::weights::state_dict::StateDict;
use tract_onnx::pb;

/// ONNX opset the graph is written for.
pub const OPSET: i64 = 17;
/// Input and output names.
pub const INPUT: &str = "image";
pub const OUTPUTS: [&str; 3] = ["force", "shape_logits", "contact"];

/// Builds nodes one after another, naming their outputs.
struct Builder<'a> {
    sd: &'a StateDict,
    nodes: Vec<pb::NodeProto>,
    initializers: Vec<pb::TensorProto>,
    counter: usize,
}

fn ints(name: &str, values: &[i64]) -> pb::AttributeProto {
    pb::AttributeProto {
        name: name.into(),
        r#type: pb::attribute_proto::AttributeType::Ints as i32,
        ints: values.to_vec(),
        ..Default::default()
    }
}

fn int(name: &str, value: i64) -> pb::AttributeProto {
    pb::AttributeProto {
        name: name.into(),
        r#type: pb::attribute_proto::AttributeType::Int as i32,
        i: value,
        ..Default::default()
    }
}

fn float(name: &str, value: f32) -> pb::AttributeProto {
    pb::AttributeProto {
        name: name.into(),
        r#type: pb::attribute_proto::AttributeType::Float as i32,
        f: value,
        ..Default::default()
    }
}

impl Builder<'_> {
    /// Adds the state-dict tensor `key` as an initialiser and returns its name.
    fn weight(&mut self, key: &str) -> String {
        if !self.initializers.iter().any(|t| t.name == key) {
            let (dims, data) = match self.sd.get(key) {
                Some(t) => (
                    t.shape.iter().map(|&d| d as i64).collect(),
                    t.data.iter().flat_map(|v| v.to_le_bytes()).collect(),
                ),
                // `recognise` checked every key before a graph is built.
                None => (vec![0], Vec::new()),
            };
            self.initializers.push(pb::TensorProto {
                name: key.into(),
                dims,
                data_type: pb::tensor_proto::DataType::Float as i32,
                raw_data: data,
                ..Default::default()
            });
        }
        key.to_string()
    }

    fn node(&mut self, op: &str, inputs: Vec<String>, attrs: Vec<pb::AttributeProto>) -> String {
        self.counter += 1;
        let out = format!("{}_{}", op.to_lowercase(), self.counter);
        self.node_named(op, inputs, attrs, &out);
        out
    }

    fn node_named(
        &mut self,
        op: &str,
        inputs: Vec<String>,
        attrs: Vec<pb::AttributeProto>,
        out: &str,
    ) {
        self.nodes.push(pb::NodeProto {
            input: inputs,
            output: vec![out.into()],
            name: format!("{op}_{}", self.nodes.len()),
            op_type: op.into(),
            attribute: attrs,
            ..Default::default()
        });
    }

    /// A constant (not a weight) as an initialiser, named after the node count.
    fn constant(&mut self, dims: &[i64], value: Constant) -> String {
        self.counter += 1;
        let name = format!("const_{}", self.counter);
        let (data_type, raw_data) = match value {
            Constant::I64(v) => (
                pb::tensor_proto::DataType::Int64,
                v.iter().flat_map(|x| x.to_le_bytes()).collect(),
            ),
            Constant::F32(v) => (
                pb::tensor_proto::DataType::Float,
                v.iter().flat_map(|x| x.to_le_bytes()).collect(),
            ),
        };
        self.initializers.push(pb::TensorProto {
            name: name.clone(),
            dims: dims.to_vec(),
            data_type: data_type as i32,
            raw_data,
            ..Default::default()
        });
        name
    }

    /// The keypoints' coordinates [N, 2 maps] (x0, y0, x1, y1, ...) of the feature map `x`
    /// [N, C, H, W] (see [`Keypoints`]).
    fn keypoints(&mut self, x: String, k: &Keypoints) -> String {
        let maps = self.conv(x, &k.conv());
        let shape = self.node("Shape", vec![maps.clone()], vec![]);
        let flat_shape = self.constant(&[3], Constant::I64(vec![0, 0, -1]));
        let flat = self.node("Reshape", vec![maps, flat_shape], vec![]);
        let soft = self.node("Softmax", vec![flat], vec![int("axis", -1)]);
        let p = self.node("Reshape", vec![soft, shape.clone()], vec![]);
        // Along x (W, axis 3) the marginal sums over the rows (axis 2), and the other way.
        let mut coords = Vec::new();
        for (dim, summed) in [(3, 2), (2, 3)] {
            let index = self.constant(&[], Constant::I64(vec![dim]));
            let n = self.node("Gather", vec![shape.clone(), index], vec![int("axis", 0)]);
            let (zero, one) = (
                self.constant(&[], Constant::I64(vec![0])),
                self.constant(&[], Constant::I64(vec![1])),
            );
            let i = self.node("Range", vec![zero, n.clone(), one], vec![]);
            let to_float = vec![int("to", pb::tensor_proto::DataType::Float as i64)];
            let i = self.node("Cast", vec![i], to_float.clone());
            let n = self.node("Cast", vec![n], to_float);
            // (2 i + 1) / n - 1
            let two = self.constant(&[], Constant::F32(vec![2.0]));
            let one_f = self.constant(&[], Constant::F32(vec![1.0]));
            let twice = self.node("Mul", vec![i, two], vec![]);
            let odd = self.node("Add", vec![twice, one_f.clone()], vec![]);
            let scaled = self.node("Div", vec![odd, n], vec![]);
            let position = self.node("Sub", vec![scaled, one_f], vec![]);
            let axes = self.constant(&[1], Constant::I64(vec![summed]));
            let marginal = self.node("ReduceSum", vec![p.clone(), axes], vec![int("keepdims", 0)]);
            let weighted = self.node("Mul", vec![marginal, position], vec![]);
            let last = self.constant(&[1], Constant::I64(vec![-1]));
            coords.push(self.node("ReduceSum", vec![weighted, last], vec![int("keepdims", 1)]));
        }
        // [N, maps, 2] -> [N, 2 maps]
        let pairs = self.node("Concat", coords, vec![int("axis", -1)]);
        self.node("Flatten", vec![pairs], vec![int("axis", 1)])
    }

    fn conv(&mut self, x: String, c: &Conv) -> String {
        let mut inputs = vec![x, self.weight(&format!("{}.weight", c.key))];
        if c.bias {
            inputs.push(self.weight(&format!("{}.bias", c.key)));
        }
        let attributes = window(c.kernel, c.stride, c.padding).to_vec();
        self.node("Conv", inputs, attributes)
    }

    fn batch_norm(&mut self, x: String, prefix: &str) -> String {
        let inputs = ["weight", "bias", "running_mean", "running_var"]
            .iter()
            .map(|n| self.weight(&format!("{prefix}.{n}")))
            .collect::<Vec<_>>();
        self.node(
            "BatchNormalization",
            std::iter::once(x).chain(inputs).collect(),
            vec![float("epsilon", 1e-5)],
        )
    }

    /// `layers` one after another on `x`.
    fn layers(&mut self, mut x: String, layers: &[Layer]) -> String {
        for layer in layers {
            x = match layer {
                Layer::Conv(c) => self.conv(x, c),
                Layer::BatchNorm { key, .. } => self.batch_norm(x, key),
                Layer::Relu => self.node("Relu", vec![x], vec![]),
                Layer::MaxPool {
                    kernel,
                    stride,
                    padding,
                } => self.node(
                    "MaxPool",
                    vec![x],
                    window(*kernel, *stride, *padding).to_vec(),
                ),
                Layer::Residual { main, skip } => {
                    let y = self.layers(x.clone(), main);
                    let s = self.layers(x, skip);
                    self.node("Add", vec![y, s], vec![])
                }
            };
        }
        x
    }
}

/// The values of a [`Builder::constant`].
enum Constant {
    I64(Vec<i64>),
    F32(Vec<f32>),
}

/// A square window's attributes (Conv, MaxPool).
fn window(kernel: usize, stride: usize, padding: usize) -> [pb::AttributeProto; 3] {
    let (k, s, p) = (kernel as i64, stride as i64, padding as i64);
    [
        ints("kernel_shape", &[k, k]),
        ints("strides", &[s, s]),
        ints("pads", &[p, p, p, p]),
    ]
}

fn value_info(name: &str, dims: &[Result<i64, &str>]) -> pb::ValueInfoProto {
    use pb::tensor_shape_proto::{dimension::Value, Dimension};
    pb::ValueInfoProto {
        name: name.into(),
        r#type: Some(pb::TypeProto {
            value: Some(pb::type_proto::Value::TensorType(pb::type_proto::Tensor {
                elem_type: pb::tensor_proto::DataType::Float as i32,
                shape: Some(pb::TensorShapeProto {
                    dim: dims
                        .iter()
                        .map(|d| Dimension {
                            value: Some(match d {
                                Ok(v) => Value::DimValue(*v),
                                Err(p) => Value::DimParam(p.to_string()),
                            }),
                            ..Default::default()
                        })
                        .collect(),
                }),
            })),
            ..Default::default()
        }),
        ..Default::default()
    }
}

/// The ONNX model of `arch` with the weights of `sd` (already checked by
/// [`crate::arch::recognise`]) and `classes` shape classes.
pub fn build(arch: Architecture, classes: usize, sd: &StateDict) -> pb::ModelProto {
    let mut b = Builder {
        sd,
        nodes: Vec::new(),
        initializers: Vec::new(),
        counter: 0,
    };
    let x = b.layers(INPUT.to_string(), &arch.body());
    let pooled = b.node("GlobalAveragePool", vec![x.clone()], vec![]);
    let mut features = b.node("Flatten", vec![pooled], vec![int("axis", 1)]);
    if let Some(k) = arch.keypoints() {
        let coords = b.keypoints(x, &k);
        features = b.node("Concat", vec![features, coords], vec![int("axis", 1)]);
    }
    for (head, out) in ["force_head", "class_head", "point_head"]
        .iter()
        .zip(OUTPUTS)
    {
        let inputs = vec![
            features.clone(),
            b.weight(&format!("{head}.weight")),
            b.weight(&format!("{head}.bias")),
        ];
        b.node_named("Gemm", inputs, vec![int("transB", 1)], out);
    }
    let graph = pb::GraphProto {
        name: format!("fringe-{}", arch.name()),
        node: b.nodes,
        initializer: b.initializers,
        input: vec![value_info(
            INPUT,
            &[Err("batch"), Ok(3), Err("height"), Err("width")],
        )],
        output: vec![
            value_info(OUTPUTS[0], &[Err("batch"), Ok(7)]),
            value_info(OUTPUTS[1], &[Err("batch"), Ok(classes as i64)]),
            value_info(OUTPUTS[2], &[Err("batch"), Ok(2)]),
        ],
        ..Default::default()
    };
    pb::ModelProto {
        ir_version: 8,
        opset_import: vec![pb::OperatorSetIdProto {
            domain: String::new(),
            version: OPSET,
        }],
        producer_name: "fringe".into(),
        producer_version: env!("CARGO_PKG_VERSION").into(),
        graph: Some(graph),
        ..Default::default()
    }
}

/// The model's bytes, as an `.onnx` file holds them.
pub fn encode(model: &pb::ModelProto) -> Vec<u8> {
    prost::Message::encode_to_vec(model)
}

/// The graph of a network built by [`build`], cut after the features its heads read: one output
/// `features` [N, F]. `None` for a graph whose `force` output is not a linear head on a tensor.
pub fn features_graph(proto: &pb::ModelProto) -> Option<pb::ModelProto> {
    let graph = proto.graph.as_ref()?;
    let head = graph
        .node
        .iter()
        .find(|n| n.op_type == "Gemm" && n.output.iter().any(|o| o == OUTPUTS[0]))?;
    let features = head.input.first()?.clone();
    let mut cut = proto.clone();
    let g = cut.graph.as_mut()?;
    g.output = vec![value_info(&features, &[Err("batch"), Err("features")])];
    Some(cut)
}

/// The graph of a network built by [`build`], cut before the convolution whose weight is the
/// state-dict tensor `weight`: one output `input` [N, C, H, W], what that convolution reads.
/// `None` when no convolution reads `weight`.
pub fn conv_input_graph(proto: &pb::ModelProto, weight: &str) -> Option<pb::ModelProto> {
    let graph = proto.graph.as_ref()?;
    let conv = graph
        .node
        .iter()
        .find(|n| n.op_type == "Conv" && n.input.get(1).is_some_and(|w| w == weight))?;
    let input = conv.input.first()?.clone();
    let mut cut = proto.clone();
    let g = cut.graph.as_mut()?;
    g.output = vec![value_info(
        &input,
        &[Err("batch"), Err("channels"), Err("height"), Err("width")],
    )];
    Some(cut)
}
