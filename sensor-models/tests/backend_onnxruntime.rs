//! The `onnxruntime` backend's outputs equal PyTorch's (eval mode) within 1e-4 on checkpoints
//! that PyTorch itself saved, in every file format, for both architectures. ONNX Runtime is the
//! library `ORT_DYLIB_PATH` names, else the one of the onnxruntime wheel in `FRINGE_TORCH_PYTHON`.
#![cfg(feature = "onnxruntime")]

mod common;

use common::{ort_dylib, read_inputs, resnet_fixtures, Expected};
use fringe_sensor_models::arch::Architecture;
use fringe_sensor_models::model::Model;
use std::path::Path;

const TOLERANCE: f32 = 1e-4;

fn max_diff(got: &[Vec<f32>], want: &[Vec<f32>]) -> f32 {
    assert_eq!(got.len(), want.len());
    got.iter()
        .zip(want)
        .flat_map(|(g, w)| {
            assert_eq!(g.len(), w.len());
            g.iter().zip(w).map(|(a, b)| (a - b).abs())
        })
        .fold(0.0, f32::max)
}

fn check_dir(dir: &Path, arch: Architecture) {
    let expected = Expected::read(dir);
    let (shape, inputs) = read_inputs(&expected.inputs_path(dir));
    let batch = shape[0];
    let size = shape[2] as u32;
    assert!(
        !expected.outputs.is_empty(),
        "{}: no fixtures",
        dir.display()
    );
    for (file, want) in &expected.outputs {
        let model = Model::open(&dir.join(file)).unwrap_or_else(|e| panic!("{file}: {e}"));
        if !file.ends_with(".onnx") {
            assert_eq!(model.arch, Some(arch), "{file}");
        }
        assert_eq!(model.classes.len(), 3, "{file}");
        let mut backend = model
            .onnxruntime(2)
            .unwrap_or_else(|e| panic!("{file}: {e}"));
        assert_eq!(backend.name(), "onnxruntime");
        let got = backend.run(&inputs, batch, size).expect("run");
        let force: Vec<Vec<f32>> = got.force.iter().map(|f| f.to_vec()).collect();
        let contact: Vec<Vec<f32>> = got.contact.iter().map(|f| f.to_vec()).collect();
        let d = [
            max_diff(&force, &want.force),
            max_diff(&got.shape_logits, &want.shape_logits),
            max_diff(&contact, &want.contact),
        ];
        eprintln!(
            "{arch:?} {file}: max |onnxruntime - torch| force {:.2e}, logits {:.2e}, contact {:.2e}",
            d[0], d[1], d[2]
        );
        assert!(d.iter().all(|v| *v <= TOLERANCE), "{file}: {d:?}");
        // Batch 1 gives the same as the batch.
        let one = backend
            .run(&inputs[..inputs.len() / batch], 1, size)
            .expect("run one");
        assert!(max_diff(&[one.force[0].to_vec()], &[want.force[0].clone()]) <= TOLERANCE);
        assert!(max_diff(&[one.contact[0].to_vec()], &[want.contact[0].clone()]) <= TOLERANCE);
    }
}

#[test]
fn custom_cnn_matches_pytorch_in_every_format() {
    ort_dylib();
    check_dir(&common::fixture_dir(), Architecture::Custom);
}

#[test]
fn resnet18_matches_pytorch_in_every_format() {
    ort_dylib();
    check_dir(&resnet_fixtures(), Architecture::Resnet18);
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
