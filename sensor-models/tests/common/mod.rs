//! Test helpers for model files: where the fixtures are, their inputs and the outputs PyTorch
//! computed on them (`tests/python/model_fixtures.py` writes both).
#![allow(dead_code)]

use fringe_sensor_models::Architecture;
use fringe_sensor_models::Backend;
use fringe_sensor_models::{Model, ModelError};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

/// The environment variable naming a Python with torch (tests/python/requirements-models.txt).
pub const TORCH_PYTHON_VAR: &str = "FRINGE_TORCH_PYTHON";

/// The committed fixtures of the custom CNN (IsoNet).
pub fn fixture_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/custom")
}

/// The fixture script.
pub fn fixture_script() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/python/model_fixtures.py")
}

/// Inputs written by the fixture script: their shape (from `expected.json` beside them) and
/// values (raw little-endian f32).
pub fn read_inputs(path: &Path) -> (Vec<usize>, Vec<f32>) {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert_eq!(
        bytes.len() % 4,
        0,
        "{}: not whole f32 values",
        path.display()
    );
    let data: Vec<f32> = bytes
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    let dir = path.parent().unwrap_or(Path::new("."));
    let shape = Expected::read(dir).inputs.shape;
    assert_eq!(
        shape.iter().product::<usize>(),
        data.len(),
        "{}: {} values for shape {shape:?}",
        path.display(),
        data.len()
    );
    (shape, data)
}

/// The outputs of the network for each image, as PyTorch computed them in eval mode.
#[derive(Debug, Clone, Deserialize)]
pub struct Outputs {
    /// Per image: [Fx Fy Fz Mx My Mz Ft].
    pub force: Vec<Vec<f32>>,
    /// Per image: logits of [None, pentagon, rectangle].
    pub shape_logits: Vec<Vec<f32>>,
    /// Per image: contact [x, y].
    pub contact: Vec<Vec<f32>>,
}

#[derive(Debug, Clone, Deserialize)]
pub struct InputsInfo {
    pub file: String,
    pub shape: Vec<usize>,
    pub seed: u64,
}

/// Values of a tensor in row-major order.
#[derive(Debug, Clone, Deserialize)]
pub struct Values {
    pub shape: Vec<usize>,
    pub data: Vec<f32>,
}

/// `expected.json` of a fixture directory.
#[derive(Debug, Clone, Deserialize)]
pub struct Expected {
    /// "custom" or "resnet18".
    pub arch: String,
    pub seed: u64,
    /// The torch version that wrote the fixtures.
    pub torch: String,
    pub inputs: InputsInfo,
    /// By weights file name (state_dict.pth, model.onnx, ...).
    pub outputs: BTreeMap<String, Outputs>,
    /// TorchScript saves of the same network (scripted.pt, traced.pt), by file name.
    #[serde(default)]
    pub torchscript: BTreeMap<String, Outputs>,
    /// The tensors of views.pth.
    pub views: BTreeMap<String, Values>,
}

impl Expected {
    pub fn read(dir: &Path) -> Expected {
        let path = dir.join("expected.json");
        let text =
            std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
    }

    /// The outputs of the weights in `file` (e.g. "state_dict_f16.pth").
    pub fn outputs_for(&self, file: &str) -> &Outputs {
        self.outputs
            .get(file)
            .unwrap_or_else(|| panic!("expected.json has no outputs for {file}"))
    }

    /// The path of the inputs in `dir`.
    pub fn inputs_path(&self, dir: &Path) -> PathBuf {
        dir.join(&self.inputs.file)
    }
}

/// The Python with torch, torchvision, onnx and onnxruntime, named by `FRINGE_TORCH_PYTHON`
/// (`scripts/test` installs it and sets the variable); the test fails without it.
pub fn torch_python() -> PathBuf {
    match std::env::var_os(TORCH_PYTHON_VAR) {
        Some(p) => PathBuf::from(p),
        None => panic!(
            "{TORCH_PYTHON_VAR} is not set: set it to a Python with the packages of \
             sensor-models/tests/python/requirements-models.txt (torch, torchvision, onnx, \
             onnxruntime, safetensors, numpy); scripts/test does"
        ),
    }
}

/// A fresh scratch directory for one test.
pub fn scratch(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("fringe-models-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch directory");
    dir
}

/// The ResNet-18 fixtures (see [`written_fixtures`]).
pub fn resnet_fixtures() -> PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| written_fixtures(Architecture::Resnet18))
        .clone()
}

/// The keypoint CNN's fixtures (see [`written_fixtures`]).
pub fn keypoint_fixtures() -> PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| written_fixtures(Architecture::Keypoint))
        .clone()
}

