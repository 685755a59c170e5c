//! The default backend's outputs equal PyTorch's (eval mode) within 1e-4 on checkpoints that
//! PyTorch itself saved, in every file format, for both architectures.

mod common;

use common::{check_backend, resnet_fixtures};
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
