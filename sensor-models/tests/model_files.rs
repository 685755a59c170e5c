//! Model files as users have them, written by real PyTorch (tests/python/model_fixtures.py):
//! every format reads to the same state dict, and bad files are refused in one line that names
//! them.

mod common;

use common::{fixture_dir, read_inputs, resnet_fixtures, Expected};
use fringe_sensor_models::parse_pickle;
use fringe_sensor_models::parse_pickle_prefix;
use fringe_sensor_models::{
    read_safetensors, read_torch, read_weights, write_safetensors, ModelFileErrorKind, StateDict,
    StoredType,
};
use proptest::prelude::*;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Files holding exactly the f32 weights of state_dict.pth.
const SAME_AS_ZIP: [&str; 4] = [
    "legacy.pth",
    "checkpoint.pth",
    "compiled.pth",
    "model.safetensors",
];

fn read(path: &Path) -> StateDict {
    read_weights(path).unwrap_or_else(|e| panic!("{e}"))
}

/// `a` and `b` hold the same keys, shapes and values.
fn assert_same_values(a: &StateDict, b: &StateDict, what: &str) {
    let ka: Vec<&str> = a.keys().collect();
    let kb: Vec<&str> = b.keys().collect();
    assert_eq!(ka, kb, "{what}: keys differ");
    for (key, ta) in a.iter() {
        let tb = b.get(key).expect("same keys");
        assert_eq!(ta.shape, tb.shape, "{what}: shape of {key}");
        assert_eq!(ta.data, tb.data, "{what}: values of {key}");
    }
}

/// `low` holds `reference`'s floating values rounded to `stored` (f16 or bf16).
fn assert_cast_of(reference: &StateDict, low: &StateDict, stored: StoredType, what: &str) {
    let cast = |v: f32| match stored {
        StoredType::F16 => half::f16::from_f32(v).to_f32(),
        StoredType::BF16 => half::bf16::from_f32(v).to_f32(),
        _ => v,
    };
    assert_eq!(
        reference.keys().collect::<Vec<_>>(),
        low.keys().collect::<Vec<_>>(),
        "{what}: keys"
    );
    for (key, t) in reference.iter() {
        let l = low.get(key).expect("same keys");
        assert_eq!(t.shape, l.shape, "{what}: shape of {key}");
        if t.stored == StoredType::I64 {
            assert_eq!(l.stored, StoredType::I64, "{what}: {key} stays an integer");
            assert_eq!(t.data, l.data, "{what}: {key}");
            continue;
        }
        assert_eq!(l.stored, stored, "{what}: element type of {key}");
        let expected: Vec<f32> = t.data.iter().map(|&v| cast(v)).collect();
        assert_eq!(expected, l.data, "{what}: values of {key}");
    }
}

/// Every weights file of a fixture directory against its zip f32 state dict.
fn check_all_formats(dir: &Path) -> StateDict {
    let reference = read_torch(dir.join("state_dict.pth")).unwrap_or_else(|e| panic!("{e}"));
    assert!(reference.len() > 10, "{} tensors", reference.len());
    for file in SAME_AS_ZIP {
        let other = read(&dir.join(file));
        assert_same_values(&reference, &other, file);
    }
    assert_cast_of(
        &reference,
        &read(&dir.join("state_dict_f16.pth")),
        StoredType::F16,
        "f16",
    );
    assert_cast_of(
        &reference,
        &read(&dir.join("state_dict_bf16.pth")),
        StoredType::BF16,
        "bf16",
    );
    reference
}

#[test]
fn custom_cnn_reads_the_same_from_every_format() {
    let reference = check_all_formats(&fixture_dir());
    let mut keys: Vec<&str> = reference.keys().collect();
    keys.sort();
    let mut expected = vec![
        "class_head.bias",
        "class_head.weight",
        "force_head.bias",
        "force_head.weight",
        "point_head.bias",
        "point_head.weight",
    ];
    for i in 0..4 {
        expected.push(Box::leak(format!("cnn.{i}.block.0.bias").into_boxed_str()));
        expected.push(Box::leak(
            format!("cnn.{i}.block.0.weight").into_boxed_str(),
        ));
    }
    expected.sort();
    assert_eq!(keys, expected);
    assert_eq!(
        reference
            .get("cnn.0.block.0.weight")
            .map(|t| t.shape.clone()),
        Some(vec![16, 3, 3, 3])
    );
    assert_eq!(
        reference.get("force_head.weight").map(|t| t.shape.clone()),
        Some(vec![7, 128])
    );
    assert_eq!(reference.stored_types(), "f32");
    // About 99k parameters (the paper's count).
    assert_eq!(reference.parameter_count(), 98_988);
}

