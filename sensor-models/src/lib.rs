//! Models for the photoelastic sensor: the single preprocessing shared by export, training and
//! live inference, the network architectures, inference backends and metrics. The code arrives
//! with the model issues; the crate exists now so the workspace layout is fixed.
