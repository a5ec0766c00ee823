//! The tensor file format of the RGL material database (Dupuy & Jakob 2018), as Mitsuba and pbrt-v4 read it:
//! named, typed, multi-dimensional arrays in one little-endian file.
//!
//! Layout: the magic `"tensor_file\0"` (12 bytes), the version (2 bytes, 1 and 0), the number of fields (u32), then
//! per field its name length (u16), its name, its rank (u16), its type code (u8, see [`DType`]), the absolute offset
//! of its data in the file (u64) and one u64 extent per dimension. The data are the values in row-major order (the
//! last dimension contiguous), each of the type's size.
//!
//! Every size is checked against the bytes present before anything is allocated: a field header that runs past the
//! end, a data block outside the file, a shape whose product overflows, duplicated names and unknown type codes
//! are errors saying what is wrong. Field data are not copied when the file is read; they are converted only when
//! asked for ([`TensorFile::f32s`], [`TensorFile::bytes_of`]), so a file whose many fields all point at the same
//! bytes costs no more memory than the file.

use std::collections::HashMap;
use std::io::Read;
use std::path::Path;

use crate::error::invalid_data as bad;
use crate::RenderError;

/// The first 12 bytes of every tensor file.
pub const MAGIC: [u8; 12] = *b"tensor_file\0";

/// The largest tensor file read, 1 GiB (the RGL database's files are a few to a few hundred MB).
pub const MAX_FILE_BYTES: u64 = 1 << 30;

/// The type of a field's values; the discriminants are the file's type codes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DType {
    /// u8.
    UInt8 = 1,
    /// i8.
    Int8 = 2,
    /// u16.
    UInt16 = 3,
    /// i16.
    Int16 = 4,
    /// u32.
    UInt32 = 5,
    /// i32.
    Int32 = 6,
    /// u64.
    UInt64 = 7,
    /// i64.
    Int64 = 8,
    /// IEEE half.
    Float16 = 9,
    /// IEEE single.
    Float32 = 10,
    /// IEEE double.
    Float64 = 11,
}

impl DType {
    /// The type of file code `code` (0, "invalid", and codes above 11 are not types).
    pub fn from_code(code: u8) -> Option<DType> {
        use DType::*;
        Some(match code {
            1 => UInt8,
            2 => Int8,
            3 => UInt16,
            4 => Int16,
            5 => UInt32,
            6 => Int32,
            7 => UInt64,
            8 => Int64,
            9 => Float16,
            10 => Float32,
            11 => Float64,
            _ => return None,
        })
    }

    /// Bytes per value.
    pub fn size(self) -> usize {
        use DType::*;
        match self {
            UInt8 | Int8 => 1,
            UInt16 | Int16 | Float16 => 2,
            UInt32 | Int32 | Float32 => 4,
            UInt64 | Int64 | Float64 => 8,
        }
    }

    /// The C name, for messages.
    pub fn name(self) -> &'static str {
        use DType::*;
        match self {
            UInt8 => "uint8",
            Int8 => "int8",
            UInt16 => "uint16",
            Int16 => "int16",
            UInt32 => "uint32",
            Int32 => "int32",
            UInt64 => "uint64",
            Int64 => "int64",
            Float16 => "float16",
            Float32 => "float32",
            Float64 => "float64",
        }
    }
}

/// One field's header: where its values are and how they are laid out.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Field {
    /// The field's name.
    pub name: String,
    /// The type of its values.
    pub dtype: DType,
    /// Extent per dimension, outermost first.
    pub shape: Vec<usize>,
    /// Offset of the first value in the file.
    pub offset: usize,
    /// Bytes of data (values × type size), all inside the file.
    pub len: usize,
}

/// A tensor file: its bytes and the headers of its fields, in file order.
#[derive(Clone, Debug)]
pub struct TensorFile {
    bytes: Vec<u8>,
    fields: Vec<Field>,
    index: HashMap<String, usize>,
}

/// Reads little-endian integers from a byte slice, failing with what was being read when the bytes run out.
struct Cursor<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl<'a> Cursor<'a> {
    fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8], RenderError> {
        match self.pos.checked_add(n) {
            Some(end) if end <= self.bytes.len() => {
                let s = &self.bytes[self.pos..end];
                self.pos = end;
                Ok(s)
            }
            _ => Err(bad(format!(
                "truncated: {what} needs {n} bytes at offset {}, the file has {}",
                self.pos,
                self.bytes.len()
            ))),
        }
    }
    fn u8(&mut self, what: &str) -> Result<u8, RenderError> {
        Ok(self.take(1, what)?[0])
    }
    fn u16(&mut self, what: &str) -> Result<u16, RenderError> {
        Ok(u16::from_le_bytes(self.take(2, what)?.try_into().expect("2 bytes")))
    }
    fn u32(&mut self, what: &str) -> Result<u32, RenderError> {
        Ok(u32::from_le_bytes(self.take(4, what)?.try_into().expect("4 bytes")))
    }
    fn u64(&mut self, what: &str) -> Result<u64, RenderError> {
        Ok(u64::from_le_bytes(self.take(8, what)?.try_into().expect("8 bytes")))
    }
    fn remaining(&self) -> usize {
        self.bytes.len() - self.pos
    }
}

