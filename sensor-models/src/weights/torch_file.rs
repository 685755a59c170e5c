//! `.pth` / `.pt` files written by `torch.save`, read without Python.
//!
//! Two containers hold the same pickle ([`super::torch_pickle`] says what it means):
//! - the zip format (PyTorch >= 1.6): `<archive>/data.pkl`, one `<archive>/data/<key>` entry
//!   of raw bytes per storage, `<archive>/byteorder`;
//! - the legacy format (`_use_new_zipfile_serialization=False`): pickles of the magic number,
//!   the protocol version and the system info, then the object pickle, a pickle of the storage
//!   keys, and each storage as a u64 element count followed by its bytes.
//!
//! Every view is checked against its storage's size before a value is read.

use super::element;
use super::error::{ModelFileError, ModelFileErrorKind};
use super::file_start::{describe_start, read_head};
use super::pickle::{self, Value};
use super::state_dict::StateDict;
use super::tensor::{StoredType, Tensor};
use super::torch_pickle::{self, StorageType, TensorSpec};
use std::collections::HashMap;
use std::io::Read;
use std::path::Path;

/// The first bytes of a zip archive (a local file header; an empty archive's end record).
pub(crate) const ZIP_MAGIC: [&[u8]; 2] = [b"PK\x03\x04", b"PK\x05\x06"];

/// The number torch's legacy format pickles first, as LONG1's little-endian bytes.
const LEGACY_MAGIC: [u8; 10] = [0x6c, 0xfc, 0x9c, 0x46, 0xf9, 0x20, 0x6a, 0xa8, 0x50, 0x19];
const LEGACY_PROTOCOL: i64 = 1001;

/// Values all views together may hold beyond twice the elements of the storages they read
/// (views repeat elements when tensors share a storage or have a stride of 0): a small file
/// cannot make the reader allocate without bound.
const MAX_REPEATED_ELEMENTS: u64 = 1 << 26;

/// Largest `data.pkl` read (a ResNet-18 state dict's is about 30 kB).
const MAX_PICKLE_BYTES: u64 = 256 << 20;

/// Largest ratio of uncompressed to compressed size deflate can reach.
const MAX_DEFLATE_RATIO: u64 = 1032;

/// Reads the state dict in a file written by `torch.save` (zip or legacy format): a plain
/// state dict, an `OrderedDict`, or a checkpoint dict with `model_state_dict` (or
/// `state_dict`, `model`). Values that are not tensors are ignored; wrapper prefixes
/// (`module.`, `_orig_mod.`) are removed from the keys.
pub fn read_torch(path: impl AsRef<Path>) -> Result<StateDict, ModelFileError> {
    let path = path.as_ref();
    read_torch_inner(path).map_err(|kind| kind.at(path))
}

fn read_torch_inner(path: &Path) -> Result<StateDict, ModelFileErrorKind> {
    let mut head = [0u8; 4];
    let n = read_head(path, &mut head)?;
    let head = &head[..n];
    if n == 0 {
        return Err(ModelFileErrorKind::Empty);
    }
    if ZIP_MAGIC.iter().any(|m| head.starts_with(m)) {
        read_zip(path)
    } else if head.first() == Some(&0x80) {
        let bytes = std::fs::read(path).map_err(ModelFileErrorKind::Read)?;
        read_legacy(&bytes)
    } else {
        Err(ModelFileErrorKind::Foreign(describe_start(head)))
    }
}

/// Where the bytes of each storage come from.
trait Storages {
    /// The bytes of storage `key`, which must hold at least `needed` bytes.
    fn bytes(&mut self, key: &str, needed: u64) -> Result<&[u8], ModelFileErrorKind>;
    fn big_endian(&self) -> bool;
}

/// The tensors of `root` read from `storages`.
fn build_state_dict(
    root: &Value,
    storages: &mut dyn Storages,
) -> Result<StateDict, ModelFileErrorKind> {
    let specs = torch_pickle::state_dict_tensors(root)?;
    let mut state = StateDict::new();
    let mut budget = ElementBudget::default();
    for (key, spec) in specs {
        let tensor = materialize(&key, &spec, storages, &mut budget)?;
        state.insert(&key, tensor);
    }
    Ok(state)
}

