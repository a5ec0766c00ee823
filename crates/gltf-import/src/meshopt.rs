//! `EXT_meshopt_compression`: buffer views stored compressed with meshoptimizer's codecs (the `meshopt` crate, the
//! codecs' reference implementation), decoded into the views' places before anything reads them.
//!
//! A compressed view names its compressed bytes in the extension (buffer, offset, length) and keeps its own
//! `buffer`, offset and length for the decoded data. That buffer is either a real one holding the same data
//! uncompressed (then it is used as it is, and nothing is decoded) or a placeholder without data (no `uri`, or
//! the extension's `fallback`), which is filled with the decoded views, and only as far as they reach.

use gltf::json::Root;
use serde_json::Value;

/// The most bytes one compressed byte can stand for: the attribute codec spends at least 2 bits on a group of 16
/// bytes (64:1), the triangle codec a byte on a triangle (12:1), the index codec a byte on an index (4:1). Twice
/// the largest, so that a declared size beyond it is an error before anything is allocated.
const MAX_RATIO: u64 = 128;

/// Whether buffer `i` of `json` is a placeholder for views that `EXT_meshopt_compression` decodes: tagged as its
/// `fallback`, or without a `uri` (and not a GLB's binary chunk, which is buffer 0 of a GLB) in a file that uses
/// the extension.
pub(crate) fn is_placeholder(json: &Root, i: usize, has_blob: bool) -> bool {
    if !json.extensions_used.iter().any(|e| e == "EXT_meshopt_compression") {
        return false;
    }
    let Some(buffer) = json.buffers.get(i) else { return false };
    let tagged = buffer
        .extensions
        .as_ref()
        .and_then(|e| e.others.get("EXT_meshopt_compression"))
        .and_then(|x| x.get("fallback"))
        .and_then(Value::as_bool)
        .unwrap_or(false);
    tagged || (buffer.uri.is_none() && !(i == 0 && has_blob))
}

/// An element of `N` bytes, the decoder's unit for a stride of `N`.
#[derive(Clone, Copy)]
struct Element<const N: usize>([u8; N]);

impl<const N: usize> Default for Element<N> {
    fn default() -> Self {
        Element([0; N])
    }
}

fn vertices<const N: usize>(src: &[u8], count: usize) -> Result<Vec<u8>, String> {
    let decoded = meshopt::decode_vertex_buffer::<Element<N>>(src, count).map_err(|e| e.to_string())?;
    Ok(decoded.iter().flat_map(|e| e.0).collect())
}

/// The attribute codec's output for `count` elements of `stride` bytes (a multiple of 4, at most 256).
fn decode_attributes(src: &[u8], count: usize, stride: usize) -> Result<Vec<u8>, String> {
    macro_rules! by_stride {
        ($($n:literal)*) => {
            match stride {
                $($n => vertices::<$n>(src, count),)*
                _ => Err(format!("byteStride {stride} is not a multiple of 4 up to 256")),
            }
        };
    }
    by_stride!(4 8 12 16 20 24 28 32 36 40 44 48 52 56 60 64 68 72 76 80 84 88 92 96 100 104 108 112 116 120 124 128
        132 136 140 144 148 152 156 160 164 168 172 176 180 184 188 192 196 200 204 208 212 216 220 224 228 232 236
        240 244 248 252 256)
}

/// Applies `filter` in place to decoded attribute `data` of `stride`-byte elements.
fn apply_filter(data: &mut [u8], filter: &str, stride: usize) -> Result<(), String> {
    match (filter, stride) {
        ("NONE", _) => {}
        ("OCTAHEDRAL", 4) => {
            let mut v: Vec<[i8; 4]> = data.chunks_exact(4).map(|c| std::array::from_fn(|k| c[k] as i8)).collect();
            meshopt::decode_filter_oct(&mut v);
            for (out, e) in data.chunks_exact_mut(4).zip(&v) {
                out.copy_from_slice(&e.map(|b| b as u8));
            }
        }
        ("OCTAHEDRAL", 8) | ("QUATERNION", 8) => {
            let mut v: Vec<[i16; 4]> = data
                .chunks_exact(8)
                .map(|c| std::array::from_fn(|k| i16::from_le_bytes([c[2 * k], c[2 * k + 1]])))
                .collect();
            if filter == "OCTAHEDRAL" {
                meshopt::decode_filter_oct(&mut v);
            } else {
                meshopt::decode_filter_quat(&mut v);
            }
            for (out, e) in data.chunks_exact_mut(8).zip(&v) {
                for (k, c) in e.iter().enumerate() {
                    out[2 * k..2 * k + 2].copy_from_slice(&c.to_le_bytes());
                }
            }
        }
        ("EXPONENTIAL", s) if s % 4 == 0 => {
            // Each 32-bit component is decoded on its own, whatever the element it belongs to.
            let mut v: Vec<[u32; 1]> =
                data.chunks_exact(4).map(|c| [u32::from_le_bytes([c[0], c[1], c[2], c[3]])]).collect();
            meshopt::decode_filter_exp(&mut v);
            for (out, e) in data.chunks_exact_mut(4).zip(&v) {
                out.copy_from_slice(&e[0].to_le_bytes());
            }
        }
        ("OCTAHEDRAL" | "QUATERNION" | "EXPONENTIAL", _) => {
            return Err(format!("filter {filter} does not take a byteStride of {stride}"));
        }
        (other, _) => return Err(format!("unknown filter '{other}' (NONE, OCTAHEDRAL, QUATERNION or EXPONENTIAL)")),
    }
    Ok(())
}

