//! What `torch.save`'s pickle means: where the state dict is (a plain or ordered dict, or the
//! `model_state_dict` of a training checkpoint), which of its values are tensors
//! (`torch._utils._rebuild_tensor_v2(storage, offset, size, stride, ...)`, parameters), and the
//! storages they view (persistent ids `('storage', torch.FloatStorage, key, location, numel)`).

use super::error::ModelFileErrorKind;
use super::pickle::Value;
use super::tensor::StoredType;

/// Keys under which training checkpoints keep the model's state dict, in order of preference.
const CHECKPOINT_KEYS: [&str; 3] = ["model_state_dict", "state_dict", "model"];

/// Element type of a storage, as its class names it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum StorageType {
    /// One the reader turns into f32 values.
    Supported(StoredType),
    /// Another (`torch.IntStorage`, `torch.UntypedStorage`...): its element size, to skip
    /// it in legacy files, and its name for messages.
    Other { name: String, element_size: usize },
}

impl StorageType {
    fn from_class(module: &str, name: &str) -> Option<StorageType> {
        if module != "torch" && module != "torch.storage" && module != "torch.cuda" {
            return None;
        }
        let supported = match name {
            "FloatStorage" => Some(StoredType::F32),
            "HalfStorage" => Some(StoredType::F16),
            "BFloat16Storage" => Some(StoredType::BF16),
            "DoubleStorage" => Some(StoredType::F64),
            "LongStorage" => Some(StoredType::I64),
            _ => None,
        };
        if let Some(s) = supported {
            return Some(StorageType::Supported(s));
        }
        let element_size = match name {
            "UntypedStorage" | "ByteStorage" | "CharStorage" | "BoolStorage" | "QUInt8Storage"
            | "QInt8Storage" | "QUInt4x2Storage" | "QUInt2x4Storage" => 1,
            "ShortStorage" => 2,
            "IntStorage" | "QInt32Storage" => 4,
            "ComplexFloatStorage" => 8,
            "ComplexDoubleStorage" => 16,
            _ => return None,
        };
        Some(StorageType::Other {
            name: format!("{module}.{name}"),
            element_size,
        })
    }

    pub(crate) fn element_size(&self) -> usize {
        match self {
            StorageType::Supported(s) => super::element::size_of(*s),
            StorageType::Other { element_size, .. } => *element_size,
        }
    }
}

/// A storage as a persistent id names it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct StorageRef {
    pub(crate) key: String,
    pub(crate) storage_type: StorageType,
    /// Number of elements the pickle says the storage has.
    pub(crate) numel: u64,
}

/// A tensor of the state dict: a view into a storage.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct TensorSpec {
    pub(crate) storage: StorageRef,
    /// In elements.
    pub(crate) offset: u64,
    pub(crate) size: Vec<u64>,
    pub(crate) stride: Vec<u64>,
}

/// The `(key, tensor)` pairs of the state dict in `root`, the object `torch.save` pickled.
/// Values that are not tensors are skipped.
pub(crate) fn state_dict_tensors(
    root: &Value,
) -> Result<Vec<(String, TensorSpec)>, ModelFileErrorKind> {
    let Some(top) = root.as_dict() else {
        return Err(ModelFileErrorKind::NoTensors(format!(
            "top-level pickle is {}",
            root.describe()
        )));
    };
    for key in CHECKPOINT_KEYS {
        let Some(inner) = root.get(key) else {
            continue;
        };
        match inner.as_dict() {
            Some(entries) => {
                let tensors = tensors_of(entries)?;
                if !tensors.is_empty() {
                    return Ok(tensors);
                }
            }
            None if !matches!(inner, Value::None) && tensors_of(top)?.is_empty() => {
                return Err(ModelFileErrorKind::NoTensors(format!(
                    "'{key}' of the checkpoint is {}, not a state dict (save model.state_dict())",
                    inner.describe()
                )));
            }
            None => {}
        }
    }
    let tensors = tensors_of(top)?;
    if tensors.is_empty() {
        let keys: Vec<String> = top
            .iter()
            .take(8)
            .map(|(k, _)| match k {
                Value::Str(s) => format!("'{s}'"),
                other => other.describe(),
            })
            .collect();
        let more = if top.len() > 8 { ", ..." } else { "" };
        return Err(ModelFileErrorKind::NoTensors(format!(
            "top-level pickle is a dict of {} entries without tensor values (keys {}{more})",
            top.len(),
            keys.join(", ")
        )));
    }
    Ok(tensors)
}

