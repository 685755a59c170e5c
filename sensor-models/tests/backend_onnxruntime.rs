//! The `onnxruntime` backend's outputs equal PyTorch's (eval mode) within 1e-4 on checkpoints
//! that PyTorch itself saved, in every file format, for the paper's two architectures and the keypoint CNN. ONNX Runtime is the
//! library `ORT_DYLIB_PATH` names, else the one of the onnxruntime wheel in `FRINGE_TORCH_PYTHON`.
#![cfg(feature = "onnxruntime")]

mod common;

use common::{check_backend, keypoint_fixtures, ort_dylib, resnet_fixtures, Expected};
use fringe_sensor_models::Architecture;
use fringe_sensor_models::Model;

#[test]
fn custom_cnn_matches_pytorch_in_every_format() {
    ort_dylib();
    check_backend(
        &common::fixture_dir(),
        Architecture::Custom,
        "onnxruntime",
        |m| m.onnxruntime(2),
    );
}

#[test]
fn resnet18_matches_pytorch_in_every_format() {
    ort_dylib();
    check_backend(
        &resnet_fixtures(),
        Architecture::Resnet18,
        "onnxruntime",
        |m| m.onnxruntime(2),
    );
}

#[test]
fn a_wrong_input_size_is_refused() {
    ort_dylib();
    let dir = common::fixture_dir();
    let expected = Expected::read(&dir);
    let file = expected.outputs.keys().next().expect("a fixture");
    let model = Model::open(&dir.join(file)).expect("model");
    let mut backend = model.onnxruntime(1).expect("backend");
    let err = backend.run(&[0.0; 10], 1, 224).expect_err("refused");
    assert!(err.to_string().contains("3x224x224"), "{err}");
}

#[test]
fn keypoint_cnn_matches_pytorch_in_every_format() {
    ort_dylib();
    check_backend(
        &keypoint_fixtures(),
        Architecture::Keypoint,
        "onnxruntime",
        |m| m.onnxruntime(2),
    );
}
