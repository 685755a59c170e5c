//! The default backend's outputs equal PyTorch's (eval mode) within 1e-4 on checkpoints that
//! PyTorch itself saved, in every file format, for the paper's two architectures and the keypoint CNN.

mod common;

use common::{check_backend, keypoint_fixtures, resnet_fixtures};
use fringe_sensor_models::arch::Architecture;

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