/// The entries of `dict` whose key is a string and whose value is a tensor.
fn tensors_of(dict: &[(Value, Value)]) -> Result<Vec<(String, TensorSpec)>, ModelFileErrorKind> {
    let mut out = Vec::new();
    for (key, value) in dict {
        let Some(key) = key.as_str() else { continue };
        if let Some(spec) = tensor_spec(key, value)? {
            out.push((key.to_string(), spec));
        }
    }
    Ok(out)
}

/// The tensor `value` rebuilds, `None` when it is not a tensor.
fn tensor_spec(key: &str, value: &Value) -> Result<Option<TensorSpec>, ModelFileErrorKind> {
    let (callable, args) = match value {
        Value::Call { callable, args } => (callable, args),
        // A tensor or parameter with Python attributes: its state does not change the values.
        Value::Build { obj, .. } => return tensor_spec(key, obj),
        _ => return Ok(None),
    };
    let Some((module, name)) = callable.global() else {
        return Ok(None);
    };
    let args = args.as_sequence().unwrap_or(&[]);
    let bad = |what: &str| {
        ModelFileErrorKind::Malformed(format!("tensor '{key}': {module}.{name} with {what}"))
    };
    match (module, name) {
        ("torch._utils", "_rebuild_tensor_v2") | ("torch._utils", "_rebuild_tensor") => {
            let [storage, offset, size, stride, ..] = args else {
                return Err(bad(&format!("{} arguments", args.len())));
            };
            let storage = storage_ref(storage).ok_or_else(|| bad("no storage"))?;
            let offset = offset
                .as_int()
                .and_then(|o| u64::try_from(o).ok())
                .ok_or_else(|| bad("a bad storage offset"))?;
            let size = dims(size).ok_or_else(|| bad("a bad size"))?;
            let stride = dims(stride).ok_or_else(|| bad("a bad stride"))?;
            if size.len() != stride.len() {
                return Err(bad("a stride of another rank than its size"));
            }
            Ok(Some(TensorSpec {
                storage,
                offset,
                size,
                stride,
            }))
        }
        ("torch._utils", "_rebuild_parameter")
        | ("torch._utils", "_rebuild_parameter_with_state") => match args.first() {
            Some(data) => tensor_spec(key, data),
            None => Err(bad("no data")),
        },
        ("torch._tensor", "_rebuild_from_type_v2") | ("torch._utils", "_rebuild_from_type_v2") => {
            // (func, type, args, state): func(*args) is the tensor.
            let [func, _, inner_args, ..] = args else {
                return Err(bad(&format!("{} arguments", args.len())));
            };
            let call = Value::Call {
                callable: Box::new(func.clone()),
                args: Box::new(inner_args.clone()),
            };
            tensor_spec(key, &call)
        }
        (m, n) if m.starts_with("torch") && n.starts_with("_rebuild") => Err(
            ModelFileErrorKind::Unsupported(format!("tensor '{key}' is stored as {m}.{n}")),
        ),
        _ => Ok(None),
    }
}

/// A tuple of non-negative ints.
fn dims(value: &Value) -> Option<Vec<u64>> {
    value
        .as_sequence()?
        .iter()
        .map(|v| v.as_int().and_then(|i| u64::try_from(i).ok()))
        .collect()
}

