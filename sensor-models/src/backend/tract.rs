//! The default backend: the ONNX graph run by tract, a pure-Rust ONNX runtime, on a pool of
//! threads (2 by default, the bench machine's cores). A plan is optimised once per batch size
//! and input size and kept.

use super::{Backend, InferenceError, RawOutputs};
use crate::onnx_graph::OUTPUTS;
use std::collections::HashMap;
use std::sync::Arc;
use std::time::Instant;
use tract_onnx::pb;
use tract_onnx::prelude::*;
use tract_onnx::tract_core::tract_linalg::multithread::{multithread_tract_scope, Executor};

type Plan = Arc<TypedRunnableModel>;

/// tract running one ONNX model.
pub struct TractBackend {
    graph: TractGraph,
    /// Which graph output is force, shape logits, contact.
    order: [usize; 3],
    classes: usize,
}

/// An ONNX graph on tract: a plan optimised once per batch size and input size and kept, run on
/// the executor's threads. What [`TractBackend`] runs, and what reads a network's features.
pub(crate) struct TractGraph {
    proto: pb::ModelProto,
    plans: HashMap<(usize, u32), Plan>,
    executor: Executor,
}

impl TractGraph {
    /// `proto` on `threads` threads, loaded once now so that a bad graph is refused at once,
    /// not at the first frame.
    pub(crate) fn new(proto: pb::ModelProto, threads: usize) -> Result<TractGraph, InferenceError> {
        let executor = if threads > 1 {
            Executor::multithread(threads)
        } else {
            Executor::SingleThread
        };
        let mut g = TractGraph {
            proto,
            plans: HashMap::new(),
            executor,
        };
        g.plan(1, crate::preprocess::DEFAULT_INPUT_SIZE)?;
        Ok(g)
    }

    fn plan(&mut self, batch: usize, size: u32) -> Result<Plan, InferenceError> {
        if let Some(p) = self.plans.get(&(batch, size)) {
            return Ok(p.clone());
        }
        let s = size as usize;
        let plan = tract_onnx::onnx()
            .model_for_proto_model(&self.proto)
            .and_then(|m| m.with_input_fact(0, f32::fact([batch, 3, s, s]).into()))
            .and_then(|m| m.into_optimized())
            .and_then(|m| m.into_runnable())
            .map_err(load_err)?;
        self.plans.insert((batch, size), plan.clone());
        Ok(plan)
    }

    /// Every output of the graph for `batch` images of 3 x `size` x `size`, each flattened.
    pub(crate) fn run(
        &mut self,
        input: &[f32],
        batch: usize,
        size: u32,
    ) -> Result<Vec<Vec<f32>>, InferenceError> {
        super::check_input(input, batch, size)?;
        let s = size as usize;
        let plan = self.plan(batch, size)?;
        let tensor = Tensor::from_shape(&[batch, 3, s, s], input).map_err(run_err)?;
        let outputs = multithread_tract_scope(self.executor.clone(), || {
            plan.run(tvec!(tensor.into_tvalue()))
        })
        .map_err(run_err)?;
        outputs
            .iter()
            .map(|out| {
                out.to_plain_array_view::<f32>()
                    .map(|view| view.iter().copied().collect())
                    .map_err(|e| InferenceError::Outputs(format!("{e}")))
            })
            .collect()
    }
}

/// One kind of operation in an optimised plan and the time it took.
#[derive(Debug, Clone, PartialEq)]
pub struct OpTime {
    /// tract's name of the operation (`OptMatMul`, `Im2col`, `OptMaxPool`, ...).
    pub op: String,
    /// How many nodes of the plan run it.
    pub nodes: usize,
    /// Their time together, mean of the runs, ms.
    pub ms: f64,
}

/// Where a graph's time goes on tract: its optimised plan for one `size` px image, run `runs`
/// times on `threads` threads after two warm-up runs.
#[derive(Debug, Clone, PartialEq)]
pub struct OpProfile {
    /// A whole run, mean, ms.
    pub run_ms: f64,
    /// Per kind of operation, the slowest first.
    pub ops: Vec<OpTime>,
}