/// Elements materialized so far against those the file's storages really hold.
#[derive(Default)]
struct ElementBudget {
    storages_seen: std::collections::HashSet<String>,
    stored: u64,
    materialized: u64,
}

impl ElementBudget {
    /// Accounts for a view of `numel` elements of storage `key` of `storage_numel` elements
    /// (whose bytes were checked to be in the file).
    fn spend(&mut self, key: &str, storage_numel: u64, numel: u64) -> Result<(), String> {
        if self.storages_seen.insert(key.to_string()) {
            self.stored = self.stored.saturating_add(storage_numel);
        }
        self.materialized = self.materialized.saturating_add(numel);
        let allowed = self
            .stored
            .saturating_mul(2)
            .saturating_add(MAX_REPEATED_ELEMENTS);
        if self.materialized > allowed {
            return Err(format!(
                "views repeat more values ({}) than the file's storages hold ({})",
                self.materialized, self.stored
            ));
        }
        Ok(())
    }
}

/// The values of the view `spec` of its storage, row-major.
fn materialize(
    key: &str,
    spec: &TensorSpec,
    storages: &mut dyn Storages,
    budget: &mut ElementBudget,
) -> Result<Tensor, ModelFileErrorKind> {
    let storage = &spec.storage;
    let stored = match &storage.storage_type {
        StorageType::Supported(s) => *s,
        StorageType::Other { name, .. } => {
            return Err(ModelFileErrorKind::Unsupported(format!(
                "tensor '{key}' has elements of {name} (f32, f16, bf16, f64 and i64 are read)"
            )))
        }
    };
    let elem = element::size_of(stored) as u64;
    let malformed = |what: String| ModelFileErrorKind::Malformed(format!("tensor '{key}': {what}"));
    let numel = spec
        .size
        .iter()
        .try_fold(1u64, |acc, &d| acc.checked_mul(d))
        .ok_or_else(|| malformed(format!("size {:?} overflows", spec.size)))?;
    let shape: Vec<usize> = spec
        .size
        .iter()
        .map(|&d| usize::try_from(d))
        .collect::<Result<_, _>>()
        .map_err(|_| malformed(format!("size {:?} too large", spec.size)))?;
    if numel == 0 {
        return Ok(tensor_of(shape, Vec::new(), stored));
    }
    // The last element the view reads (strides are non-negative).
    let last = spec
        .size
        .iter()
        .zip(&spec.stride)
        .try_fold(spec.offset, |acc, (&d, &s)| {
            (d - 1).checked_mul(s).and_then(|x| acc.checked_add(x))
        })
        .ok_or_else(|| malformed("view offsets overflow".into()))?;
    if last >= storage.numel {
        return Err(malformed(format!(
            "view (offset {}, size {:?}, stride {:?}) reaches element {last} of storage '{}' \
             which has {} elements",
            spec.offset, spec.size, spec.stride, storage.key, storage.numel
        )));
    }
    let needed = storage
        .numel
        .checked_mul(elem)
        .ok_or_else(|| malformed(format!("storage '{}' size overflows", storage.key)))?;
    let big_endian = storages.big_endian();
    let bytes = storages.bytes(&storage.key, needed)?;
    budget
        .spend(&storage.key, storage.numel, numel)
        .map_err(malformed)?;
    // Bytes of the storage are now known to cover elements 0..=last.
    let offset = spec.offset as usize;
    let contiguous = is_contiguous(&spec.size, &spec.stride);
    let data = if contiguous {
        let start = offset * elem as usize;
        let end = start + numel as usize * elem as usize;
        match bytes.get(start..end) {
            Some(slice) => element::decode_all(slice, stored, big_endian),
            None => return Err(malformed("view outside its storage".into())),
        }
    } else {
        strided(&shape, &spec.stride, offset, numel as usize, |i| {
            element::value_at(bytes, i, stored, big_endian)
        })
    };
    Ok(tensor_of(shape, data, stored))
}

fn tensor_of(shape: Vec<usize>, data: Vec<f32>, stored: StoredType) -> Tensor {
    Tensor {
        shape,
        data,
        stored,
    }
}

