//! The default backend's outputs equal PyTorch's (eval mode) within 1e-4 on checkpoints that
//! PyTorch itself saved, in every file format, for both architectures.

mod common;

use common::{read_inputs, resnet_fixtures, Expected};
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
    for (file, want) in &expected.outputs {
        let model = Model::open(&dir.join(file)).unwrap_or_else(|e| panic!("{file}: {e}"));
        if !file.ends_with(".onnx") {
            // An ONNX graph from elsewhere is run as it is, whatever its initialisers are named.
            assert_eq!(model.arch, Some(arch), "{file}");
        }
        assert_eq!(model.classes.len(), 3, "{file}");
        let mut backend = model.tract(2).expect("backend");
        let got = backend.run(&inputs, batch, size).expect("run");
        let force: Vec<Vec<f32>> = got.force.iter().map(|f| f.to_vec()).collect();
        let contact: Vec<Vec<f32>> = got.contact.iter().map(|f| f.to_vec()).collect();
        let d = [
            max_diff(&force, &want.force),
            max_diff(&got.shape_logits, &want.shape_logits),
            max_diff(&contact, &want.contact),
        ];
        eprintln!(
            "{arch:?} {file}: max |tract - torch| force {:.2e}, logits {:.2e}, contact {:.2e}",
            d[0], d[1], d[2]
        );
        assert!(d.iter().all(|v| *v <= TOLERANCE), "{file}: {d:?}");
        // Batch 1 gives the same as the batch.
        let one = backend
            .run(&inputs[..inputs.len() / batch], 1, size)
            .expect("run one");
        assert!(max_diff(&[one.force[0].to_vec()], &[want.force[0].clone()]) <= TOLERANCE);
    }
}

#[test]
fn custom_cnn_matches_pytorch_in_every_format() {
    check_dir(&common::fixture_dir(), Architecture::Custom);
}

#[test]
fn resnet18_matches_pytorch_in_every_format() {
    check_dir(&resnet_fixtures(), Architecture::Resnet18);
}
