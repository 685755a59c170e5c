//! Element types of stored tensors: their sizes and how their bytes become f32 values.

use super::tensor::StoredType;

/// Bytes per element of `stored`.
pub(crate) fn size_of(stored: StoredType) -> usize {
    match stored {
        StoredType::F16 | StoredType::BF16 => 2,
        StoredType::F32 => 4,
        StoredType::F64 | StoredType::I64 => 8,
    }
}

/// The `index`-th element of `bytes` (which must hold it) as f32.
pub(crate) fn value_at(bytes: &[u8], index: usize, stored: StoredType, big_endian: bool) -> f32 {
    let n = size_of(stored);
    let start = index * n;
    let mut buf = [0u8; 8];
    if let Some(src) = bytes.get(start..start + n) {
        buf[..n].copy_from_slice(src);
    }
    if big_endian {
        buf[..n].reverse();
    }
    decode_le(&buf[..n], stored)
}

/// All elements of `bytes` (a whole number of elements) as f32.
pub(crate) fn decode_all(bytes: &[u8], stored: StoredType, big_endian: bool) -> Vec<f32> {
    let n = size_of(stored);
    bytes
        .chunks_exact(n)
        .map(|chunk| {
            if big_endian {
                let mut buf = [0u8; 8];
                buf[..n].copy_from_slice(chunk);
                buf[..n].reverse();
                decode_le(&buf[..n], stored)
            } else {
                decode_le(chunk, stored)
            }
        })
        .collect()
}

/// One little-endian element (`bytes.len() == size_of(stored)`).
fn decode_le(bytes: &[u8], stored: StoredType) -> f32 {
    let mut b8 = [0u8; 8];
    let len = bytes.len().min(8);
    b8[..len].copy_from_slice(&bytes[..len]);
    match stored {
        StoredType::F32 => f32::from_le_bytes([b8[0], b8[1], b8[2], b8[3]]),
        StoredType::F16 => half::f16::from_le_bytes([b8[0], b8[1]]).to_f32(),
        StoredType::BF16 => half::bf16::from_le_bytes([b8[0], b8[1]]).to_f32(),
        StoredType::F64 => f64::from_le_bytes(b8) as f32,
        StoredType::I64 => i64::from_le_bytes(b8) as f32,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decodes_each_type_in_both_byte_orders() {
        let le = 1.5f32.to_le_bytes();
        assert_eq!(decode_all(&le, StoredType::F32, false), vec![1.5]);
        assert_eq!(
            decode_all(&1.5f32.to_be_bytes(), StoredType::F32, true),
            vec![1.5]
        );
        let h = half::f16::from_f32(-2.25).to_le_bytes();
        assert_eq!(value_at(&h, 0, StoredType::F16, false), -2.25);
        let b = half::bf16::from_f32(3.0).to_be_bytes();
        assert_eq!(value_at(&b, 0, StoredType::BF16, true), 3.0);
        assert_eq!(
            decode_all(&7i64.to_le_bytes(), StoredType::I64, false),
            vec![7.0]
        );
        assert_eq!(
            decode_all(&0.25f64.to_le_bytes(), StoredType::F64, false),
            vec![0.25]
        );
    }
}