/// Whether row-major `size` with `stride` is a dense block (size-1 dims may have any stride).
fn is_contiguous(size: &[u64], stride: &[u64]) -> bool {
    let mut expected = 1u64;
    for (&d, &s) in size.iter().zip(stride).rev() {
        if d != 1 && s != expected {
            return false;
        }
        expected = expected.saturating_mul(d);
    }
    true
}

/// The elements of a strided view in row-major order (indices already checked in range).
fn strided(
    shape: &[usize],
    stride: &[u64],
    offset: usize,
    numel: usize,
    value: impl Fn(usize) -> f32,
) -> Vec<f32> {
    let stride: Vec<usize> = stride.iter().map(|&s| s as usize).collect();
    let mut index = vec![0usize; shape.len()];
    let mut out = Vec::with_capacity(numel);
    let mut pos = offset;
    for _ in 0..numel {
        out.push(value(pos));
        // Odometer step: the last dim fastest.
        for d in (0..shape.len()).rev() {
            index[d] += 1;
            pos += stride[d];
            if index[d] < shape[d] {
                break;
            }
            pos -= stride[d] * shape[d];
            index[d] = 0;
        }
    }
    out
}

/// The zip format.
fn read_zip(path: &Path) -> Result<StateDict, ModelFileErrorKind> {
    let file = std::fs::File::open(path).map_err(ModelFileErrorKind::Read)?;
    let file_len = file.metadata().map(|m| m.len()).unwrap_or(0);
    let mut archive = zip::ZipArchive::new(file).map_err(|e| zip_open_error(path, file_len, e))?;
    let names: Vec<String> = archive
        .file_names()
        .filter_map(|n| n.ok().map(|n| n.into_owned()))
        .collect();
    let Some(pkl) = names
        .iter()
        .find(|n| n.ends_with("/data.pkl") || n.as_str() == "data.pkl")
    else {
        let shown: Vec<&str> = names.iter().take(5).map(String::as_str).collect();
        return Err(ModelFileErrorKind::Foreign(format!(
            "a zip archive without data.pkl, not a torch.save file (entries: {})",
            if shown.is_empty() {
                "none".to_string()
            } else {
                shown.join(", ")
            }
        )));
    };
    let prefix = pkl.strip_suffix("data.pkl").unwrap_or("").to_string();
    if is_torchscript(&names, &prefix) {
        return Err(ModelFileErrorKind::TorchScript);
    }
    let pickle_bytes = read_entry(&mut archive, pkl, Some(MAX_PICKLE_BYTES + 1))?;
    if pickle_bytes.len() as u64 > MAX_PICKLE_BYTES {
        return Err(ModelFileErrorKind::Unsupported(format!(
            "{pkl} is larger than {MAX_PICKLE_BYTES} bytes"
        )));
    }
    let root =
        pickle::parse(&pickle_bytes).map_err(|e| ModelFileErrorKind::pickle("data.pkl", e))?;
    let byteorder_name = format!("{prefix}byteorder");
    let big_endian = if names.contains(&byteorder_name) {
        let order = read_entry(&mut archive, &byteorder_name, Some(16))?;
        match order.as_slice() {
            b"little" => false,
            b"big" => true,
            other => {
                return Err(ModelFileErrorKind::Malformed(format!(
                    "byteorder entry says {:?}",
                    String::from_utf8_lossy(other)
                )))
            }
        }
    } else {
        false
    };
    let mut storages = ZipStorages {
        archive,
        prefix,
        big_endian,
        loaded: HashMap::new(),
    };
    build_state_dict(&root, &mut storages)
}

/// A zip that would not open: cut short (no end record) or damaged.
/// Whether a torch zip archive's entries are those of `torch.jit.save` (its program under
/// `code/` and its `constants.pkl`) rather than of `torch.save`.
fn is_torchscript(names: &[String], prefix: &str) -> bool {
    names.iter().any(|n| {
        n.strip_prefix(prefix)
            .is_some_and(|rest| rest == "constants.pkl" || rest.starts_with("code/"))
    })
}