/// The index codecs' output (`TRIANGLES` or `INDICES`) for `count` indices of `stride` bytes (2 or 4).
fn decode_indices(src: &[u8], count: usize, stride: usize, triangles: bool) -> Result<Vec<u8>, String> {
    let e = |e: meshopt::Error| e.to_string();
    Ok(match (stride, triangles) {
        (2, true) => {
            meshopt::decode_index_buffer::<u16>(src, count).map_err(e)?.iter().flat_map(|i| i.to_le_bytes()).collect()
        }
        (4, true) => {
            meshopt::decode_index_buffer::<u32>(src, count).map_err(e)?.iter().flat_map(|i| i.to_le_bytes()).collect()
        }
        (2, false) => {
            meshopt::decode_index_sequence::<u16>(src, count).map_err(e)?.iter().flat_map(|i| i.to_le_bytes()).collect()
        }
        (4, false) => {
            meshopt::decode_index_sequence::<u32>(src, count).map_err(e)?.iter().flat_map(|i| i.to_le_bytes()).collect()
        }
        _ => return Err(format!("indices take a byteStride of 2 or 4, not {stride}")),
    })
}

/// Decodes every compressed view of `json` whose own buffer is a placeholder (`placeholder[i]`) into `buffers`
/// (placeholders start empty and grow as far as the views reach). Errors as (JSON path, message).
pub(crate) fn decode_views(json: &Root, buffers: &mut [Vec<u8>], placeholder: &[bool]) -> Result<(), (String, String)> {
    for (v, view) in json.buffer_views.iter().enumerate() {
        let Some(ext) = view.extensions.as_ref().and_then(|e| e.others.get("EXT_meshopt_compression")) else {
            continue;
        };
        let at = format!("bufferViews[{v}].extensions.EXT_meshopt_compression");
        let target = view.buffer.value();
        if !placeholder.get(target).copied().unwrap_or(false) {
            // The view's own buffer holds the data uncompressed.
            continue;
        }
        let field = |key: &str| format!("{at}.{key}");
        let int = |key: &str, default: Option<u64>| -> Result<u64, (String, String)> {
            match ext.get(key) {
                None => default.ok_or_else(|| (field(key), "is required".to_string())),
                Some(x) => x.as_u64().ok_or_else(|| (field(key), "must be an integer ≥ 0".to_string())),
            }
        };
        let text = |key: &str, default: Option<&str>| -> Result<String, (String, String)> {
            match ext.get(key) {
                None => default.map(str::to_string).ok_or_else(|| (field(key), "is required".to_string())),
                Some(x) => x.as_str().map(str::to_string).ok_or_else(|| (field(key), "must be a string".to_string())),
            }
        };
        let (source, offset, length) = (int("buffer", None)?, int("byteOffset", Some(0))?, int("byteLength", None)?);
        let (stride, count) = (int("byteStride", None)?, int("count", None)?);
        let (mode, filter) = (text("mode", None)?, text("filter", Some("NONE"))?);
        let decoded_length = stride.saturating_mul(count);
        if decoded_length != view.byte_length.0 {
            let message =
                format!("byteStride × count is {decoded_length}, not the view's byteLength {}", view.byte_length.0);
            return Err((field("count"), message));
        }
        if view.byte_stride.is_some_and(|s| s.0 as u64 != stride) {
            return Err((field("byteStride"), "differs from the view's byteStride".into()));
        }
        if decoded_length > MAX_RATIO.saturating_mul(length).saturating_add(4096) {
            let message = format!("{decoded_length} bytes cannot come out of {length} compressed bytes");
            return Err((field("byteLength"), message));
        }
        let src = buffers
            .get(source as usize)
            .filter(|_| !placeholder.get(source as usize).copied().unwrap_or(true))
            .and_then(|b| b.get(offset as usize..offset.saturating_add(length) as usize))
            .ok_or_else(|| {
                (
                    field("buffer"),
                    format!("buffers[{source}] does not hold bytes {offset} to {}", offset.saturating_add(length)),
                )
            })?;
        let (count, stride) = (count as usize, stride as usize);
        let decoded = match mode.as_str() {
            "ATTRIBUTES" => {
                if stride % 4 != 0 || stride > 256 {
                    return Err((
                        field("byteStride"),
                        format!("ATTRIBUTES take a multiple of 4 up to 256, not {stride}"),
                    ));
                }
                let mut data = decode_attributes(src, count, stride)
                    .map_err(|m| (at.clone(), format!("the compressed attributes do not decode ({m})")))?;
                apply_filter(&mut data, &filter, stride).map_err(|m| (field("filter"), m))?;
                data
            }
            "TRIANGLES" | "INDICES" => {
                if filter != "NONE" {
                    return Err((field("filter"), format!("{mode} takes no filter")));
                }
                if mode == "TRIANGLES" && count % 3 != 0 {
                    return Err((field("count"), "TRIANGLES needs a multiple of 3".into()));
                }
                if stride != 2 && stride != 4 {
                    return Err((field("byteStride"), format!("{mode} take a byteStride of 2 or 4, not {stride}")));
                }
                decode_indices(src, count, stride, mode == "TRIANGLES")
                    .map_err(|m| (at.clone(), format!("the compressed indices do not decode ({m})")))?
            }
            other => return Err((field("mode"), format!("unknown mode '{other}' (ATTRIBUTES, TRIANGLES or INDICES)"))),
        };
        let start = view.byte_offset.map_or(0, |o| o.0) as usize;
        let end = start + decoded.len();
        let declared = json.buffers.get(target).map_or(0, |b| b.byte_length.0) as usize;
        if end > declared {
            return Err((
                format!("bufferViews[{v}]"),
                format!("reaches past the end of buffers[{target}] ({declared} bytes)"),
            ));
        }
        let buffer = &mut buffers[target];
        if buffer.len() < end {
            buffer.resize(end, 0);
        }
        buffer[start..end].copy_from_slice(&decoded);
    }
    Ok(())
}
