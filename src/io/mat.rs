//! MATLAB `.mat` files (Level 5: MATLAB's `-v6` and default `-v7`, scipy's
//! `savemat`, dSPACE ControlDesk's MAT export) read into `f64` columns.
//!
//! Supported: little- and big-endian files, compressed (`-v7`) or not
//! (`-v6`), variables of every real numeric class (double, single, int8 to
//! uint64; integers are converted to `f64`, exactly up to 2^53) that are
//! vectors (row or column) or 2-D matrices whose columns are picked as
//! `name:K` (rows are samples).
//!
//! Not supported, each with a one-line error that says why and what to do:
//! MATLAB v4 files; v7.3 files, which are HDF5 files with a MAT header (re-save
//! with `save(file, '-v7')` in MATLAB or `scipy.io.savemat` in Python);
//! complex, sparse, logical, char, cell, struct and object variables (a
//! ControlDesk record saved as a struct must have its signals saved as
//! separate variables); arrays of three or more dimensions; empty variables;
//! NaN or infinite samples.
//!
//! The numeric data are decoded by the `matfile` crate: small, pure Rust, no
//! C library, and all that a record of real vectors needs. It has no HDF5
//! support, hence the clear error for v7.3 rather than a dependency on
//! libhdf5. `matfile` 0.5 trusts what a file declares (crafted sizes or
//! dimensions overflow its integer arithmetic and panic; it inflates a
//! compressed variable with no bound; it prints to stdout on an unknown
//! element type) and refuses int32 arrays (it checks them against uint32
//! storage). So this module walks the file itself first: it checks every
//! declared size against the bytes it has, refuses a compressed variable
//! that declares more than its stream could inflate to (deflate expands at
//! most 1032:1), inflates only the variables asked for (a listing inflates
//! at most the first 4 KiB of each), and hands `matfile` one checked,
//! uncompressed variable at a time (an int32 one relabelled as double, which
//! converts exactly).
//!
//! Like the rest of [`crate::io`], nothing here touches the file system:
//! callers pass the bytes (or a reader) and a source name for the messages.

use super::InputError;
use std::borrow::Cow;
use std::fmt;
use std::io::Read;

/// The MAT-file header: 116 bytes of text, 8 of subsystem offset, version, endianness.
const HEADER_LEN: usize = 128;
/// The signature of an HDF5 file, found at byte 512 of a v7.3 MAT-file.
const HDF5_SIGNATURE: &[u8; 8] = b"\x89HDF\r\n\x1a\n";
/// Data element types (MAT-file format, table 1-1) used here.
const MI_INT8: u32 = 1;
const MI_INT32: u32 = 5;
const MI_UINT32: u32 = 6;
const MI_MATRIX: u32 = 14;
const MI_COMPRESSED: u32 = 15;
/// The most a deflate stream can expand (258-byte matches in about two bits).
const MAX_DEFLATE_RATIO: usize = 1032;
/// How much of a compressed variable is inflated to read its name, class and size.
const HEADER_PREFIX: usize = 4096;
/// How many names the "the file has" list shows.
const MAX_LISTED: usize = 30;
/// How re-saving a file in a readable format is said in messages.
const RESAVE_HINT: &str =
    "re-save it with save(file, '-v7') in MATLAB, or scipy.io.savemat(file, data) in Python";

/// One requested variable: `name` for a vector (row or column), or `name:K`
/// for the K-th column (1-based) of a 2-D matrix whose rows are samples.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MatColumn {
    /// The variable's name (case-sensitive).
    pub name: String,
    /// The 1-based column of a matrix, if one was named.
    pub column: Option<usize>,
}

impl MatColumn {
    /// Parses the command-line form: `name` or `name:K` (`K` digits; MATLAB
    /// names cannot contain `:`, so any other suffix stays part of the name
    /// and will not be found).
    pub fn parse(text: &str) -> Self {
        let text = text.trim();
        if let Some((name, k)) = text.rsplit_once(':')
            && !k.is_empty()
            && k.bytes().all(|b| b.is_ascii_digit())
            && let Ok(k) = k.parse::<usize>()
        {
            return MatColumn {
                name: name.trim().to_owned(),
                column: Some(k),
            };
        }
        MatColumn {
            name: text.to_owned(),
            column: None,
        }
    }
}

impl fmt::Display for MatColumn {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.column {
            Some(k) => write!(f, "{}:{k}", self.name),
            None => f.write_str(&self.name),
        }
    }
}

/// The MATLAB class of a variable (MAT-file format, table 1-3).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MatClass {
    Cell,
    Struct,
    Object,
    Char,
    Sparse,
    Double,
    Single,
    Int8,
    UInt8,
    Int16,
    UInt16,
    Int32,
    UInt32,
    Int64,
    UInt64,
    /// A function handle.
    Function,
    /// A MATLAB class object (string, table, timeseries, ...).
    Opaque,
}