fn zip_open_error(path: &Path, file_len: u64, e: zip::result::ZipError) -> ModelFileErrorKind {
    let has_end = std::fs::read(path)
        .map(|b| {
            let tail = &b[b.len().saturating_sub(65_557)..];
            tail.windows(4).any(|w| w == b"PK\x05\x06")
        })
        .unwrap_or(true);
    if has_end {
        ModelFileErrorKind::Malformed(format!("damaged zip archive: {e}"))
    } else {
        ModelFileErrorKind::Truncated(format!(
            "a zip archive without its end record ({file_len} bytes; was the copy cut short?)"
        ))
    }
}

/// The bytes of entry `name`, at most `limit` (or the entry's size) bytes.
fn read_entry(
    archive: &mut zip::ZipArchive<std::fs::File>,
    name: &str,
    limit: Option<u64>,
) -> Result<Vec<u8>, ModelFileErrorKind> {
    let entry = archive
        .by_name(name)
        .map_err(|e| ModelFileErrorKind::Malformed(format!("zip entry {name}: {e}")))?;
    let cap = entry_cap(&entry);
    let limit = limit.map_or(cap, |l| l.min(cap));
    let mut out = Vec::new();
    entry
        .take(limit)
        .read_to_end(&mut out)
        .map_err(|e| ModelFileErrorKind::Malformed(format!("zip entry {name}: {e}")))?;
    Ok(out)
}

/// Most bytes an entry can really produce: its size, bounded by what its compressed bytes
/// can expand to.
fn entry_cap<R: std::io::Read>(entry: &zip::read::ZipFile<'_, R>) -> u64 {
    let compressed = entry.compressed_size();
    let bound = match entry.compression() {
        zip::CompressionMethod::Stored => compressed,
        _ => compressed.saturating_mul(MAX_DEFLATE_RATIO),
    };
    entry.size().min(bound)
}

struct ZipStorages {
    archive: zip::ZipArchive<std::fs::File>,
    prefix: String,
    big_endian: bool,
    loaded: HashMap<String, Vec<u8>>,
}

impl Storages for ZipStorages {
    fn bytes(&mut self, key: &str, needed: u64) -> Result<&[u8], ModelFileErrorKind> {
        if !self.loaded.contains_key(key) {
            let name = format!("{}data/{key}", self.prefix);
            let mut entry = self.archive.by_name(&name).map_err(|_| {
                ModelFileErrorKind::Malformed(format!(
                    "storage '{key}' is missing (no entry {name})"
                ))
            })?;
            let available = entry_cap(&entry);
            if available < needed {
                return Err(ModelFileErrorKind::Truncated(format!(
                    "storage '{key}' needs {needed} bytes, file has {available}"
                )));
            }
            let mut bytes = Vec::new();
            (&mut entry)
                .take(needed)
                .read_to_end(&mut bytes)
                .map_err(|e| ModelFileErrorKind::Malformed(format!("storage '{key}': {e}")))?;
            if (bytes.len() as u64) < needed {
                return Err(ModelFileErrorKind::Truncated(format!(
                    "storage '{key}' needs {needed} bytes, file has {}",
                    bytes.len()
                )));
            }
            self.loaded.insert(key.to_string(), bytes);
        }
        storage_slice(&self.loaded, key, needed)
    }

    fn big_endian(&self) -> bool {
        self.big_endian
    }
}

/// The first `needed` bytes of loaded storage `key`.
fn storage_slice<'a>(
    loaded: &'a HashMap<String, Vec<u8>>,
    key: &str,
    needed: u64,
) -> Result<&'a [u8], ModelFileErrorKind> {
    let bytes = loaded
        .get(key)
        .ok_or_else(|| ModelFileErrorKind::Malformed(format!("storage '{key}' is missing")))?;
    let have = bytes.len() as u64;
    usize::try_from(needed)
        .ok()
        .and_then(|n| bytes.get(..n))
        .ok_or_else(|| {
            ModelFileErrorKind::Truncated(format!(
                "storage '{key}' needs {needed} bytes, file has {have}"
            ))
        })
}