/// The storage a persistent id names: `('storage', storage_type, key, location, numel, ...)`.
pub(crate) fn storage_ref(value: &Value) -> Option<StorageRef> {
    let Value::PersistentId(pid) = value else {
        return None;
    };
    let items = pid.as_sequence()?;
    let [tag, class, key, _location, numel, rest @ ..] = items else {
        return None;
    };
    if tag.as_str() != Some("storage") {
        return None;
    }
    // Legacy files may add view metadata; torch has written None there since 1.0.
    if rest.first().is_some_and(|v| !matches!(v, Value::None)) {
        return None;
    }
    let (module, name) = class.global()?;
    let storage_type = StorageType::from_class(module, name).unwrap_or(StorageType::Other {
        name: format!("{module}.{name}"),
        element_size: 0,
    });
    let key = match key {
        Value::Str(s) => s.clone(),
        Value::Int(i) => i.to_string(),
        _ => return None,
    };
    let numel = numel.as_int().and_then(|n| u64::try_from(n).ok())?;
    Some(StorageRef {
        key,
        storage_type,
        numel,
    })
}

/// Every storage any persistent id in `value` names (legacy files store all of them in
/// sequence, optimizer state included, so each one's size is needed to skip it).
pub(crate) fn all_storages(value: &Value, out: &mut Vec<StorageRef>) {
    match value {
        Value::PersistentId(_) => {
            if let Some(s) = storage_ref(value) {
                out.push(s);
            }
        }
        Value::List(items) | Value::Tuple(items) => {
            items.iter().for_each(|v| all_storages(v, out));
        }
        Value::Dict(entries) => entries.iter().for_each(|(k, v)| {
            all_storages(k, out);
            all_storages(v, out);
        }),
        Value::Call { callable, args } => {
            all_storages(callable, out);
            all_storages(args, out);
        }
        Value::Build { obj, state } => {
            all_storages(obj, out);
            all_storages(state, out);
        }
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn g(module: &str, name: &str) -> Value {
        Value::Global {
            module: module.into(),
            name: name.into(),
        }
    }

    fn tensor(key: &str) -> Value {
        let pid = Value::PersistentId(Box::new(Value::Tuple(vec![
            Value::Str("storage".into()),
            g("torch", "HalfStorage"),
            Value::Str(key.into()),
            Value::Str("cpu".into()),
            Value::Int(6),
        ])));
        Value::Call {
            callable: Box::new(g("torch._utils", "_rebuild_tensor_v2")),
            args: Box::new(Value::Tuple(vec![
                pid,
                Value::Int(0),
                Value::Tuple(vec![Value::Int(2), Value::Int(3)]),
                Value::Tuple(vec![Value::Int(3), Value::Int(1)]),
                Value::Bool(false),
                Value::Dict(vec![]),
            ])),
        }
    }

    #[test]
    fn finds_the_model_state_dict_of_a_checkpoint_and_skips_the_rest() {
        let sd = Value::Dict(vec![(Value::Str("module.w".into()), tensor("0"))]);
        let ckpt = Value::Dict(vec![
            (Value::Str("epoch".into()), Value::Int(3)),
            (Value::Str("model_state_dict".into()), sd),
            (
                Value::Str("optimizer_state_dict".into()),
                Value::Dict(vec![(Value::Int(0), tensor("1"))]),
            ),
        ]);
        let t = state_dict_tensors(&ckpt).expect("tensors");
        assert_eq!(t.len(), 1);
        assert_eq!(t[0].0, "module.w");
        assert_eq!(
            t[0].1.storage.storage_type,
            StorageType::Supported(StoredType::F16)
        );
        assert_eq!(t[0].1.size, vec![2, 3]);
        let mut all = Vec::new();
        all_storages(&ckpt, &mut all);
        assert_eq!(all.len(), 2);
    }

    #[test]
    fn says_what_it_found_when_there_are_no_tensors() {
        let e = state_dict_tensors(&Value::List(vec![])).expect_err("no tensors");
        assert_eq!(
            e.to_string(),
            "no tensors found: top-level pickle is a list"
        );
        let d = Value::Dict(vec![(Value::Str("epoch".into()), Value::Int(1))]);
        let e = state_dict_tensors(&d).expect_err("no tensors");
        assert!(e.to_string().contains("'epoch'"), "{e}");
    }
}