/// Fixtures of `arch` written by the fixture script (with the Python named by
/// `FRINGE_TORCH_PYTHON`) into a directory of this test process under the target's tmp dir.
fn written_fixtures(arch: Architecture) -> PathBuf {
    let python = torch_python();
    let base = PathBuf::from(env!("CARGO_TARGET_TMPDIR"));
    remove_stale_fixture_dirs(&base);
    let dir = base.join(format!("{}-fixtures-{}", arch.name(), std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let out = Command::new(&python)
        .arg(fixture_script())
        .args(["--arch", arch.name(), "--out"])
        .arg(&dir)
        .output()
        .unwrap_or_else(|e| {
            panic!(
                "{TORCH_PYTHON_VAR}={}: cannot run: {e}",
                Path::new(&python).display()
            )
        });
    assert!(
        out.status.success(),
        "model_fixtures.py --arch {} failed ({}):\n{}",
        arch.name(),
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    dir
}

/// Removes fixture directories left by test processes that are gone (Linux: by /proc).
fn remove_stale_fixture_dirs(base: &Path) {
    let proc = Path::new("/proc");
    if !proc.is_dir() {
        return;
    }
    let Ok(entries) = std::fs::read_dir(base) else {
        return;
    };
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        let pid = name.split_once("-fixtures-").map(|(_, pid)| pid);
        if let Some(pid) = pid {
            if !proc.join(pid).exists() {
                let _ = std::fs::remove_dir_all(entry.path());
            }
        }
    }
}

/// The ONNX Runtime library for the `onnxruntime` backend: `ORT_DYLIB_PATH` when set, else the
/// `libonnxruntime.so*` of the onnxruntime wheel in the Python named by `FRINGE_TORCH_PYTHON`
/// (which then becomes `ORT_DYLIB_PATH` for this test process, the variable the backend reads).
pub fn ort_dylib() -> PathBuf {
    static PATH: OnceLock<PathBuf> = OnceLock::new();
    PATH.get_or_init(|| {
        if let Some(p) = std::env::var_os("ORT_DYLIB_PATH").filter(|p| !p.is_empty()) {
            return PathBuf::from(p);
        }
        let python = torch_python();
        let out = Command::new(&python)
            .args([
                "-c",
                "import onnxruntime, pathlib; print(next(pathlib.Path(onnxruntime.__file__)\
                 .parent.glob('capi/libonnxruntime.so*')))",
            ])
            .output()
            .unwrap_or_else(|e| panic!("{TORCH_PYTHON_VAR}={}: cannot run: {e}", python.display()));
        assert!(
            out.status.success(),
            "{TORCH_PYTHON_VAR}={} has no onnxruntime library (pip install onnxruntime==1.32.0):\n{}",
            python.display(),
            String::from_utf8_lossy(&out.stderr)
        );
        let path = PathBuf::from(String::from_utf8_lossy(&out.stdout).trim());
        // Set once, under the OnceLock, which every test of the backend passes first.
        std::env::set_var("ORT_DYLIB_PATH", &path);
        path
    })
    .clone()
}

/// A backend opened on a model, or why not.
pub type Opened = Result<Box<dyn Backend>, ModelError>;

/// How far a backend may be from PyTorch.
pub const TOLERANCE: f32 = 1e-4;

/// The largest absolute difference between two row sets of the same shape.
pub fn max_diff(got: &[Vec<f32>], want: &[Vec<f32>]) -> f32 {
    assert_eq!(got.len(), want.len());
    got.iter()
        .zip(want)
        .flat_map(|(g, w)| {
            assert_eq!(g.len(), w.len());
            g.iter().zip(w).map(|(a, b)| (a - b).abs())
        })
        .fold(0.0, f32::max)
}

/// Opens each file of `files` in the fixture directory `dir`, runs it with the backend that
/// `open_backend` makes on the fixture inputs (the batch, then its first image alone) and
/// asserts every output within [`TOLERANCE`] of PyTorch's. `arch`: what the file must be
/// recognised as (None for graphs and programs that are not recognised from weights).
pub fn check_backend_on(
    dir: &Path,
    files: &BTreeMap<String, Outputs>,
    arch: impl Fn(&str) -> Option<Architecture>,
    backend_name: &str,
    open_backend: impl Fn(&Model) -> Opened,
) {
    let expected = Expected::read(dir);
    let (shape, inputs) = read_inputs(&expected.inputs_path(dir));
    let batch = shape[0];
    let size = shape[2] as u32;
    assert!(!files.is_empty(), "{}: no fixtures", dir.display());
    for (file, want) in files {
        let model = Model::open(&dir.join(file)).unwrap_or_else(|e| panic!("{file}: {e}"));
        if let Some(a) = arch(file) {
            assert_eq!(model.arch, Some(a), "{file}");
        }
        assert_eq!(model.classes.len(), 3, "{file}");
        let mut backend = open_backend(&model).unwrap_or_else(|e| panic!("{file}: {e}"));
        assert_eq!(backend.name(), backend_name);
        let got = backend.run(&inputs, batch, size).expect("run");
        let force: Vec<Vec<f32>> = got.force.iter().map(|f| f.to_vec()).collect();
        let contact: Vec<Vec<f32>> = got.contact.iter().map(|f| f.to_vec()).collect();
        let d = [
            max_diff(&force, &want.force),
            max_diff(&got.shape_logits, &want.shape_logits),
            max_diff(&contact, &want.contact),
        ];
        eprintln!(
            "{} {file}: max |{backend_name} - torch| force {:.2e}, logits {:.2e}, contact {:.2e}",
            expected.arch, d[0], d[1], d[2]
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

/// [`check_backend_on`] over the weights files and ONNX graph of `dir` (not its TorchScript).
pub fn check_backend(
    dir: &Path,
    arch: Architecture,
    backend_name: &str,
    open_backend: impl Fn(&Model) -> Opened,
) {
    let expected = Expected::read(dir);
    check_backend_on(
        dir,
        &expected.outputs,
        |file| (!file.ends_with(".onnx")).then_some(arch),
        backend_name,
        open_backend,
    );
}