impl MatClass {
    fn from_code(code: u32) -> Option<Self> {
        use MatClass::*;
        Some(match code {
            1 => Cell,
            2 => Struct,
            3 => Object,
            4 => Char,
            5 => Sparse,
            6 => Double,
            7 => Single,
            8 => Int8,
            9 => UInt8,
            10 => Int16,
            11 => UInt16,
            12 => Int32,
            13 => UInt32,
            14 => Int64,
            15 => UInt64,
            16 => Function,
            17 => Opaque,
            _ => return None,
        })
    }

    /// MATLAB's name of the class (`double`, `int16`, `struct`, ...).
    pub fn name(self) -> &'static str {
        use MatClass::*;
        match self {
            Cell => "cell",
            Struct => "struct",
            Object => "object",
            Char => "char",
            Sparse => "sparse",
            Double => "double",
            Single => "single",
            Int8 => "int8",
            UInt8 => "uint8",
            Int16 => "int16",
            UInt16 => "uint16",
            Int32 => "int32",
            UInt32 => "uint32",
            Int64 => "int64",
            UInt64 => "uint64",
            Function => "function_handle",
            Opaque => "object (opaque)",
        }
    }

    /// A full numeric class (double, single or an integer type).
    pub fn is_numeric(self) -> bool {
        use MatClass::*;
        matches!(
            self,
            Double | Single | Int8 | UInt8 | Int16 | UInt16 | Int32 | UInt32 | Int64 | UInt64
        )
    }
}

impl fmt::Display for MatClass {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A variable of a MAT-file, as its header describes it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MatVariable {
    /// The variable's name.
    pub name: String,
    /// Its dimensions (rows, columns, ...); empty for opaque objects.
    pub dims: Vec<usize>,
    /// Its class.
    pub class: MatClass,
    /// Complex values.
    pub complex: bool,
    /// A logical array (stored as uint8, or sparse).
    pub logical: bool,
}

impl MatVariable {
    /// What the variable is, e.g. `double`, `complex double`, `logical`, `sparse`.
    pub fn kind(&self) -> String {
        match self.class {
            MatClass::Sparse if self.logical => "sparse logical".to_owned(),
            MatClass::Sparse if self.complex => "complex sparse".to_owned(),
            _ if self.logical => "logical".to_owned(),
            c if self.complex => format!("complex {c}"),
            c => c.name().to_owned(),
        }
    }

    /// The dimensions as MATLAB prints them, e.g. `200x1`.
    pub fn size_text(&self) -> String {
        if self.dims.is_empty() {
            return "?".to_owned();
        }
        let dims: Vec<String> = self.dims.iter().map(usize::to_string).collect();
        dims.join("x")
    }

    /// A real numeric array (what [`read_columns`] accepts, shape aside).
    pub fn is_real_numeric(&self) -> bool {
        self.class.is_numeric() && !self.complex && !self.logical
    }

    /// The dimensions without trailing singleton dimensions past the second.
    fn shape(&self) -> &[usize] {
        let mut n = self.dims.len();
        while n > 2 && self.dims[n - 1] == 1 {
            n -= 1;
        }
        &self.dims[..n]
    }

    /// The number of samples, for a non-empty real numeric vector (row or column).
    pub fn vector_len(&self) -> Option<usize> {
        match self.shape() {
            &[r, c] if self.is_real_numeric() && r.min(c) == 1 => Some(r.max(c)),
            _ => None,
        }
    }
}

impl fmt::Display for MatVariable {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} ({} {})", self.name, self.size_text(), self.kind())
    }
}

/// Why `head` (a file's first bytes) is no text table and no MAT v5/v7
/// file, if it is binary: a MATLAB v4 file, or any file with a NUL or
/// another control byte a text table never holds (tab, line feed, carriage
/// return and form feed are text). The message quotes no byte of it.
pub fn binary_reason(head: &[u8]) -> Option<String> {
    if looks_like_v4(head) {
        return Some(format!(
            "a MATLAB v4 MAT-file, which fts does not read; {RESAVE_HINT}"
        ));
    }
    let text = |b: u8| b >= 0x20 || matches!(b, b'\t' | b'\n' | b'\r' | 0x0c);
    let at = head.iter().take(BINARY_SNIFF).position(|&b| !text(b))?;
    Some(format!(
        "binary content (byte {at} is 0x{:02x}), not a text table (CSV, DaISy .dat) or a MAT v5/v7 file",
        head[at]
    ))
}

/// How much of a file's start [`binary_reason`] looks at.
const BINARY_SNIFF: usize = 4096;

/// Whether `bytes` look like a MAT-file of any version: the text header of
/// a Level 5 or v7.3 file, its binary version and endianness marker, or the
/// HDF5 signature at byte 512 of a v7.3 file.
pub fn is_mat(bytes: &[u8]) -> bool {
    bytes.starts_with(b"MATLAB 5.0 MAT-file")
        || bytes.starts_with(b"MATLAB 7.3 MAT-file")
        || hdf5_at_512(bytes)
        || matches!(
            bytes.get(124..HEADER_LEN),
            Some([0x00, 0x01 | 0x02, b'I', b'M'] | [0x01 | 0x02, 0x00, b'M', b'I'])
        )
}

