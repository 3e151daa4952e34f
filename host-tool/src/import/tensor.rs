//! RGL-EPFL's `tensor_file` container (as the reference reader rgl-epfl/brdf-loader's
//! `Tensor` reads it): named little-endian arrays, each checked against the file's
//! bounds before it is read.
//!
//! Layout: `tensor_file\0` (12 bytes), version 1.0 (2 bytes), u32 field count; per
//! field: u16 name length, the name, u16 rank, u8 type, u64 offset of its data, rank
//! u64 sizes; the data at the offsets.

use std::collections::BTreeMap;

/// Fields in a file at most (a real material has about a dozen).
const MAX_FIELDS: u32 = 1024;

/// Rank of a field at most.
const MAX_RANK: u16 = 16;

/// The values of all fields widened to f64 take at most this many times the file's
/// size: one byte widened is 8 bytes, so fields that do not share data stay within it;
/// many fields pointing at one buffer (each widened again) do not.
const MAX_WIDENING: u64 = 8;

/// One field's shape and values (as f64; u8 fields widened).
#[derive(Debug, Clone, PartialEq)]
pub struct Field {
    /// Sizes along each dimension, outermost first (the last is contiguous).
    pub shape: Vec<usize>,
    /// The type code (1 u8, 10 f32, ...; the reference's `Tensor::Type`).
    pub dtype: u8,
    /// The values, in file order.
    pub values: Vec<f64>,
}

/// Reads every field of `bytes`. A wrong header or version, a count, rank, type or
/// shape that does not fit, data past the end of the file or overlapping the header,
/// fields whose values widened to f64 would take more than [`MAX_WIDENING`] times the
/// file (fields sharing one buffer), and a non-finite float are refused with one line
/// (no panic, no allocation larger than that).
pub fn read_tensor(bytes: &[u8]) -> Result<BTreeMap<String, Field>, String> {
    let mut at = 0usize;
    let take = |at: &mut usize, n: usize, what: &str| -> Result<&[u8], String> {
        let end = at
            .checked_add(n)
            .filter(|&e| e <= bytes.len())
            .ok_or_else(|| {
                format!("cut short in the {what} (at byte {at}): not a whole tensor file")
            })?;
        let s = &bytes[*at..end];
        *at = end;
        Ok(s)
    };
    if take(&mut at, 12, "header")? != b"tensor_file\0" {
        return Err("not an RGL tensor file (its first bytes are not 'tensor_file')".into());
    }
    let version = take(&mut at, 2, "header")?;
    if version != [1, 0] {
        return Err(format!(
            "tensor file version {}.{}: gonio reads version 1.0",
            version[0], version[1]
        ));
    }
    let n = u32::from_le_bytes(take(&mut at, 4, "header")?.try_into().expect("4"));
    if n > MAX_FIELDS {
        return Err(format!(
            "{n} fields (at most {MAX_FIELDS}): not a tensor file gonio reads"
        ));
    }
    let mut fields = BTreeMap::new();
    let mut widened = 0u64;
    for _ in 0..n {
        let len = u16::from_le_bytes(take(&mut at, 2, "field list")?.try_into().expect("2"));
        let name = String::from_utf8_lossy(take(&mut at, len as usize, "field list")?).into_owned();
        let rank = u16::from_le_bytes(take(&mut at, 2, "field list")?.try_into().expect("2"));
        let dtype = take(&mut at, 1, "field list")?[0];
        let offset = u64::from_le_bytes(take(&mut at, 8, "field list")?.try_into().expect("8"));
        if rank > MAX_RANK {
            return Err(format!(
                "field '{}' has rank {rank} (at most {MAX_RANK})",
                crate::text::escape_line(&name, 40)
            ));
        }
        let mut shape = Vec::with_capacity(rank as usize);
        for _ in 0..rank {
            shape.push(u64::from_le_bytes(
                take(&mut at, 8, "field list")?.try_into().expect("8"),
            ));
        }
        let width: u64 = match dtype {
            1 | 2 => 1,
            3 | 4 | 9 => 2,
            5 | 6 | 10 => 4,
            7 | 8 | 11 => 8,
            _ => {
                return Err(format!(
                    "field '{}' has an unknown type {dtype}",
                    crate::text::escape_line(&name, 40)
                ));
            }
        };
        let bad = || {
            format!(
                "field '{}' (shape {shape:?}) does not fit in the file's {} bytes: cut short or not a tensor file",
                crate::text::escape_line(&name, 40),
                bytes.len()
            )
        };
        let count = shape
            .iter()
            .try_fold(1u64, |a, &s| a.checked_mul(s))
            .ok_or_else(bad)?;
        let size = count.checked_mul(width).ok_or_else(bad)?;
        let end = offset.checked_add(size).ok_or_else(bad)?;
        if end > bytes.len() as u64 {
            return Err(bad());
        }
        if matches!(dtype, 1 | 10 | 11) {
            widened = widened.saturating_add(count.saturating_mul(8));
            if widened > MAX_WIDENING.saturating_mul(bytes.len() as u64) {
                return Err(format!(
                    "its fields would take {widened} bytes as f64, more than {MAX_WIDENING} times the file's {} bytes: fields share data (field '{}'); not a tensor file gonio reads",
                    bytes.len(),
                    crate::text::escape_line(&name, 40)
                ));
            }
        }
        let data = &bytes[offset as usize..end as usize];
        let values: Vec<f64> = match dtype {
            1 => data.iter().map(|&b| f64::from(b)).collect(),
            10 => data
                .chunks_exact(4)
                .map(|c| f64::from(f32::from_le_bytes(c.try_into().expect("4"))))
                .collect(),
            11 => data
                .chunks_exact(8)
                .map(|c| f64::from_le_bytes(c.try_into().expect("8")))
                .collect(),
            // Other types are not read by the BRDF; their bytes were checked above.
            _ => Vec::new(),
        };
        if let Some(k) = values.iter().position(|v| !v.is_finite()) {
            return Err(format!(
                "field '{}' holds a value that is not finite (element {k}): a damaged file",
                crate::text::escape_line(&name, 40)
            ));
        }
        let shape = shape.into_iter().map(|s| s as usize).collect();
        fields.insert(
            name,
            Field {
                shape,
                dtype,
                values,
            },
        );
    }
    Ok(fields)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A tensor file of `fields` f32 fields of `len` values, every one pointing at the
    /// same data.
    fn shared(fields: u32, len: u64) -> Vec<u8> {
        let mut b = b"tensor_file\0".to_vec();
        b.extend([1, 0]);
        b.extend(fields.to_le_bytes());
        let header = 18 + u64::from(fields) * (2 + 4 + 2 + 1 + 8 + 8);
        for k in 0..fields {
            b.extend(4u16.to_le_bytes());
            b.extend(format!("f{k:03}").as_bytes());
            b.extend(1u16.to_le_bytes());
            b.push(10);
            b.extend(header.to_le_bytes());
            b.extend(len.to_le_bytes());
        }
        assert_eq!(b.len() as u64, header);
        b.extend(std::iter::repeat_n(0u8, 4 * len as usize));
        b
    }

    /// Issue 50 case 10: many fields on one buffer asked for gigabytes (a 4 MiB file
    /// aborted); the total widened size is bounded by a multiple of the file's.
    #[test]
    fn fields_sharing_one_buffer_are_refused_before_they_are_widened() {
        assert_eq!(read_tensor(&shared(2, 1000)).unwrap().len(), 2);
        let e = read_tensor(&shared(20, 1000)).unwrap_err();
        assert!(
            e.contains("more than 8 times the file's") && e.contains("fields share data"),
            "{e}"
        );
    }
}
