//! The ONNX graph of a network, built from its weights: what the default backend runs and what
//! `fringe model export --onnx` writes.
//!
//! Input `image` [N, 3, S, S] (N and S free); outputs `force` [N, 7], `shape_logits` [N, C] and
//! `contact` [N, 2]. Operators of opset 17: Conv, Relu, MaxPool, BatchNormalization (inference),
//! Add, GlobalAveragePool, Flatten, Gemm. Weights are stored as f32 initialisers under their
//! state-dict names, so the graph's weights can be read back by name.

use crate::arch::{Architecture, Conv, Layer};
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
    let pooled = b.node("GlobalAveragePool", vec![x], vec![]);
    let features = b.node("Flatten", vec![pooled], vec![int("axis", 1)]);
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