/// The fewest bytes a field header can take: name length, rank, type and offset with an empty name and rank 0.
const MIN_FIELD_HEADER: usize = 2 + 2 + 1 + 8;

impl TensorFile {
    /// Reads and checks the file at `path` (at most [`MAX_FILE_BYTES`]); the error names the file.
    pub fn read(path: &Path) -> Result<TensorFile, RenderError> {
        let io = |source| RenderError::Io { path: path.to_path_buf(), source };
        let mut bytes = Vec::new();
        // One byte past the limit tells "exactly the limit" from "more than the limit".
        std::fs::File::open(path).and_then(|f| f.take(MAX_FILE_BYTES + 1).read_to_end(&mut bytes)).map_err(io)?;
        if bytes.len() as u64 > MAX_FILE_BYTES {
            let message = format!("the file is larger than {MAX_FILE_BYTES} bytes, the limit; refusing it");
            return Err(RenderError::InvalidData { path: Some(path.to_path_buf()), message });
        }
        TensorFile::parse(bytes).map_err(|e| e.in_file(path))
    }

    /// Checks a tensor file's bytes and indexes its fields.
    pub fn parse(bytes: Vec<u8>) -> Result<TensorFile, RenderError> {
        let mut c = Cursor { bytes: &bytes, pos: 0 };
        if bytes.len() < 18 {
            return Err(bad(format!("not a tensor file: {} bytes, shorter than the 18-byte header", bytes.len())));
        }
        if c.take(12, "the magic number")? != MAGIC {
            return Err(bad("not a tensor file: it does not start with \"tensor_file\""));
        }
        let version = c.take(2, "the version")?;
        if version != [1, 0] {
            return Err(bad(format!("tensor file version {}.{} is not supported (only 1.0)", version[0], version[1])));
        }
        let n_fields = c.u32("the number of fields")? as usize;
        if n_fields > c.remaining() / MIN_FIELD_HEADER {
            return Err(bad(format!(
                "the header claims {n_fields} fields, more than the {} bytes after it can describe",
                c.remaining()
            )));
        }
        let mut fields = Vec::with_capacity(n_fields);
        let mut index = HashMap::with_capacity(n_fields);
        for i in 0..n_fields {
            let what = |s: &str| format!("field {i}'s {s}");
            let name_len = c.u16(&what("name length"))? as usize;
            let name = std::str::from_utf8(c.take(name_len, &what("name"))?)
                .map_err(|_| bad(format!("field {i}'s name is not UTF-8")))?
                .to_owned();
            let ndim = c.u16(&what("rank"))? as usize;
            let code = c.u8(&what("type"))?;
            let dtype =
                DType::from_code(code).ok_or_else(|| bad(format!("field '{name}' has unknown type code {code}")))?;
            let offset = c.u64(&what("offset"))?;
            if ndim > c.remaining() / 8 {
                return Err(bad(format!(
                    "truncated: field '{name}' claims {ndim} dimensions, past the end of the file"
                )));
            }
            let mut shape = Vec::with_capacity(ndim);
            let mut len = dtype.size() as u64;
            for _ in 0..ndim {
                let extent = c.u64(&what("shape"))?;
                len = len.checked_mul(extent).ok_or_else(|| bad(format!("field '{name}': its shape overflows")))?;
                shape.push(extent);
            }
            let end = offset.checked_add(len);
            if end.is_none_or(|e| e > bytes.len() as u64) {
                return Err(bad(format!(
                    "field '{name}' claims {len} bytes of {} at offset {offset}, past the end of the {}-byte file",
                    dtype.name(),
                    bytes.len()
                )));
            }
            // Inside the file, so every extent and the length fit in usize.
            let shape = shape.into_iter().map(|e| e as usize).collect();
            if index.insert(name.clone(), fields.len()).is_some() {
                return Err(bad(format!("field '{name}' appears twice")));
            }
            fields.push(Field { name, dtype, shape, offset: offset as usize, len: len as usize });
        }
        Ok(TensorFile { bytes, fields, index })
    }

    /// The fields, in file order.
    #[cfg(test)]
    pub fn fields(&self) -> &[Field] {
        &self.fields
    }

    /// The field called `name`, if any.
    pub fn field(&self, name: &str) -> Option<&Field> {
        self.index.get(name).map(|&i| &self.fields[i])
    }

    /// The raw bytes of a field's values.
    pub fn bytes_of(&self, field: &Field) -> &[u8] {
        &self.bytes[field.offset..field.offset + field.len]
    }

    /// A `float32` field's values (an error naming the field if it has another type).
    pub fn f32s(&self, field: &Field) -> Result<Vec<f32>, RenderError> {
        if field.dtype != DType::Float32 {
            let message = format!("field '{}' is {}, expected float32", field.name, field.dtype.name());
            return Err(bad(message));
        }
        Ok(self.bytes_of(field).chunks_exact(4).map(|b| f32::from_le_bytes(b.try_into().expect("4 bytes"))).collect())
    }

    /// The size of the file in bytes.
    #[cfg(test)]
    pub fn size(&self) -> usize {
        self.bytes.len()
    }
}