/// The legacy format, from the whole file's bytes.
fn read_legacy(bytes: &[u8]) -> Result<StateDict, ModelFileErrorKind> {
    let mut pickles = Pickles { bytes, pos: 0 };
    let big_endian = legacy_header(&mut pickles)?;
    let root = pickles.next("the object")?;
    let keys = pickles.next("the storage keys")?;
    let Some(keys) = keys.as_sequence() else {
        return Err(ModelFileErrorKind::Malformed(format!(
            "storage keys are {}, not a list",
            keys.describe()
        )));
    };
    let spans = storage_spans(bytes, pickles.pos, keys, &root, big_endian)?;
    let mut storages = LegacyStorages {
        bytes,
        spans,
        big_endian,
    };
    build_state_dict(&root, &mut storages)
}

/// The pickles a legacy file starts with, read one after another.
struct Pickles<'a> {
    bytes: &'a [u8],
    /// Where the next one starts.
    pos: usize,
}

impl Pickles<'_> {
    /// The next pickle's value; `part` names it in errors.
    fn next(&mut self, part: &'static str) -> Result<Value, ModelFileErrorKind> {
        let (value, used) = pickle::parse_prefix(&self.bytes[self.pos..])
            .map_err(|e| ModelFileErrorKind::pickle(part, e))?;
        self.pos += used;
        Ok(value)
    }
}

/// Reads and checks the magic number, the protocol version and the system info; whether the
/// file's storages are big-endian.
fn legacy_header(pickles: &mut Pickles<'_>) -> Result<bool, ModelFileErrorKind> {
    let magic = pickles.next("the magic number")?;
    if magic != Value::BigInt(LEGACY_MAGIC.to_vec()) {
        return Err(ModelFileErrorKind::Foreign(format!(
            "a Python pickle of {}, not a torch.save file",
            magic.describe()
        )));
    }
    let protocol = pickles.next("the protocol version")?;
    if protocol.as_int() != Some(LEGACY_PROTOCOL) {
        return Err(ModelFileErrorKind::Unsupported(format!(
            "legacy torch format version {protocol:?} (1001 is read)"
        )));
    }
    let sys_info = pickles.next("the system info")?;
    Ok(matches!(
        sys_info.get("little_endian"),
        Some(Value::Bool(false))
    ))
}

/// Where each storage's bytes lie in the file: the storages follow one another from `pos` in
/// the order of `keys`, each sized by the element type the tensors of `root` give it.
fn storage_spans(
    bytes: &[u8],
    mut pos: usize,
    keys: &[Value],
    root: &Value,
    big_endian: bool,
) -> Result<HashMap<String, std::ops::Range<usize>>, ModelFileErrorKind> {
    let mut refs = Vec::new();
    torch_pickle::all_storages(root, &mut refs);
    let element_sizes: HashMap<&str, usize> = refs
        .iter()
        .map(|r| (r.key.as_str(), r.storage_type.element_size()))
        .collect();
    let mut spans = HashMap::new();
    for (index, key) in keys.iter().enumerate() {
        let key = storage_key(index, key)?;
        let Some(&size) = element_sizes.get(key.as_str()) else {
            return Err(ModelFileErrorKind::Malformed(format!(
                "storage '{key}' is stored but no tensor uses it"
            )));
        };
        if size == 0 {
            return Err(ModelFileErrorKind::Unsupported(format!(
                "storage '{key}' has an unknown element type"
            )));
        }
        let span = storage_span(bytes, pos, (&key, index), size, big_endian)?;
        pos = span.end;
        spans.insert(key, span);
    }
    Ok(spans)
}

/// Storage key number `index` as a string (pickled as a str or an int).
fn storage_key(index: usize, key: &Value) -> Result<String, ModelFileErrorKind> {
    match key {
        Value::Str(s) => Ok(s.clone()),
        Value::Int(i) => Ok(i.to_string()),
        other => Err(ModelFileErrorKind::Malformed(format!(
            "storage key {index} is {}",
            other.describe()
        ))),
    }
}