#[test]
fn checkpoint_prefixes_are_removed_and_optimizer_state_ignored() {
    let dir = fixture_dir();
    // The file really has module. keys and an Adam state (tensors of its own).
    let raw = std::fs::read(dir.join("checkpoint.pth")).expect("checkpoint");
    let pkl = zip_entry(&raw, "data.pkl");
    let text = String::from_utf8_lossy(&pkl);
    for needle in [
        "module.cnn.0.block.0.weight",
        "optimizer_state_dict",
        "exp_avg_sq",
    ] {
        assert!(text.contains(needle), "checkpoint.pth lacks {needle}");
    }
    let sd = read(&dir.join("checkpoint.pth"));
    assert!(sd.keys().all(|k| !k.starts_with("module.")));
    assert!(sd.contains("cnn.0.block.0.weight"));
    assert_eq!(sd.len(), 14);
    let compiled = std::fs::read(dir.join("compiled.pth")).expect("compiled");
    assert!(String::from_utf8_lossy(&zip_entry(&compiled, "data.pkl")).contains("_orig_mod."));
}

#[test]
fn strided_views_with_offsets_read_like_torch() {
    let dir = fixture_dir();
    let expected = Expected::read(&dir);
    let sd = read(&dir.join("views.pth"));
    assert_eq!(sd.len(), expected.views.len());
    for (key, values) in &expected.views {
        let t = sd
            .get(key)
            .unwrap_or_else(|| panic!("views.pth lacks {key}"));
        assert_eq!(t.shape, values.shape, "{key}");
        assert_eq!(t.data, values.data, "{key}");
    }
}

#[test]
fn fixture_inputs_and_outputs_load() {
    let dir = fixture_dir();
    let expected = Expected::read(&dir);
    assert_eq!(expected.arch, "custom");
    let (shape, data) = read_inputs(&expected.inputs_path(&dir));
    assert_eq!(shape, vec![2, 3, 224, 224]);
    assert!(data.iter().all(|v| (-1.0..=1.0).contains(v)));
    for file in [
        "state_dict.pth",
        "legacy.pth",
        "state_dict_f16.pth",
        "model.onnx",
    ] {
        let o = expected.outputs_for(file);
        assert_eq!(o.force.len(), 2);
        assert!(o.force.iter().all(|f| f.len() == 7));
        assert!(o.shape_logits.iter().all(|f| f.len() == 3));
        assert!(o.contact.iter().all(|f| f.len() == 2));
    }
}

#[test]
fn a_torchscript_archive_is_named_as_such_not_read_as_a_state_dict() {
    for name in ["scripted.pt", "traced.pt"] {
        let path = fixture_dir().join(name);
        let e = read_weights(&path).expect_err("a program, not a state dict");
        assert!(
            matches!(e.kind, ModelFileErrorKind::TorchScript),
            "{name}: {e}"
        );
        let text = e.to_string();
        assert!(
            text.contains(name)
                && text.contains("--backend torch")
                && text.contains("state_dict()"),
            "{text}"
        );
    }
}

#[test]
fn safetensors_written_here_read_back_and_replace_atomically() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let reference = read(&fixture_dir().join("state_dict.pth"));
    let path = tmp.path().join("weights.safetensors");
    write_safetensors(&path, &reference).expect("write");
    write_safetensors(&path, &reference).expect("overwrite");
    assert_same_values(
        &reference,
        &read_safetensors(&path).expect("read"),
        "written",
    );
    let leftovers: Vec<_> = std::fs::read_dir(tmp.path()).expect("dir").collect();
    assert_eq!(leftovers.len(), 1, "temporary files left: {leftovers:?}");
    let e = write_safetensors(tmp.path().join("no/such/dir/w.safetensors"), &reference)
        .expect_err("missing dir");
    assert!(matches!(e.kind, ModelFileErrorKind::Write(_)), "{e}");
}