/// The variables of a Level 5 MAT-file, in file order (unnamed elements,
/// such as MATLAB's subsystem data, are left out).
pub fn variables(bytes: &[u8], source: &str) -> Result<Vec<MatVariable>, InputError> {
    Ok(directory(bytes, source)?
        .into_iter()
        .map(|e| e.var)
        .collect())
}

/// Reads the requested columns, in order. Every one must be a real numeric
/// vector (or a named column of a 2-D matrix) of finite samples, and all
/// must have the same length.
pub fn read_columns(
    bytes: &[u8],
    source: &str,
    columns: &[MatColumn],
) -> Result<Vec<Vec<f64>>, InputError> {
    let dir = directory(bytes, source)?;
    let endian = endianness(bytes).unwrap_or(Endian::Little);
    let mut decoded: Vec<Option<Vec<f64>>> = vec![None; dir.len()];
    let mut out: Vec<Vec<f64>> = Vec::with_capacity(columns.len());
    for col in columns {
        let field = col.to_string();
        let err = |msg: String| InputError::new(source, msg).in_field(&field);
        let Some(index) = dir.iter().position(|e| e.var.name == col.name) else {
            return Err(err(format!(
                "no variable '{}' ({})",
                col.name,
                listing(&dir)
            )));
        };
        let var = &dir[index].var;
        let (rows, cols) = check_shape(var, col).map_err(&err)?;
        if decoded[index].is_none() {
            let values = decode(&dir[index], endian)
                .map_err(|m| err(format!("'{}' could not be decoded: {m}", col.name)))?;
            decoded[index] = Some(values);
        }
        let values = decoded[index].as_deref().unwrap_or_default();
        let k = col.column.unwrap_or(1);
        let range = if cols == 1 || rows == 1 {
            0..values.len()
        } else {
            (k - 1) * rows..k * rows
        };
        let column = values.get(range).ok_or_else(|| {
            err(format!(
                "'{}' holds fewer values than its size says",
                col.name
            ))
        })?;
        if let Some(j) = column.iter().position(|v| !v.is_finite()) {
            return Err(err(format!(
                "sample {} is {}; every sample must be finite",
                j + 1,
                column[j]
            )));
        }
        if let Some(first) = out.first()
            && first.len() != column.len()
        {
            return Err(err(format!(
                "{} samples, but '{}' has {}; all columns must have the same length",
                column.len(),
                columns[0],
                first.len()
            )));
        }
        out.push(column.to_vec());
    }
    Ok(out)
}

/// [`read_columns`] from a reader (read to its end first).
pub fn read_columns_from<R: Read>(
    mut reader: R,
    source: &str,
    columns: &[MatColumn],
) -> Result<Vec<Vec<f64>>, InputError> {
    let mut bytes = Vec::new();
    reader
        .read_to_end(&mut bytes)
        .map_err(|e| InputError::new(source, format!("cannot read: {e}")))?;
    read_columns(&bytes, source, columns)
}

/// Checks class and shape against the request; returns (rows, columns).
fn check_shape(var: &MatVariable, col: &MatColumn) -> Result<(usize, usize), String> {
    let name = &var.name;
    if !var.is_real_numeric() {
        let (what, hint) = match var.class {
            MatClass::Struct => (
                "a struct",
                " (save its fields as separate variables)".into(),
            ),
            MatClass::Cell => (
                "a cell array",
                " (save its cells as separate variables)".into(),
            ),
            MatClass::Char => ("a char array (text)", String::new()),
            MatClass::Sparse => ("a sparse matrix", format!(" (save full({name}))")),
            MatClass::Object | MatClass::Opaque => (
                "a MATLAB object",
                " (save its data as separate numeric variables)".into(),
            ),
            MatClass::Function => ("a function handle", String::new()),
            _ if var.logical => ("logical", format!(" (save double({name}))")),
            _ => ("complex", format!(" (save real({name}) or abs({name}))")),
        };
        return Err(format!(
            "'{name}' is {what} ({} {}); a real numeric vector is needed{hint}",
            var.size_text(),
            var.kind()
        ));
    }
    let (rows, cols) = match var.shape() {
        &[r, c] => (r, c),
        shape => {
            return Err(format!(
                "'{name}' is a {}-D array ({}); a vector or a 2-D matrix is needed",
                shape.len(),
                var.size_text()
            ));
        }
    };
    if rows == 0 || cols == 0 {
        return Err(format!("'{name}' is empty ({})", var.size_text()));
    }
    let vector = rows == 1 || cols == 1;
    match col.column {
        None if !vector => Err(format!(
            "'{name}' is a {rows}x{cols} matrix; name one column, '{name}:1' to '{name}:{cols}' (rows are samples)"
        )),
        Some(k) if vector && k != 1 => Err(format!(
            "column {k} out of range: '{name}' is a vector ({}), its only column is '{name}:1'",
            var.size_text()
        )),
        Some(k) if !vector && (k == 0 || k > cols) => Err(format!(
            "column {k} out of range: '{name}' is a {rows}x{cols} matrix, its columns are 1 to {cols}"
        )),
        _ => Ok((rows, cols)),
    }
}

