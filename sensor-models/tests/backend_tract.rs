//! The default backend's outputs equal PyTorch's (eval mode) within 1e-4 on checkpoints that
//! PyTorch itself saved, in every file format, for the paper's two architectures and the keypoint CNN.

mod common;

use common::{check_backend, keypoint_fixtures, resnet_fixtures};
use fringe_sensor_models::Architecture;

#[test]
fn custom_cnn_matches_pytorch_in_every_format() {
    check_backend(&common::fixture_dir(), Architecture::Custom, "tract", |m| {
        m.tract(2)
    });
}

#[test]
fn resnet18_matches_pytorch_in_every_format() {
    check_backend(&resnet_fixtures(), Architecture::Resnet18, "tract", |m| {
        m.tract(2)
    });
}

#[test]
fn keypoint_cnn_matches_pytorch_in_every_format() {
    check_backend(&keypoint_fixtures(), Architecture::Keypoint, "tract", |m| {
        m.tract(2)
    });
}

/// `model_bench --profile`: every node's time is counted once, within its run, and the
/// convolutions show up as the matrix products they are planned as.
#[test]
fn a_profile_accounts_for_each_convolution_within_the_run() {
    use fringe_sensor_models::profile_tract as profile;
    use fringe_sensor_models::{onnx_graph, StateDict, Tensor};
    let arch = Architecture::Custom;
    let layout = arch.layout(3);
    let convs = layout.iter().filter(|(_, shape)| shape.len() == 4).count();
    let sd = StateDict::from_pairs(layout.into_iter().map(|(k, shape)| {
        let n = shape.iter().product();
        (k, Tensor::new(shape, vec![0.01; n]).expect("tensor"))
    }));
    let p = profile(onnx_graph::build(arch, 3, &sd), 112, 1, 3).expect("profile");
    let counted: f64 = p.ops.iter().map(|o| o.ms).sum();
    assert!(
        counted > 0.0 && counted <= p.run_ms,
        "{counted} ms of ops in {} ms runs",
        p.run_ms
    );
    let matmul = p
        .ops
        .iter()
        .find(|o| o.op == "OptMatMul")
        .expect("matrix products");
    assert!(
        matmul.nodes >= convs,
        "{} matrix products for {convs} convolutions",
        matmul.nodes
    );
    assert!(
        p.ops.windows(2).all(|w| w[0].ms >= w[1].ms),
        "slowest first: {:?}",
        p.ops
    );
}
