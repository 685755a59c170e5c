//! The `onnxruntime` backend (cargo feature `onnxruntime`): the same ONNX graph run by ONNX
//! Runtime, loaded at run time from the `libonnxruntime.so` that the PyPI wheel `onnxruntime`
//! ships. Nothing is downloaded at build time; the library is found by `ORT_DYLIB_PATH`:
//!
//! ```sh
//! pip install onnxruntime==1.32.0
//! export ORT_DYLIB_PATH=$(python -c "import onnxruntime, pathlib; print(next(pathlib.Path(onnxruntime.__file__).parent.glob('capi/libonnxruntime.so*')))")
//! ```

use super::tract::output_order;
use super::{Backend, InferenceError, RawOutputs};
use ort::environment::Environment;
use ort::session::builder::GraphOptimizationLevel;
use ort::session::Session;
use ort::value::TensorRef;
use std::ffi::OsString;
use std::path::PathBuf;
use std::sync::Mutex;
use tract_onnx::pb;

/// The variable naming the ONNX Runtime library (ort's own).
pub(crate) const DYLIB_VAR: &str = "ORT_DYLIB_PATH";

/// The ONNX Runtime version this backend is built and tested against (the PyPI wheel's).
pub(crate) const ONNXRUNTIME_VERSION: &str = "1.32.0";

/// How to install ONNX Runtime and point `ORT_DYLIB_PATH` at it, in two shell lines.
pub(crate) fn install_hint() -> String {
    format!(
        "pip install onnxruntime=={ONNXRUNTIME_VERSION}, then \
         export {DYLIB_VAR}=$(python -c \"import onnxruntime, pathlib; \
         print(next(pathlib.Path(onnxruntime.__file__).parent.glob('capi/libonnxruntime.so*')))\")"
    )
}

const NAME: &str = "onnxruntime";

fn load_err(detail: impl Into<String>) -> InferenceError {
    InferenceError::Load {
        backend: NAME,
        detail: detail.into(),
    }
}

fn run_err(e: impl std::fmt::Display) -> InferenceError {
    InferenceError::Run {
        backend: NAME,
        detail: e.to_string(),
    }
}

/// The library named by `ORT_DYLIB_PATH` (`var`), or the error saying how to get one.
fn dylib_path(var: Option<OsString>) -> Result<PathBuf, InferenceError> {
    let path = match var {
        Some(p) if !p.is_empty() => PathBuf::from(p),
        _ => {
            return Err(load_err(format!(
                "{DYLIB_VAR} is not set: it names the ONNX Runtime library (libonnxruntime.so) \
                 this backend loads; {}",
                install_hint()
            )))
        }
    };
    if !path.is_file() {
        return Err(load_err(format!(
            "{DYLIB_VAR}={} is not a file; {}",
            path.display(),
            install_hint()
        )));
    }
    Ok(path)
}

/// The process's one ONNX Runtime environment (ONNX Runtime allows one per process), made at
/// the first backend from the library `ORT_DYLIB_PATH` names.
static ENVIRONMENT: Mutex<Option<Environment>> = Mutex::new(None);

fn environment() -> Result<Environment, InferenceError> {
    let mut env = ENVIRONMENT
        .lock()
        .map_err(|_| load_err("an earlier ONNX Runtime set-up panicked"))?;
    if let Some(e) = env.as_ref() {
        return Ok(e.clone());
    }
    let path = dylib_path(std::env::var_os(DYLIB_VAR))?;
    let path = path.as_path();
    let built = ort::init_from(path)
        .map_err(|e| {
            load_err(format!(
                "{DYLIB_VAR}={}: {e}; {}",
                path.display(),
                install_hint()
            ))
        })?
        .with_name("fringe")
        .build()
        .map_err(|e| load_err(format!("ONNX Runtime environment: {e}")))?;
    *env = Some(built.clone());
    Ok(built)
}

/// ONNX Runtime running one ONNX model.
pub struct OrtBackend {
    session: Session,
    /// The names of the force, shape logits and contact outputs.
    outputs: [String; 3],
    classes: usize,
}

impl OrtBackend {
    /// A backend for the encoded ONNX model `model_bytes` (`onnx_graph::encode(model.onnx())`)
    /// with `classes` shape classes, on `threads` intra-op threads.
    pub fn new(
        model_bytes: &[u8],
        classes: usize,
        threads: usize,
    ) -> Result<OrtBackend, InferenceError> {
        let proto: pb::ModelProto = prost::Message::decode(model_bytes)
            .map_err(|e| load_err(format!("not an encoded ONNX model: {e}")))?;
        let order = output_order(&proto)?;
        let env = environment()?;
        let err = |e: ort::Error<_>| load_err(e.to_string());
        let session = Session::builder(&env)
            .map_err(|e| load_err(e.to_string()))?
            .with_optimization_level(GraphOptimizationLevel::All)
            .map_err(err)?
            .with_intra_threads(threads.max(1))
            .map_err(err)?
            .with_inter_threads(1)
            .map_err(err)?
            .commit_from_memory(model_bytes)
            .map_err(|e| load_err(e.to_string()))?;
        if session.inputs().len() != 1 {
            return Err(load_err(format!(
                "the graph has {} inputs; expected one image batch [N,3,H,W]",
                session.inputs().len()
            )));
        }
        let names: Vec<String> = session
            .outputs()
            .iter()
            .map(|o| o.name().to_string())
            .collect();
        let pick = |i: usize| -> Result<String, InferenceError> {
            names.get(order[i]).cloned().ok_or_else(|| {
                InferenceError::Outputs(format!(
                    "ONNX Runtime lists {} outputs ({})",
                    names.len(),
                    names.join(", ")
                ))
            })
        };
        Ok(OrtBackend {
            outputs: [pick(0)?, pick(1)?, pick(2)?],
            session,
            classes,
        })
    }
}

impl Backend for OrtBackend {
    fn name(&self) -> &'static str {
        NAME
    }

    fn run(
        &mut self,
        input: &[f32],
        batch: usize,
        size: u32,
    ) -> Result<RawOutputs, InferenceError> {
        super::check_input(input, batch, size)?;
        let s = size as usize;
        let tensor = TensorRef::from_array_view(([batch, 3, s, s], input)).map_err(run_err)?;
        let outputs = self.session.run(ort::inputs![tensor]).map_err(run_err)?;
        let values = |i: usize| -> Result<&[f32], InferenceError> {
            let name = &self.outputs[i];
            let value = outputs
                .get(name)
                .ok_or_else(|| InferenceError::Outputs(format!("output {name} is missing")))?;
            let (_, data) = value
                .try_extract_tensor::<f32>()
                .map_err(|e| InferenceError::Outputs(format!("{name}: {e}")))?;
            Ok(data)
        };
        RawOutputs::from_flat(values(0)?, values(1)?, self.classes, values(2)?, batch)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_unset_or_wrong_dylib_path_says_how_to_install() {
        for var in [
            None,
            Some(OsString::new()),
            Some("/nonexistent/libonnxruntime.so".into()),
        ] {
            let err = dylib_path(var).expect_err("refused").to_string();
            assert!(err.contains("ORT_DYLIB_PATH"), "{err}");
            assert!(err.contains("pip install onnxruntime==1.32.0"), "{err}");
            assert!(err.contains("capi/libonnxruntime.so*"), "{err}");
        }
    }
}