/// "the file has: a, b, c" for a missing-variable message.
fn listing(dir: &[Entry<'_>]) -> String {
    if dir.is_empty() {
        return "the file has no variables".to_owned();
    }
    let names: Vec<&str> = dir
        .iter()
        .take(MAX_LISTED)
        .map(|e| e.var.name.as_str())
        .collect();
    let mut text = format!("the file has: {}", names.join(", "));
    if dir.len() > MAX_LISTED {
        text.push_str(&format!(", ... ({} more)", dir.len() - MAX_LISTED));
    }
    text
}

// ---------------------------------------------------------------------------
// The file's structure.

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Endian {
    Little,
    Big,
}

impl Endian {
    fn u32(self, b: [u8; 4]) -> u32 {
        match self {
            Endian::Little => u32::from_le_bytes(b),
            Endian::Big => u32::from_be_bytes(b),
        }
    }

    fn u32_bytes(self, v: u32) -> [u8; 4] {
        match self {
            Endian::Little => v.to_le_bytes(),
            Endian::Big => v.to_be_bytes(),
        }
    }
}

/// A variable's place in the file.
#[derive(Debug)]
enum Body<'a> {
    /// The bytes after the miMATRIX tag.
    Plain(&'a [u8]),
    /// A zlib stream holding a miMATRIX tag and `size` bytes.
    Compressed { stream: &'a [u8], size: usize },
}

#[derive(Debug)]
struct Entry<'a> {
    var: MatVariable,
    body: Body<'a>,
}

fn hdf5_at_512(bytes: &[u8]) -> bool {
    bytes.get(512..520) == Some(HDF5_SIGNATURE.as_slice())
}

/// The byte order of a Level 5 header (version 0x0100), if `bytes` start with one.
fn endianness(bytes: &[u8]) -> Option<Endian> {
    match bytes.get(124..HEADER_LEN)? {
        [0x00, 0x01, b'I', b'M'] => Some(Endian::Little),
        [0x01, 0x00, b'M', b'I'] => Some(Endian::Big),
        _ => None,
    }
}

fn is_v73(bytes: &[u8]) -> bool {
    bytes.starts_with(b"MATLAB 7.3")
        || matches!(
            bytes.get(124..HEADER_LEN),
            Some([0x00, 0x02, b'I', b'M'] | [0x02, 0x00, b'M', b'I'])
        )
        || (hdf5_at_512(bytes) && endianness(bytes).is_none())
}

/// A MATLAB v4 file starts with a matrix header: type code MOPT
/// (M 0..4, O 0, P 0..5, T 0..2), rows, columns, imaginary flag, name length.
pub(crate) fn looks_like_v4(bytes: &[u8]) -> bool {
    let Some(head) = bytes.get(..20) else {
        return false;
    };
    let word = |i: usize, big: bool| {
        let b = [head[i], head[i + 1], head[i + 2], head[i + 3]];
        if big {
            u32::from_be_bytes(b)
        } else {
            u32::from_le_bytes(b)
        }
    };
    [false, true].into_iter().any(|big| {
        let mopt = word(0, big);
        let (m, o, p, t) = (mopt / 1000, mopt / 100 % 10, mopt / 10 % 10, mopt % 10);
        let namlen = word(16, big) as usize;
        m <= 4
            && o == 0
            && p <= 5
            && t <= 2
            && word(12, big) <= 1
            && (1..=64).contains(&namlen)
            && bytes.get(20 + namlen - 1) == Some(&0)
    })
}

/// Checks the header and lists the variables with where their data are.
fn directory<'a>(bytes: &'a [u8], source: &str) -> Result<Vec<Entry<'a>>, InputError> {
    let fail = |msg: String| InputError::new(source, msg);
    if is_v73(bytes) {
        return Err(fail(format!(
            "a MATLAB v7.3 MAT-file (HDF5), which fts does not read; {RESAVE_HINT}"
        )));
    }
    let Some(endian) = endianness(bytes) else {
        let what = if bytes.starts_with(b"MATLAB 5.0") && bytes.len() < HEADER_LEN {
            "the file ends inside the 128-byte header"
        } else if looks_like_v4(bytes) {
            "it looks like a MATLAB v4 file"
        } else {
            "no MAT-file header"
        };
        return Err(fail(format!(
            "not a MAT v5/v7 file ({what}); {RESAVE_HINT}"
        )));
    };
    let mut entries = Vec::new();
    let mut pos = HEADER_LEN;
    let mut number = 0usize;
    while pos < bytes.len() {
        let rest = &bytes[pos..];
        number += 1;
        let corrupt = |msg: String| {
            fail(format!(
                "corrupt MAT-file: element {number} (byte {pos}): {msg}"
            ))
        };
        let Some(tag) = rest.get(..8) else {
            if rest.iter().all(|&b| b == 0) {
                break;
            }
            return Err(corrupt("the file ends in the middle of a tag".to_owned()));
        };
        let ty = endian.u32([tag[0], tag[1], tag[2], tag[3]]);
        let size = endian.u32([tag[4], tag[5], tag[6], tag[7]]) as usize;
        let data = rest.get(8..).and_then(|r| r.get(..size)).ok_or_else(|| {
            corrupt(format!(
                "declares {size} bytes but only {} remain (truncated file?)",
                rest.len() - 8
            ))
        })?;
        let (var, body, advance) = match ty {
            MI_MATRIX => {
                let (var, _) = parse_header(data, endian).map_err(corrupt)?;
                (var, Body::Plain(data), 8 + size.div_ceil(8) * 8)
            }
            MI_COMPRESSED => {
                let prefix = inflate(data, HEADER_PREFIX).map_err(&corrupt)?;
                let (inner_size, body) = matrix_tag(&prefix, endian).map_err(&corrupt)?;
                if inner_size
                    > data
                        .len()
                        .saturating_mul(MAX_DEFLATE_RATIO)
                        .saturating_add(1024)
                {
                    return Err(corrupt(format!(
                        "declares {inner_size} bytes, more than {} compressed bytes can hold",
                        data.len()
                    )));
                }
                let (var, _) = parse_header(body, endian).map_err(corrupt)?;
                let body = Body::Compressed {
                    stream: data,
                    size: inner_size,
                };
                (var, body, 8 + size)
            }
            0 if rest.iter().all(|&b| b == 0) => break,
            _ => {
                return Err(corrupt(format!(
                    "unexpected data element type {ty} (a variable is type 14 or 15)"
                )));
            }
        };
        if !var.name.is_empty() {
            entries.push(Entry { var, body });
        }
        pos = pos.saturating_add(advance);
    }
    Ok(entries)
}