#[test]
fn resnet18_files_read_with_batchnorm_statistics() {
    let dir = resnet_fixtures();
    let started = Instant::now();
    let sd = read_torch(dir.join("state_dict.pth")).unwrap_or_else(|e| panic!("{e}"));
    let zip_time = started.elapsed();
    let started = Instant::now();
    let _ = read(&dir.join("legacy.pth"));
    let legacy_time = started.elapsed();
    eprintln!("ResNet-18 state_dict.pth read in {zip_time:?}, legacy.pth in {legacy_time:?}");
    let reference = check_all_formats(&dir);
    assert_same_values(&sd, &reference, "again");
    for key in [
        "backbone.0.weight",
        "backbone.1.weight",
        "backbone.1.running_mean",
        "backbone.1.running_var",
        "backbone.4.0.conv1.weight",
        "backbone.5.0.downsample.0.weight",
        "backbone.5.0.downsample.1.running_var",
        "backbone.7.1.bn2.running_mean",
        "force_head.weight",
        "class_head.bias",
        "point_head.weight",
    ] {
        assert!(sd.contains(key), "missing {key}");
    }
    assert_eq!(
        sd.get("backbone.0.weight").map(|t| t.shape.clone()),
        Some(vec![64, 3, 7, 7])
    );
    assert_eq!(
        sd.get("force_head.weight").map(|t| t.shape.clone()),
        Some(vec![7, 512])
    );
    let tracked = sd.get("backbone.1.num_batches_tracked").expect("counter");
    assert_eq!(tracked.stored, StoredType::I64);
    assert!(
        tracked.shape.is_empty() && tracked.data[0] >= 1.0,
        "{tracked:?}"
    );
    let var = sd.get("backbone.1.running_var").expect("running_var");
    assert!(
        var.data.iter().all(|&v| (0.5..=2.0).contains(&v)),
        "seeded running_var"
    );
    assert_eq!(sd.stored_types(), "f32, i64");
    // resnet18 without fc: 11,176,512 parameters, plus the heads on 512 features.
    assert_eq!(sd.parameter_count(), 11_176_512 + 512 * 12 + 12);
    let expected = Expected::read(&dir);
    assert_eq!(expected.arch, "resnet18");
    assert_eq!(
        read_inputs(&expected.inputs_path(&dir)).0,
        vec![2, 3, 224, 224]
    );
}

// ---- bad files ----

/// Writes `bytes` as `name` in a new temp dir.
fn temp_file(name: &str, bytes: &[u8]) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join(name);
    std::fs::write(&path, bytes).expect("write");
    (dir, path)
}

/// The error reading `bytes` as file `name`; checks it is one line naming the file.
fn refusal(name: &str, bytes: &[u8]) -> (ModelFileErrorKind, String) {
    let (_dir, path) = temp_file(name, bytes);
    let e = read_weights(&path).expect_err("refused");
    let message = e.to_string();
    assert!(
        message.starts_with(&path.display().to_string()),
        "message does not name the file: {message}"
    );
    assert!(!message.contains('\n'), "more than one line: {message}");
    (e.kind, message)
}

fn zip_entry(zip_bytes: &[u8], suffix: &str) -> Vec<u8> {
    let mut archive = zip::ZipArchive::new(std::io::Cursor::new(zip_bytes)).expect("zip");
    let name = archive
        .file_names()
        .filter_map(|n| n.ok().map(|n| n.into_owned()))
        .find(|n| n.ends_with(suffix))
        .expect("entry");
    let mut out = Vec::new();
    archive
        .by_name(&name)
        .expect("entry")
        .read_to_end(&mut out)
        .expect("read");
    out
}

/// A copy of zip `zip_bytes` with entry `suffix` replaced by `replace(old bytes)`.
fn rezip(zip_bytes: &[u8], suffix: &str, replace: impl Fn(Vec<u8>) -> Vec<u8>) -> Vec<u8> {
    let mut archive = zip::ZipArchive::new(std::io::Cursor::new(zip_bytes)).expect("zip");
    let mut writer = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    let options =
        zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Stored);
    for i in 0..archive.len() {
        let mut entry = archive.by_index(i).expect("entry");
        let name = entry.name().expect("name").into_owned();
        let mut bytes = Vec::new();
        entry.read_to_end(&mut bytes).expect("read");
        if name.ends_with(suffix) {
            bytes = replace(bytes);
        }
        writer.start_file(name, options).expect("start");
        writer.write_all(&bytes).expect("write");
    }
    writer.finish().expect("finish").into_inner()
}

