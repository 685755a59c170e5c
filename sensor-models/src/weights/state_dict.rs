//! A model's weights by name, as PyTorch's `state_dict()` holds them, whatever file they came
//! from. Wrapper prefixes (`module.` from DataParallel, `_orig_mod.` from torch.compile) are
//! removed so every key reads as the bare model's.

use super::tensor::{StoredType, Tensor};
use std::collections::BTreeMap;

/// Named tensors.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct StateDict {
    tensors: BTreeMap<String, Tensor>,
}

/// Prefixes that wrappers add to every key.
const WRAPPER_PREFIXES: [&str; 2] = ["module.", "_orig_mod."];

impl StateDict {
    pub fn new() -> StateDict {
        StateDict::default()
    }

    /// Builds a state dict from `(key, tensor)` pairs, removing wrapper prefixes from the keys.
    pub fn from_pairs(pairs: impl IntoIterator<Item = (String, Tensor)>) -> StateDict {
        let tensors = pairs
            .into_iter()
            .map(|(k, t)| (strip_wrappers(&k).to_string(), t))
            .collect();
        StateDict { tensors }
    }

    pub fn insert(&mut self, key: &str, tensor: Tensor) {
        self.tensors.insert(strip_wrappers(key).to_string(), tensor);
    }

    pub fn get(&self, key: &str) -> Option<&Tensor> {
        self.tensors.get(key)
    }

    pub fn contains(&self, key: &str) -> bool {
        self.tensors.contains_key(key)
    }

    pub fn keys(&self) -> impl Iterator<Item = &str> {
        self.tensors.keys().map(String::as_str)
    }

    pub fn iter(&self) -> impl Iterator<Item = (&str, &Tensor)> {
        self.tensors.iter().map(|(k, v)| (k.as_str(), v))
    }

    pub fn len(&self) -> usize {
        self.tensors.len()
    }

    pub fn is_empty(&self) -> bool {
        self.tensors.is_empty()
    }

    /// The element types found, e.g. "f16" or "f32, i64".
    pub fn stored_types(&self) -> String {
        let mut seen: Vec<StoredType> = Vec::new();
        for t in self.tensors.values() {
            if !seen.contains(&t.stored) {
                seen.push(t.stored);
            }
        }
        seen.iter().map(|s| s.name()).collect::<Vec<_>>().join(", ")
    }

    /// Number of values in the tensors that are parameters (all but BatchNorm's counters and
    /// running statistics).
    pub fn parameter_count(&self) -> usize {
        self.tensors
            .iter()
            .filter(|(k, _)| {
                !(k.ends_with("num_batches_tracked")
                    || k.ends_with("running_mean")
                    || k.ends_with("running_var"))
            })
            .map(|(_, t)| t.len())
            .sum()
    }
}

/// `key` without any leading wrapper prefixes (`module._orig_mod.x` -> `x`).
pub(crate) fn strip_wrappers(mut key: &str) -> &str {
    loop {
        match WRAPPER_PREFIXES.iter().find_map(|p| key.strip_prefix(p)) {
            Some(rest) => key = rest,
            None => return key,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrapper_prefixes_are_removed_in_any_nesting() {
        assert_eq!(
            strip_wrappers("module.cnn.0.block.0.weight"),
            "cnn.0.block.0.weight"
        );
        assert_eq!(
            strip_wrappers("_orig_mod.module.force_head.bias"),
            "force_head.bias"
        );
        assert_eq!(strip_wrappers("backbone.module.x"), "backbone.module.x");
        let t = Tensor::new(vec![2], vec![1.0, 2.0]).expect("tensor");
        let sd = StateDict::from_pairs([("module.a.weight".to_string(), t)]);
        assert!(sd.contains("a.weight"));
        assert_eq!(sd.parameter_count(), 2);
    }
}