/// Reads the miMATRIX tag at the start of inflated data: (declared size, the bytes after it).
fn matrix_tag(data: &[u8], endian: Endian) -> Result<(usize, &[u8]), String> {
    let tag = data.get(..8).ok_or("compressed data too short for a tag")?;
    let ty = endian.u32([tag[0], tag[1], tag[2], tag[3]]);
    let size = endian.u32([tag[4], tag[5], tag[6], tag[7]]) as usize;
    if ty != MI_MATRIX {
        return Err(format!(
            "compressed data hold element type {ty}, not a matrix (14)"
        ));
    }
    let rest = &data[8..];
    Ok((size, &rest[..size.min(rest.len())]))
}

/// Inflates at most `limit` bytes of a zlib stream.
fn inflate(stream: &[u8], limit: usize) -> Result<Vec<u8>, String> {
    let decoder =
        libflate::zlib::Decoder::new(stream).map_err(|e| format!("bad compressed data: {e}"))?;
    let mut out = Vec::new();
    decoder
        .take(limit as u64)
        .read_to_end(&mut out)
        .map_err(|e| format!("bad compressed data: {e}"))?;
    Ok(out)
}

/// A cursor over the sub-elements of a matrix.
struct Cursor<'a> {
    buf: &'a [u8],
    pos: usize,
    endian: Endian,
}

impl<'a> Cursor<'a> {
    fn take(&mut self, n: usize) -> Result<&'a [u8], String> {
        let out = self
            .buf
            .get(self.pos..)
            .and_then(|r| r.get(..n))
            .ok_or_else(|| {
                format!(
                    "a sub-element declares {n} bytes but only {} remain",
                    self.buf.len().saturating_sub(self.pos)
                )
            })?;
        self.pos += n;
        Ok(out)
    }

    fn u32(&mut self) -> Result<u32, String> {
        let b = self.take(4)?;
        Ok(self.endian.u32([b[0], b[1], b[2], b[3]]))
    }

    /// One sub-element (small or long format): (type, data). Skips the
    /// padding to 8 bytes, or what there is of it at the end.
    fn element(&mut self) -> Result<(u32, &'a [u8]), String> {
        let first = self.u32()?;
        if first >> 16 != 0 {
            let size = (first >> 16) as usize;
            if size > 4 {
                return Err(format!(
                    "a small sub-element declares {size} bytes (at most 4)"
                ));
            }
            let data = self.take(4)?;
            Ok((first & 0xFFFF, &data[..size]))
        } else {
            let size = self.u32()? as usize;
            let data = self.take(size)?;
            let pad = (8 - size % 8) % 8;
            self.pos = (self.pos + pad).min(self.buf.len());
            Ok((first, data))
        }
    }
}

/// Parses the array flags, dimensions and name at the start of a matrix
/// body; returns the variable and the offset of the data after the name.
fn parse_header(body: &[u8], endian: Endian) -> Result<(MatVariable, usize), String> {
    let mut c = Cursor {
        buf: body,
        pos: 0,
        endian,
    };
    if body.is_empty() {
        // MATLAB writes an empty miMATRIX for an empty cell element; at top level, ignore it.
        return Ok((
            MatVariable {
                name: String::new(),
                dims: Vec::new(),
                class: MatClass::Double,
                complex: false,
                logical: false,
            },
            0,
        ));
    }
    let (ty, flags) = c.element()?;
    if ty != MI_UINT32 || flags.len() != 8 {
        return Err("the array flags are missing".to_owned());
    }
    let word = endian.u32([flags[0], flags[1], flags[2], flags[3]]);
    let class = MatClass::from_code(word & 0xFF)
        .ok_or_else(|| format!("unknown array class {}", word & 0xFF))?;
    let mut dims = Vec::new();
    if class != MatClass::Opaque {
        let (ty, raw) = c.element()?;
        if ty != MI_INT32 || raw.len() < 8 || raw.len() % 4 != 0 {
            return Err("the dimensions are missing".to_owned());
        }
        for d in raw.chunks_exact(4) {
            let d = endian.u32([d[0], d[1], d[2], d[3]]) as i32;
            dims.push(usize::try_from(d).map_err(|_| format!("a negative dimension ({d})"))?);
        }
    }
    let (ty, name) = c.element()?;
    if ty != MI_INT8 {
        return Err("the array name is missing".to_owned());
    }
    let var = MatVariable {
        name: String::from_utf8_lossy(name).into_owned(),
        dims,
        class,
        complex: word & 0x0800 != 0,
        logical: word & 0x0200 != 0,
    };
    Ok((var, c.pos))
}

