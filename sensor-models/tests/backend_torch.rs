//! The `torch` backend's outputs equal PyTorch's (eval mode) within 1e-4: the paper's networks
//! from every weights format PyTorch saved, and TorchScript modules (`torch.jit.script` and
//! `torch.jit.trace` saves) of every architecture. ONNX graphs are refused with what to use.
#![cfg(feature = "torch")]

mod common;

use common::{check_backend_on, keypoint_fixtures, resnet_fixtures, Expected};
use fringe_sensor_models::Architecture;
use fringe_sensor_models::BackendKind;
use fringe_sensor_models::{Model, ModelError, ModelSource as Source};
use std::path::Path;

fn check_dir(dir: &Path, arch: Architecture) {
    let expected = Expected::read(dir);
    let weights = expected
        .outputs
        .iter()
        .filter(|(f, _)| !f.ends_with(".onnx"))
        .map(|(f, o)| (f.clone(), o.clone()))
        .collect();
    check_backend_on(dir, &weights, |_| Some(arch), "torch", |m| m.torch(2));
    assert_eq!(expected.torchscript.len(), 2, "scripted.pt and traced.pt");
    check_backend_on(
        dir,
        &expected.torchscript,
        |_| None,
        "torch",
        |m| {
            assert_eq!(m.source, Source::TorchScript);
            assert_eq!(m.describe(), "TorchScript module");
            assert!(m.parameters > 0);
            m.backend(BackendKind::Torch, 2)
        },
    );
}

#[test]
fn custom_cnn_matches_pytorch_from_weights_and_torchscript() {
    check_dir(&common::fixture_dir(), Architecture::Custom);
}

#[test]
fn resnet18_matches_pytorch_from_weights_and_torchscript() {
    check_dir(&resnet_fixtures(), Architecture::Resnet18);
}

#[test]
fn a_torchscript_module_runs_only_on_torch_and_an_onnx_graph_not_on_torch() {
    let dir = common::fixture_dir();
    let script = Model::open(&dir.join("scripted.pt")).expect("TorchScript opens");
    for kind in [BackendKind::Tract, BackendKind::OnnxRuntime] {
        let err = script.backend(kind, 1).err().expect("refused");
        assert!(matches!(err, ModelError::TorchScriptOnly { .. }), "{err}");
        let text = err.to_string();
        assert!(
            text.contains("scripted.pt") && text.contains("--backend torch"),
            "{text}"
        );
    }
    assert!(script.onnx().is_err(), "no ONNX graph to export");
    let graph = Model::open(&dir.join("model.onnx")).expect("ONNX opens");
    let err = graph.torch(1).err().expect("refused");
    let text = err.to_string();
    assert!(
        text.contains("model.onnx") && text.contains("tract or onnxruntime"),
        "{text}"
    );
}

#[test]
fn a_wrong_input_size_is_refused() {
    let model = Model::open(&common::fixture_dir().join("state_dict.pth")).expect("model");
    let mut backend = model.torch(1).expect("backend");
    let err = backend.run(&[0.0; 10], 1, 224).expect_err("refused");
    assert!(err.to_string().contains("3x224x224"), "{err}");
}

#[test]
fn keypoint_cnn_matches_pytorch_from_weights_and_torchscript() {
    check_dir(&keypoint_fixtures(), Architecture::Keypoint);
}