/// The bytes of the storage at `pos` (its element count, then `size`-byte elements), checked to
/// be in the file; `name` is its key and number, for errors.
fn storage_span(
    bytes: &[u8],
    pos: usize,
    name: (&str, usize),
    size: usize,
    big_endian: bool,
) -> Result<std::ops::Range<usize>, ModelFileErrorKind> {
    let (key, index) = name;
    let rest = bytes.len() - pos;
    let Some(count) = bytes.get(pos..pos + 8) else {
        return Err(ModelFileErrorKind::Truncated(format!(
            "storage '{key}' (number {index}) starts at byte {pos}, file has {}",
            bytes.len()
        )));
    };
    let mut count_bytes = [0u8; 8];
    count_bytes.copy_from_slice(count);
    let count = if big_endian {
        u64::from_be_bytes(count_bytes)
    } else {
        u64::from_le_bytes(count_bytes)
    };
    let needed = count.saturating_mul(size as u64);
    let have = (rest - 8) as u64;
    if needed > have {
        return Err(ModelFileErrorKind::Truncated(format!(
            "storage '{key}' needs {needed} bytes, file has {have}"
        )));
    }
    let start = pos + 8;
    Ok(start..start + needed as usize)
}

struct LegacyStorages<'a> {
    bytes: &'a [u8],
    spans: HashMap<String, std::ops::Range<usize>>,
    big_endian: bool,
}

impl Storages for LegacyStorages<'_> {
    fn bytes(&mut self, key: &str, needed: u64) -> Result<&[u8], ModelFileErrorKind> {
        let Some(span) = self.spans.get(key) else {
            return Err(ModelFileErrorKind::Malformed(format!(
                "storage '{key}' is not in the file"
            )));
        };
        let have = span.len() as u64;
        if have < needed {
            return Err(ModelFileErrorKind::Truncated(format!(
                "storage '{key}' needs {needed} bytes, file has {have}"
            )));
        }
        Ok(&self.bytes[span.start..span.start + needed as usize])
    }

    fn big_endian(&self) -> bool {
        self.big_endian
    }
}

#[cfg(test)]
mod tests {
    use super::torch_pickle::StorageRef;
    use super::*;

    struct OneStorage(Vec<u8>);

    impl Storages for OneStorage {
        fn bytes(&mut self, _key: &str, needed: u64) -> Result<&[u8], ModelFileErrorKind> {
            self.0
                .get(..needed as usize)
                .ok_or_else(|| ModelFileErrorKind::Truncated("short".into()))
        }
        fn big_endian(&self) -> bool {
            false
        }
    }

    fn view(size: Vec<u64>, stride: Vec<u64>, offset: u64) -> TensorSpec {
        TensorSpec {
            storage: StorageRef {
                key: "0".into(),
                storage_type: StorageType::Supported(StoredType::F32),
                numel: 4,
            },
            offset,
            size,
            stride,
        }
    }

    #[test]
    fn views_are_checked_against_their_storage_and_the_element_budget() {
        let bytes: Vec<u8> = [1.0f32, 2.0, 3.0, 4.0]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        let mut storage = OneStorage(bytes);
        let mut budget = ElementBudget::default();
        let t = materialize(
            "t",
            &view(vec![2, 2], vec![1, 2], 0),
            &mut storage,
            &mut budget,
        )
        .expect("transpose");
        assert_eq!(t.data, vec![1.0, 3.0, 2.0, 4.0]);
        let e = materialize(
            "t",
            &view(vec![2, 2], vec![2, 1], 1),
            &mut storage,
            &mut budget,
        )
        .expect_err("past the end");
        assert!(e.to_string().contains("reaches element 4"), "{e}");
        // A broadcast of one element to 2^27 values from a 16-byte storage.
        let e = materialize(
            "b",
            &view(vec![1 << 27], vec![0], 0),
            &mut storage,
            &mut budget,
        )
        .expect_err("budget");
        assert!(e.to_string().contains("views repeat more values"), "{e}");
    }

    #[test]
    fn strided_views_read_in_row_major_order() {
        // A 2x3 transpose of a 3x2 storage [0..6]: stride (1, 2).
        let v = strided(&[2, 3], &[1, 2], 0, 6, |i| i as f32);
        assert_eq!(v, vec![0.0, 2.0, 4.0, 1.0, 3.0, 5.0]);
        assert!(is_contiguous(&[2, 3], &[3, 1]));
        assert!(is_contiguous(&[1, 3], &[99, 1]));
        assert!(!is_contiguous(&[2, 3], &[1, 2]));
        // Broadcast: stride 0.
        assert_eq!(strided(&[3], &[0], 4, 3, |i| i as f32), vec![4.0; 3]);
    }
}