/// Bytes per value of a numeric data type, or `None` for another type.
fn element_size(ty: u32) -> Option<usize> {
    match ty {
        1 | 2 => Some(1),       // int8, uint8
        3 | 4 => Some(2),       // int16, uint16
        5..=7 => Some(4),       // int32, uint32, single
        9 | 12 | 13 => Some(8), // double, int64, uint64
        _ => None,
    }
}

/// The real part of a (checked real numeric) variable, column-major, as f64.
fn decode(entry: &Entry<'_>, endian: Endian) -> Result<Vec<f64>, String> {
    let body: Cow<'_, [u8]> = match entry.body {
        Body::Plain(b) => Cow::Borrowed(b),
        Body::Compressed { stream, size } => {
            let all = inflate(stream, size + 8)?;
            let (_, body) = matrix_tag(&all, endian)?;
            if body.len() < size {
                return Err(format!(
                    "compressed data end after {} of {size} bytes",
                    body.len()
                ));
            }
            Cow::Owned(body.to_vec())
        }
    };
    let (var, data_pos) = parse_header(&body, endian)?;
    // The real part: a numeric type, whole values, one per element.
    let mut c = Cursor {
        buf: &body,
        pos: data_pos,
        endian,
    };
    let (ty, real) = c.element()?;
    let size = element_size(ty).ok_or_else(|| format!("data of type {ty} are not numbers"))?;
    let count = var
        .dims
        .iter()
        .try_fold(1usize, |acc, &d| {
            // matfile multiplies the dimensions in i32: every partial product must fit
            acc.checked_mul(d).filter(|&n| n <= i32::MAX as usize)
        })
        .ok_or_else(|| format!("size {} is too large", var.size_text()))?;
    if real.len() != count * size {
        return Err(format!(
            "size {} needs {count} values but the data hold {} bytes of {size}-byte values",
            var.size_text(),
            real.len()
        ));
    }
    // One uncompressed variable for matfile: a fixed header, the miMATRIX
    // tag, the body padded to 8 bytes.
    let padded = body.len().div_ceil(8) * 8;
    let tag_size = u32::try_from(padded).map_err(|_| "variable too large".to_owned())?;
    let mut file = Vec::with_capacity(HEADER_LEN + 8 + padded);
    file.extend_from_slice(&[b' '; 116]);
    file[..19].copy_from_slice(b"MATLAB 5.0 MAT-file");
    file.extend_from_slice(&[0; 8]);
    file.extend_from_slice(match endian {
        Endian::Little => &[0x00, 0x01, b'I', b'M'],
        Endian::Big => &[0x01, 0x00, b'M', b'I'],
    });
    file.extend_from_slice(&endian.u32_bytes(MI_MATRIX));
    file.extend_from_slice(&endian.u32_bytes(tag_size));
    let body_start = file.len();
    file.extend_from_slice(&body);
    file.resize(body_start + padded, 0);
    if var.class == MatClass::Int32 {
        // matfile 0.5 checks int32 arrays against uint32 storage and refuses
        // them; as class double the int32 values convert exactly.
        let at = body_start + 8; // after the flags' tag
        let word = endian.u32([file[at], file[at + 1], file[at + 2], file[at + 3]]);
        file[at..at + 4].copy_from_slice(&endian.u32_bytes((word & !0xFF) | 6));
    }
    let parsed = matfile::MatFile::parse(file.as_slice()).map_err(|e| e.to_string())?;
    let [array] = parsed.arrays().as_slice() else {
        return Err("unexpected layout".to_owned());
    };
    use matfile::NumericData as N;
    let values: Vec<f64> = match array.data() {
        N::Double { real, .. } => real.clone(),
        N::Single { real, .. } => real.iter().map(|&v| f64::from(v)).collect(),
        N::Int8 { real, .. } => real.iter().map(|&v| f64::from(v)).collect(),
        N::UInt8 { real, .. } => real.iter().map(|&v| f64::from(v)).collect(),
        N::Int16 { real, .. } => real.iter().map(|&v| f64::from(v)).collect(),
        N::UInt16 { real, .. } => real.iter().map(|&v| f64::from(v)).collect(),
        N::Int32 { real, .. } => real.iter().map(|&v| f64::from(v)).collect(),
        N::UInt32 { real, .. } => real.iter().map(|&v| f64::from(v)).collect(),
        N::Int64 { real, .. } => real.iter().map(|&v| v as f64).collect(),
        N::UInt64 { real, .. } => real.iter().map(|&v| v as f64).collect(),
    };
    if values.len() != count {
        return Err(format!(
            "{} values for size {}",
            values.len(),
            var.size_text()
        ));
    }
    Ok(values)
}