/// The time per kind of operation of `proto` on tract (examples/model_bench `--profile`): what
/// an inference-speed change has to beat. The input is a fixed pattern; a plan's time does not
/// depend on the values.
pub fn profile(
    proto: pb::ModelProto,
    size: u32,
    threads: usize,
    runs: usize,
) -> Result<OpProfile, InferenceError> {
    use tract_onnx::tract_core::plan::{eval, SimpleState};
    let mut graph = TractGraph::new(proto, threads)?;
    let plan = graph.plan(1, size)?;
    let s = size as usize;
    let input: Vec<f32> = (0..3 * s * s).map(|i| (i % 251) as f32 / 251.0).collect();
    let tensor = Tensor::from_shape(&[1, 3, s, s], &input).map_err(run_err)?;
    let mut per_op: Vec<OpTime> = Vec::new();
    let mut run_ms = 0.0;
    let warm_up = 2;
    multithread_tract_scope(graph.executor.clone(), || -> Result<(), InferenceError> {
        let mut state = SimpleState::new(&plan).map_err(run_err)?;
        for i in 0..warm_up + runs {
            let counted = i >= warm_up;
            let start = Instant::now();
            state
                .run_plan_with_eval(
                    tvec!(tensor.clone().into_tvalue()),
                    |ctx, op_state, node, inputs| {
                        let t = Instant::now();
                        let out = eval(ctx, op_state, node, inputs);
                        if counted {
                            let name = node.op().name();
                            let ms = t.elapsed().as_secs_f64() * 1e3;
                            match per_op.iter_mut().find(|o| o.op == name) {
                                Some(o) => o.ms += ms,
                                None => per_op.push(OpTime {
                                    op: name.to_string(),
                                    nodes: 0,
                                    ms,
                                }),
                            }
                        }
                        out
                    },
                )
                .map_err(run_err)?;
            if counted {
                run_ms += start.elapsed().as_secs_f64() * 1e3;
            }
        }
        Ok(())
    })?;
    for o in &mut per_op {
        o.nodes = plan
            .model()
            .nodes()
            .iter()
            .filter(|n| n.op().name() == o.op)
            .count();
        o.ms /= runs.max(1) as f64;
    }
    per_op.sort_by(|a, b| b.ms.total_cmp(&a.ms));
    Ok(OpProfile {
        run_ms: run_ms / runs.max(1) as f64,
        ops: per_op,
    })
}

fn load_err(e: impl std::fmt::Display) -> InferenceError {
    InferenceError::Load {
        backend: "tract",
        detail: format!("{e:#}"),
    }
}

fn run_err(e: impl std::fmt::Display) -> InferenceError {
    InferenceError::Run {
        backend: "tract",
        detail: format!("{e:#}"),
    }
}

/// The positions of force, shape logits and contact among a graph's outputs: by name when the
/// graph uses ours, else the first three in that order.
pub(crate) fn output_order(proto: &pb::ModelProto) -> Result<[usize; 3], InferenceError> {
    let names: Vec<&str> = proto
        .graph
        .as_ref()
        .map(|g| g.output.iter().map(|o| o.name.as_str()).collect())
        .unwrap_or_default();
    if let [Some(a), Some(b), Some(c)] = OUTPUTS.map(|want| names.iter().position(|n| *n == want)) {
        return Ok([a, b, c]);
    }
    if names.len() == 3 {
        return Ok([0, 1, 2]);
    }
    Err(InferenceError::Outputs(format!(
        "the graph has {} outputs ({}); expected force, shape_logits and contact",
        names.len(),
        names.join(", ")
    )))
}

impl TractBackend {
    /// A backend for `proto` with `classes` shape classes, on `threads` threads.
    pub fn new(
        proto: pb::ModelProto,
        classes: usize,
        threads: usize,
    ) -> Result<TractBackend, InferenceError> {
        let order = output_order(&proto)?;
        Ok(TractBackend {
            graph: TractGraph::new(proto, threads)?,
            order,
            classes,
        })
    }
}

impl Backend for TractBackend {
    fn name(&self) -> &'static str {
        "tract"
    }

    fn run(
        &mut self,
        input: &[f32],
        batch: usize,
        size: u32,
    ) -> Result<RawOutputs, InferenceError> {
        let outputs = self.graph.run(input, batch, size)?;
        let values = |i: usize| -> Result<&[f32], InferenceError> {
            outputs
                .get(self.order[i])
                .map(Vec::as_slice)
                .ok_or_else(|| InferenceError::Outputs(format!("output {i} is missing")))
        };
        RawOutputs::from_flat(values(0)?, values(1)?, self.classes, values(2)?, batch)
    }
}