/// A legacy-format file around `object_pickle`, with no storages.
fn legacy_file(object_pickle: &[u8]) -> Vec<u8> {
    let mut f = b"\x80\x02\x8a\x0a\x6c\xfc\x9c\x46\xf9\x20\x6a\xa8\x50\x19.".to_vec();
    f.extend(b"\x80\x02M\xe9\x03.");
    f.extend(b"\x80\x02}(X\x0d\x00\x00\x00little_endian\x88u.");
    f.extend(object_pickle);
    f.extend(b"\x80\x02].");
    f
}

#[test]
fn truncated_files_are_refused_with_what_is_missing() {
    let dir = fixture_dir();
    let zip = std::fs::read(dir.join("state_dict.pth")).expect("zip");
    let (kind, m) = refusal("cut.pth", &zip[..zip.len() / 2]);
    assert!(matches!(kind, ModelFileErrorKind::Truncated(_)), "{m}");
    assert!(m.contains("truncated"), "{m}");

    let legacy = std::fs::read(dir.join("legacy.pth")).expect("legacy");
    let (kind, m) = refusal("cut.pth", &legacy[..legacy.len() - 100]);
    assert!(matches!(kind, ModelFileErrorKind::Truncated(_)), "{m}");
    assert!(
        m.contains("truncated: storage '") && m.contains("bytes, file has"),
        "{m}"
    );
    let (kind, m) = refusal("cut.pth", &legacy[..1000]);
    assert!(matches!(kind, ModelFileErrorKind::Truncated(_)), "{m}");

    // A zip whose storage entry is shorter than the pickle says.
    let short = rezip(&zip, "data/2", |b| b[..100].to_vec());
    let (kind, m) = refusal("short.pth", &short);
    assert!(matches!(kind, ModelFileErrorKind::Truncated(_)), "{m}");
    assert!(
        m.ends_with("truncated: storage '2' needs 18432 bytes, file has 100"),
        "{m}"
    );

    let st = std::fs::read(dir.join("model.safetensors")).expect("safetensors");
    let (kind, m) = refusal("cut.safetensors", &st[..st.len() - 10]);
    assert!(matches!(kind, ModelFileErrorKind::Truncated(_)), "{m}");
    let (kind, m) = refusal("cut.safetensors", &st[..40]);
    assert!(matches!(kind, ModelFileErrorKind::Truncated(_)), "{m}");
}

#[test]
fn foreign_empty_and_onnx_files_are_refused() {
    let (kind, m) = refusal("image.pth", b"\x89PNG\r\n\x1a\n\0\0\0\rIHDR");
    assert!(matches!(kind, ModelFileErrorKind::Foreign(_)), "{m}");
    assert!(
        m.contains("not a PyTorch or safetensors file: starts with 89 50 4e 47"),
        "{m}"
    );
    assert!(m.contains("PNG image"), "{m}");
    let (kind, m) = refusal("notes.pth", b"hello, these are not weights");
    assert!(matches!(kind, ModelFileErrorKind::Foreign(_)), "{m}");
    let (kind, m) = refusal("empty.pth", b"");
    assert!(matches!(kind, ModelFileErrorKind::Empty), "{m}");
    let onnx = std::fs::read(fixture_dir().join("model.onnx")).expect("onnx");
    let (kind, m) = refusal("model.onnx", &onnx);
    assert!(matches!(kind, ModelFileErrorKind::Onnx), "{m}");
    // Recognised by content, whatever its name.
    let (kind, _) = refusal("model.pth", &onnx);
    assert!(matches!(kind, ModelFileErrorKind::Onnx));
    // A zip that torch did not write.
    let mut w = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    w.start_file("weights.npy", zip::write::SimpleFileOptions::default())
        .expect("start");
    w.write_all(b"\x93NUMPY").expect("write");
    let npz = w.finish().expect("zip").into_inner();
    let (kind, m) = refusal("arrays.pth", &npz);
    assert!(matches!(kind, ModelFileErrorKind::Foreign(_)), "{m}");
    assert!(
        m.contains("without data.pkl") && m.contains("weights.npy"),
        "{m}"
    );
    // A pickle that is not torch's.
    let (kind, m) = refusal("list.pkl", b"\x80\x02]q\x00.");
    assert!(matches!(kind, ModelFileErrorKind::Foreign(_)), "{m}");
    assert!(m.contains("a Python pickle of a list"), "{m}");
    let e = read_weights("/no/such/file.pth").expect_err("missing");
    assert!(matches!(e.kind, ModelFileErrorKind::Read(_)));
    assert!(
        e.to_string().starts_with("/no/such/file.pth: cannot read"),
        "{e}"
    );
}