#[cfg(feature = "checks")]
#[doc(hidden)]
pub mod checks {
    use super::*;
    use std::io::Write;

    /// A hand-built MAT-file, for layouts scipy does not write.
    struct Builder {
        endian: Endian,
    }

    impl Builder {
        fn u32(&self, v: u32) -> [u8; 4] {
            self.endian.u32_bytes(v)
        }

        /// A long-format element, padded to 8 bytes.
        fn element(&self, ty: u32, data: &[u8]) -> Vec<u8> {
            let mut out = Vec::new();
            out.extend_from_slice(&self.u32(ty));
            out.extend_from_slice(&self.u32(data.len() as u32));
            out.extend_from_slice(data);
            out.resize(out.len().div_ceil(8) * 8, 0);
            out
        }

        /// A miMATRIX element of class `class` with data of type `ty`.
        fn matrix(&self, class: u32, dims: &[i32], name: &str, ty: u32, data: &[u8]) -> Vec<u8> {
            let mut body = Vec::new();
            let mut flags = self.u32(class).to_vec();
            flags.extend_from_slice(&[0; 4]);
            body.extend(self.element(MI_UINT32, &flags));
            let dims: Vec<u8> = dims.iter().flat_map(|&d| self.u32(d as u32)).collect();
            body.extend(self.element(MI_INT32, &dims));
            body.extend(self.element(MI_INT8, name.as_bytes()));
            body.extend(self.element(ty, data));
            self.element(MI_MATRIX, &body)
        }

        fn compressed(&self, element: &[u8]) -> Vec<u8> {
            let mut enc = libflate::zlib::Encoder::new(Vec::new()).unwrap();
            enc.write_all(element).unwrap();
            let stream = enc.finish().into_result().unwrap();
            let mut out = self.u32(MI_COMPRESSED).to_vec();
            out.extend_from_slice(&self.u32(stream.len() as u32));
            out.extend(stream);
            out
        }

        fn file(&self, elements: &[Vec<u8>]) -> Vec<u8> {
            let mut out = b"MATLAB 5.0 MAT-file, hand-built".to_vec();
            out.resize(124, b' ');
            out.extend_from_slice(match self.endian {
                Endian::Little => &[0x00, 0x01, b'I', b'M'],
                Endian::Big => &[0x01, 0x00, b'M', b'I'],
            });
            for e in elements {
                out.extend_from_slice(e);
            }
            out
        }
    }

    const LE: Builder = Builder {
        endian: Endian::Little,
    };
    const BE: Builder = Builder {
        endian: Endian::Big,
    };

    fn col(text: &str) -> Vec<MatColumn> {
        vec![MatColumn::parse(text)]
    }

    fn f64s(b: &Builder, v: &[f64]) -> Vec<u8> {
        v.iter()
            .flat_map(|x| match b.endian {
                Endian::Little => x.to_le_bytes(),
                Endian::Big => x.to_be_bytes(),
            })
            .collect()
    }

    pub fn column_syntax() {
        assert_eq!(
            MatColumn::parse(" data:3 "),
            MatColumn {
                name: "data".into(),
                column: Some(3)
            }
        );
        assert_eq!(MatColumn::parse("pos_um").column, None);
        assert_eq!(MatColumn::parse("x:0").column, Some(0));
        assert_eq!(MatColumn::parse("a:b").name, "a:b");
        assert_eq!(MatColumn::parse("a:").name, "a:");
        assert_eq!(MatColumn::parse("a:+2").name, "a:+2");
        assert_eq!(MatColumn::parse("data:2").to_string(), "data:2");
    }

    pub fn big_endian_and_compact_storage() {
        // MATLAB stores doubles holding small integers as uint8 or int16.
        for b in [&LE, &BE] {
            let y: Vec<u8> = [-3i16, 0, 700]
                .iter()
                .flat_map(|v| match b.endian {
                    Endian::Little => v.to_le_bytes(),
                    Endian::Big => v.to_be_bytes(),
                })
                .collect();
            let file = b.file(&[
                b.matrix(6, &[3, 1], "x", 9, &f64s(b, &[0.5, -1.25, 1e300])),
                b.compressed(&b.matrix(6, &[1, 3], "y", 3, &y)),
                b.matrix(6, &[3, 1], "u", 2, &[1, 2, 255]),
                b.matrix(12, &[3, 1], "i", 5, &f64s(b, &[0.0, 0.0])[..12]),
            ]);
            assert!(is_mat(&file));
            let cols: Vec<MatColumn> = ["x", "y", "u", "i"].map(MatColumn::parse).to_vec();
            let got = read_columns(&file, "hand.mat", &cols).unwrap();
            assert_eq!(got[0], [0.5, -1.25, 1e300]);
            assert_eq!(got[1], [-3.0, 0.0, 700.0]);
            assert_eq!(got[2], [1.0, 2.0, 255.0]);
            assert_eq!(got[3], [0.0, 0.0, 0.0]);
            let vars = variables(&file, "hand.mat").unwrap();
            assert_eq!(vars[1].dims, [1, 3]);
            assert_eq!(vars[3].class, MatClass::Int32);
        }
    }

    pub fn sixty_four_bit_integers() {
        let data: Vec<u8> = [-(1i64 << 53), 7]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        let file = LE.file(&[LE.matrix(14, &[2, 1], "n", 12, &data)]);
        assert_eq!(
            read_columns(&file, "n.mat", &col("n")).unwrap()[0],
            [-(2f64.powi(53)), 7.0]
        );
    }

    pub fn declared_sizes_beyond_the_bytes_are_refused() {
        // A top-level element declaring 4 GiB.
        let mut file = LE.file(&[LE.matrix(6, &[1, 1], "x", 9, &f64s(&LE, &[1.0]))]);
        file[132..136].copy_from_slice(&u32::MAX.to_le_bytes());
        let e = variables(&file, "big.mat").unwrap_err().to_string();
        assert!(e.contains("declares 4294967295 bytes"), "{e}");
        // Dimensions whose product overflows i32, with one value.
        let file = LE.file(&[LE.matrix(6, &[65536, 65536], "x", 9, &f64s(&LE, &[1.0]))]);
        let e = read_columns(&file, "dims.mat", &col("x:1"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("too large"), "{e}");
        // A compressed element whose matrix claims far more than the stream can inflate to.
        let mut inner = LE.matrix(6, &[1, 1], "x", 9, &f64s(&LE, &[1.0]));
        inner[4..8].copy_from_slice(&0xFFFF_FFF0u32.to_le_bytes());
        let file = LE.file(&[LE.compressed(&inner)]);
        let e = variables(&file, "zip.mat").unwrap_err().to_string();
        assert!(e.contains("more than"), "{e}");
        // A sub-element (the real part) declaring more than the matrix holds.
        let mut file = LE.file(&[LE.matrix(6, &[1, 1], "x", 9, &f64s(&LE, &[1.0]))]);
        let at = file.len() - 12;
        file[at..at + 4].copy_from_slice(&0xFFFF_FFFFu32.to_le_bytes());
        let e = read_columns(&file, "sub.mat", &col("x"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("could not be decoded") && e.contains("declares"),
            "{e}"
        );
        // A data count that disagrees with the dimensions.
        let file = LE.file(&[LE.matrix(6, &[3, 1], "x", 9, &f64s(&LE, &[1.0, 2.0]))]);
        let e = read_columns(&file, "count.mat", &col("x"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("needs 3 values"), "{e}");
    }

    pub fn structure_errors() {
        let good = LE.matrix(6, &[1, 1], "x", 9, &f64s(&LE, &[1.0]));
        // Nested compression and other element types at top level.
        let file = LE.file(&[LE.compressed(&LE.compressed(&good))]);
        let e = variables(&file, "n.mat").unwrap_err().to_string();
        assert!(e.contains("not a matrix"), "{e}");
        let file = LE.file(&[LE.element(9, &f64s(&LE, &[1.0]))]);
        let e = variables(&file, "t.mat").unwrap_err().to_string();
        assert!(e.contains("unexpected data element type 9"), "{e}");
        // Trailing zero bytes are ignored, trailing junk is not.
        let mut file = LE.file(std::slice::from_ref(&good));
        file.extend_from_slice(&[0; 13]);
        assert_eq!(variables(&file, "z.mat").unwrap().len(), 1);
        let mut file = LE.file(std::slice::from_ref(&good));
        file.extend_from_slice(&[1, 2, 3]);
        let e = variables(&file, "j.mat").unwrap_err().to_string();
        assert!(e.contains("ends in the middle of a tag"), "{e}");
        // A negative dimension, an unknown class.
        let file = LE.file(&[LE.matrix(6, &[-1, -1], "x", 9, &f64s(&LE, &[1.0]))]);
        assert!(
            variables(&file, "neg.mat")
                .unwrap_err()
                .to_string()
                .contains("negative")
        );
        let file = LE.file(&[LE.matrix(40, &[1, 1], "x", 9, &f64s(&LE, &[1.0]))]);
        assert!(
            variables(&file, "cls.mat")
                .unwrap_err()
                .to_string()
                .contains("unknown array class 40")
        );
        // A header cut short.
        let file = LE.file(&[]);
        let e = variables(&file[..60], "short.mat").unwrap_err().to_string();
        assert!(e.contains("ends inside the 128-byte header"), "{e}");
    }

    pub fn is_mat_recognises_headers() {
        assert!(is_mat(&LE.file(&[])));
        assert!(is_mat(&BE.file(&[])));
        assert!(!is_mat(b"t,x\n0,1\n"));
        assert!(!is_mat(b""));
        let mut v73 = vec![0u8; 520];
        v73[512..].copy_from_slice(HDF5_SIGNATURE);
        assert!(is_mat(&v73));
    }
}