#[test]
fn files_without_tensors_say_what_they_hold() {
    let (kind, m) = refusal("list.pth", &legacy_file(b"\x80\x02]q\x00(K\x01K\x02e."));
    assert!(matches!(kind, ModelFileErrorKind::NoTensors(_)), "{m}");
    assert!(
        m.ends_with("no tensors found: top-level pickle is a list"),
        "{m}"
    );
    let (kind, m) = refusal(
        "epoch.pth",
        &legacy_file(b"\x80\x02}q\x00X\x05\x00\x00\x00epochK\x03s."),
    );
    assert!(matches!(kind, ModelFileErrorKind::NoTensors(_)), "{m}");
    assert!(m.contains("'epoch'"), "{m}");
    // A zip whose pickle is replaced by a dict of numbers.
    let zip = std::fs::read(fixture_dir().join("state_dict.pth")).expect("zip");
    let numbers = rezip(&zip, "data.pkl", |_| {
        b"\x80\x02}q\x00X\x04\x00\x00\x00lossG?\xe0\x00\x00\x00\x00\x00\x00s.".to_vec()
    });
    let (kind, m) = refusal("numbers.pth", &numbers);
    assert!(matches!(kind, ModelFileErrorKind::NoTensors(_)), "{m}");
    // A damaged pickle.
    let damaged = rezip(&zip, "data.pkl", |mut b| {
        b[2] = 0xff; // the first opcode after PROTO
        b
    });
    let (kind, m) = refusal("damaged.pth", &damaged);
    assert!(matches!(kind, ModelFileErrorKind::Pickle { .. }), "{m}");
    assert!(m.contains("data.pkl"), "{m}");
}

// ---- no panic on any input ----

/// Real files to mutate in the property tests.
fn seeds() -> &'static [Vec<u8>] {
    static SEEDS: std::sync::OnceLock<Vec<Vec<u8>>> = std::sync::OnceLock::new();
    SEEDS.get_or_init(|| {
        let dir = fixture_dir();
        ["views.pth", "legacy.pth", "model.safetensors"]
            .iter()
            .map(|f| std::fs::read(dir.join(f)).expect("fixture"))
            .collect()
    })
}

fn data_pkl() -> &'static [u8] {
    static PKL: std::sync::OnceLock<Vec<u8>> = std::sync::OnceLock::new();
    PKL.get_or_init(|| {
        zip_entry(
            &std::fs::read(fixture_dir().join("checkpoint.pth")).expect("fixture"),
            "data.pkl",
        )
    })
}

/// Reading `bytes` as a file returns (Ok or a one-line error naming it) without panicking.
fn read_any(bytes: &[u8]) {
    let (_dir, path) = temp_file("any.pth", bytes);
    if let Err(e) = read_weights(&path) {
        let m = e.to_string();
        assert!(
            m.starts_with(&path.display().to_string()) && !m.contains('\n'),
            "{m}"
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 200, ..ProptestConfig::default() })]

    #[test]
    fn pickle_never_panics_on_arbitrary_bytes(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        let _ = parse_pickle(&bytes);
        let mut framed = b"\x80\x02".to_vec();
        framed.extend(&bytes);
        let _ = parse_pickle_prefix(&framed);
    }

    #[test]
    fn pickle_never_panics_on_mutated_torch_pickles(
        edits in proptest::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..8),
        cut in any::<prop::sample::Index>(),
    ) {
        let mut bytes = data_pkl().to_vec();
        for (at, value) in edits {
            let i = at.index(bytes.len());
            bytes[i] = value;
        }
        let _ = parse_pickle(&bytes);
        let _ = parse_pickle(&bytes[..cut.index(bytes.len())]);
    }

    #[test]
    fn read_weights_never_panics_on_arbitrary_files(
        prefix in prop::sample::select(vec![&b""[..], b"PK\x03\x04", b"\x80\x02", b"\x10\0\0\0\0\0\0\0{"]),
        bytes in proptest::collection::vec(any::<u8>(), 0..300),
    ) {
        let mut file = prefix.to_vec();
        file.extend(&bytes);
        read_any(&file);
    }

    #[test]
    fn read_weights_never_panics_on_mutated_model_files(
        which in 0usize..3,
        edits in proptest::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..6),
        cut in proptest::option::of(any::<prop::sample::Index>()),
    ) {
        let mut bytes = seeds()[which].clone();
        for (at, value) in edits {
            // Most edits near the start, where the structure is.
            let i = at.index(bytes.len().min(4096));
            bytes[i] = value;
        }
        if let Some(cut) = cut {
            bytes.truncate(cut.index(bytes.len()));
        }
        read_any(&bytes);
    }
}

/// An ONNX graph whose image input is declared [1, 3, 112, 112], as `torch.onnx.export` writes a
/// network exported at 112 px, and the custom CNN's weights.
fn graph_declaring(side: [i64; 2]) -> tract_onnx::pb::ModelProto {
    use tract_onnx::pb;
    use tract_onnx::pb::tensor_shape_proto::dimension::Value;
    let sd = read(&fixture_dir().join("model.safetensors"));
    let mut proto =
        fringe_sensor_models::onnx_graph::build(fringe_sensor_models::Architecture::Custom, 3, &sd);
    let graph = proto.graph.as_mut().expect("graph");
    let input = graph.input.first_mut().expect("input");
    let Some(pb::type_proto::Value::TensorType(t)) =
        input.r#type.as_mut().and_then(|t| t.value.as_mut())
    else {
        panic!("the image input is a tensor");
    };
    let dims = &mut t.shape.as_mut().expect("shape").dim;
    for (k, v) in [(0, 1), (2, side[0]), (3, side[1])] {
        dims[k].value = Some(Value::DimValue(v));
    }
    proto.metadata_props.clear();
    proto
}

/// An ONNX file without a card whose graph declares a 112 px input runs at 112 px (before, at
/// the 224 px guess); a card that says otherwise, or a graph that is not square, is refused.
#[test]
fn an_onnx_graph_without_a_card_runs_at_the_input_size_it_declares() {
    use fringe_sensor_models::onnx_graph::encode;
    use fringe_sensor_models::Model;
    let dir = tempfile::tempdir().expect("dir");
    let path = dir.path().join("exported.onnx");
    std::fs::write(&path, encode(&graph_declaring([112, 112]))).expect("write");
    let model = Model::open(&path).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(model.input_size, 112);
    let warning = model.missing_card_warning().expect("no card: warned");
    assert!(warning.contains("running it as 112 px"), "{warning}");
    // It runs at that size.
    let mut backend = model.tract(1).expect("backend");
    let input = vec![0.1f32; 3 * 112 * 112];
    let out = backend
        .run(&input, 1, 112)
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(out.force.len(), 1);
    // A card beside it that says another size is refused, naming the file and both sizes.
    std::fs::write(
        dir.path().join("exported.onnx.json"),
        r#"{"input_size": 224}"#,
    )
    .expect("card");
    let e = Model::open(&path).expect_err("refused").to_string();
    assert!(
        e.contains("exported.onnx") && e.contains("input_size 224 px") && e.contains("112 x 112"),
        "{e}"
    );
    std::fs::write(
        dir.path().join("exported.onnx.json"),
        r#"{"input_size": 112}"#,
    )
    .expect("card");
    assert_eq!(Model::open(&path).expect("agrees").input_size, 112);
    std::fs::remove_file(dir.path().join("exported.onnx.json")).expect("rm");
    std::fs::write(&path, encode(&graph_declaring([112, 96]))).expect("write");
    let e = Model::open(&path).expect_err("refused").to_string();
    assert!(e.contains("112 x 96 px") && e.contains("square"), "{e}");
}
