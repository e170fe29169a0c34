//! Reading and writing the arrays of a `.npz` archive (numpy's `np.savez` format: a zip of `.npy`
//! files), with the dtype checks the episode-set format needs. The one `.npz` reader and writer of
//! the project: [`read_array`] and [`write_arrays`] are its public face (e.g. `defender env
//! replay` writes its rollout with them).

use std::fs::File;
use std::io::{BufReader, Read, Seek, Write};
use std::path::{Path, PathBuf};

use npyz::{DType, NpyFile, NpyHeader, Order, TypeChar, WriterBuilder};

use crate::error::{DefenderError, Result};

/// The values of one array, in the dtype the file holds them.
#[derive(Debug, Clone, PartialEq)]
pub enum Values {
    /// float32 or float64, widened to f64 only when the file holds float64.
    F32(Vec<f32>),
    /// float64.
    F64(Vec<f64>),
    /// Any signed or unsigned integer of at most 8 bytes, widened to i64 (u64 over i64::MAX is refused).
    Int(Vec<i64>),
    /// bool.
    Bool(Vec<bool>),
    /// uint8 (also reported as `Int` for integer arrays; kept apart for `meta`).
    U8(Vec<u8>),
}

/// One array read from an archive: shape and values in C (row-major) order.
#[derive(Debug, Clone)]
pub(crate) struct Array {
    pub shape: Vec<usize>,
    pub values: Values,
    pub descr: String,
}

/// A deflated entry cannot expand more than about 1032:1; an archive whose directory claims more
/// is lying (a zip bomb or a corrupt file) and is refused before anything is inflated.
const MAX_DEFLATE_RATIO: u64 = 1100;

/// What an array's `.npy` header declares, already checked against the size of its archive entry
/// (so that nothing is allocated from a declared size the file cannot back).
#[derive(Debug, Clone)]
pub(crate) struct Header {
    /// The declared shape.
    pub shape: Vec<usize>,
    /// Number of elements (the product of `shape`, known not to overflow).
    pub len: usize,
    /// numpy's dtype string (`<f4`, `<i8`, `|b1` ...).
    pub descr: String,
    type_char: TypeChar,
    size: u64,
}

impl Header {
    /// A float32 or float64 array.
    pub fn is_float(&self) -> bool {
        self.type_char == TypeChar::Float && matches!(self.size, 4 | 8)
    }

    /// A signed or unsigned integer array (uint8 included).
    pub fn is_int(&self) -> bool {
        matches!(self.type_char, TypeChar::Int | TypeChar::Uint) && matches!(self.size, 1 | 2 | 4 | 8)
    }

    /// A bool array.
    pub fn is_bool(&self) -> bool {
        self.type_char == TypeChar::Bool && self.size == 1
    }
}

/// An open `.npz` archive.
pub(crate) struct NpzReader {
    path: PathBuf,
    file_len: u64,
    zip: zip::ZipArchive<BufReader<File>>,
}

/// Counts the bytes read through it (the length of a `.npy` header).
struct Counting<R> {
    inner: R,
    count: u64,
}

impl<R: Read> Read for Counting<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.count += n as u64;
        Ok(n)
    }
}

type Entry<'a> = zip::read::ZipFile<'a, BufReader<File>>;

/// numpy refuses `.npy` headers longer than this by default (`np.load(max_header_size=10000)`).
const MAX_HEADER_BYTES: u64 = 10_000;

/// Reads an `.npy` preamble (magic, version, header length) and checks the declared header length
/// before anything is allocated from it.
fn read_preamble(r: &mut impl Read) -> std::io::Result<Vec<u8>> {
    let bad = |what: String| std::io::Error::new(std::io::ErrorKind::InvalidData, what);
    let mut pre = vec![0u8; 10];
    r.read_exact(&mut pre)?;
    if &pre[..6] != b"\x93NUMPY" {
        return Err(bad("not an .npy file (no magic string)".into()));
    }
    let len = match pre[6] {
        1 => u64::from(u16::from_le_bytes([pre[8], pre[9]])),
        2 | 3 => {
            let mut more = [0u8; 2];
            r.read_exact(&mut more)?;
            pre.extend_from_slice(&more);
            u64::from(u32::from_le_bytes([pre[8], pre[9], more[0], more[1]]))
        }
        v => return Err(bad(format!("unsupported .npy format version {v}"))),
    };
    if len > MAX_HEADER_BYTES {
        return Err(bad(format!("a header of {len} bytes (numpy reads at most {MAX_HEADER_BYTES})")));
    }
    Ok(pre)
}

impl NpzReader {
    pub fn open(path: &Path) -> Result<Self> {
        let file = defender_io::open_input(path).map_err(|e| DefenderError::io(path, e))?;
        let file_len = file.metadata().map_err(|e| DefenderError::io(path, e))?.len();
        let zip = zip::ZipArchive::new(BufReader::new(file)).map_err(|e| DefenderError::Format {
            path: path.to_owned(),
            what: format!("not a .npz (zip) archive: {e}"),
        })?;
        Ok(Self { path: path.to_owned(), file_len, zip })
    }

    /// The header of `name` (only its first bytes are inflated), or `None` if the archive has no
    /// such array.
    ///
    /// # Errors
    /// An unreadable entry or header, a dtype this format cannot hold, or a declared shape whose
    /// data does not fill the entry exactly (a truncated, padded or lying file).
    pub fn header(&mut self, name: &'static str) -> Result<Option<Header>> {
        Ok(self.entry(name)?.map(|(_, header, _)| header))
    }

    fn entry(&mut self, name: &'static str) -> Result<Option<(NpyHeader, Header, Entry<'_>)>> {
        let path = self.path.clone();
        let file_len = self.file_len;
        let format = |what: String| DefenderError::Format {
            path: path.clone(),
            what: format!("array '{name}': {what}"),
        };
        let entry = match self.zip.by_name(&format!("{name}.npy")) {
            Ok(entry) => entry,
            Err(zip::result::ZipError::FileNotFound) => return Ok(None),
            Err(e) => return Err(format(format!("unreadable zip entry: {e}"))),
        };
        let (size, packed) = (entry.size(), entry.compressed_size());
        if packed > file_len {
            return Err(format(format!(
                "the archive claims {packed} compressed bytes in a file of {file_len} bytes (the file is truncated or corrupt)"
            )));
        }
        let limit = match entry.compression() {
            zip::CompressionMethod::Stored => packed,
            _ => packed.saturating_mul(MAX_DEFLATE_RATIO).saturating_add(1024),
        };
        if size > limit {
            return Err(format(format!(
                "the archive claims {size} bytes from {packed} compressed bytes, more than compression can produce (a zip bomb or a corrupt file)"
            )));
        }
        let mut counting = Counting { inner: entry, count: 0 };
        // The preamble first: the header length it declares is checked before anything is
        // allocated from it (as numpy's `max_header_size`).
        let preamble = read_preamble(&mut counting).map_err(|e| format(format!("bad .npy: {e}")))?;
        let npy = NpyHeader::from_reader(std::io::Cursor::new(preamble).chain(&mut counting))
            .map_err(|e| format(format!("bad .npy: {e}")))?;
        let Counting { inner: entry, count: header_len } = counting;
        let dtype = npy.dtype();
        let descr = dtype.descr();
        let ts = match &dtype {
            DType::Plain(ts) => ts.clone(),
            _ => {
                return Err(bad(
                    &path,
                    name,
                    "a plain numeric or bool dtype (no records, no objects)",
                    descr,
                ));
            }
        };
        let item = ts.size_field();
        let (type_char, size_ok) = (ts.type_char(), matches!(item, 1 | 2 | 4 | 8));
        if !size_ok || !matches!(type_char, TypeChar::Float | TypeChar::Int | TypeChar::Uint | TypeChar::Bool)
        {
            return Err(bad(&path, name, "float32, float64, an integer type, bool or uint8", descr));
        }
        if npy.order() == Order::Fortran && npy.shape().len() > 2 {
            return Err(bad(
                &path,
                name,
                "a C-ordered array (or Fortran-ordered with at most 2 dimensions)",
                "Fortran order",
            ));
        }
        let declared = format!("shape {:?} of {descr}", npy.shape());
        let len = npy.shape().iter().try_fold(1u64, |acc, &d| acc.checked_mul(d));
        let bytes = len.and_then(|n| n.checked_mul(item));
        let (Some(len), Some(bytes)) = (len, bytes) else {
            return Err(bad(&path, name, "a shape whose size fits in memory", declared));
        };
        let data = size.saturating_sub(header_len);
        if bytes != data || header_len > size {
            return Err(bad(
                &path,
                name,
                &format!("as many data bytes as its header declares ({declared} = {bytes} bytes)"),
                format!("{data} bytes in the archive (the file is truncated, padded or corrupt)"),
            ));
        }
        let (Ok(len), Ok(shape)) = (
            usize::try_from(len),
            npy.shape().iter().map(|&d| usize::try_from(d)).collect::<std::result::Result<Vec<_>, _>>(),
        ) else {
            return Err(bad(&path, name, "a shape whose size fits in memory", declared));
        };
        let header = Header { shape, len, descr, type_char, size: item };
        Ok(Some((npy, header, entry)))
    }

    /// Reads `name`, or `None` if the archive has no such array. The header is checked against
    /// the entry's size first ([`NpzReader::header`]); then the data is read and the entry's
    /// checksum verified.
    pub fn read(&mut self, name: &'static str) -> Result<Option<Array>> {
        let path = self.path.clone();
        let Some((npy, header, mut entry)) = self.entry(name)? else {
            return Ok(None);
        };
        let order = npy.order();
        let values = read_values(NpyFile::with_header(npy, &mut entry), &header, &path, name)?;
        // One more read: the entry must end here, and reaching its end verifies its CRC-32.
        let mut probe = [0u8; 1];
        match entry.read(&mut probe) {
            Ok(0) => {}
            Ok(_) => {
                return Err(data_error(&path, name, std::io::Error::other("data beyond its declared shape")));
            }
            Err(e) => return Err(data_error(&path, name, e)),
        }
        let mut array = Array { shape: header.shape, values, descr: header.descr };
        if order == Order::Fortran && array.shape.len() == 2 {
            array.values = transpose(array.values, array.shape[0], array.shape[1]);
        }
        Ok(Some(array))
    }
}

/// An array of an `.npz` file that is not what SPEC section 8 says.
pub(crate) fn bad(path: &Path, array: &'static str, expected: &str, got: impl Into<String>) -> DefenderError {
    DefenderError::InvalidArray {
        path: path.to_owned(),
        array,
        expected: expected.to_owned(),
        got: got.into(),
    }
}

fn data_error(path: &Path, name: &str, e: std::io::Error) -> DefenderError {
    let what = match e.kind() {
        std::io::ErrorKind::UnexpectedEof => {
            "the data ends before its declared shape is filled (the file is truncated or corrupt)".to_owned()
        }
        _ if e.to_string().contains("checksum") => "checksum mismatch (the file is corrupt)".to_owned(),
        _ => e.to_string(),
    };
    DefenderError::Format { path: path.to_owned(), what: format!("array '{name}': {what}") }
}

fn collect<T: npyz::Deserialize, U>(
    npy: NpyFile<impl Read>,
    len: usize,
    map: impl Fn(T) -> U,
) -> std::io::Result<Vec<U>> {
    let mut out = Vec::with_capacity(len);
    for v in npy.data::<T>().map_err(std::io::Error::other)? {
        out.push(map(v?));
    }
    Ok(out)
}

fn read_values(npy: NpyFile<impl Read>, header: &Header, path: &Path, name: &'static str) -> Result<Values> {
    let n = header.len;
    let err = |e| data_error(path, name, e);
    Ok(match (header.type_char, header.size) {
        (TypeChar::Float, 4) => Values::F32(collect(npy, n, |v: f32| v).map_err(err)?),
        (TypeChar::Float, 8) => Values::F64(collect(npy, n, |v: f64| v).map_err(err)?),
        (TypeChar::Bool, 1) => Values::Bool(collect(npy, n, |v: bool| v).map_err(err)?),
        (TypeChar::Uint, 1) => Values::U8(collect(npy, n, |v: u8| v).map_err(err)?),
        (TypeChar::Int, 1) => Values::Int(collect(npy, n, |v: i8| i64::from(v)).map_err(err)?),
        (TypeChar::Int, 2) => Values::Int(collect(npy, n, |v: i16| i64::from(v)).map_err(err)?),
        (TypeChar::Int, 4) => Values::Int(collect(npy, n, |v: i32| i64::from(v)).map_err(err)?),
        (TypeChar::Int, 8) => Values::Int(collect(npy, n, |v: i64| v).map_err(err)?),
        (TypeChar::Uint, 2) => Values::Int(collect(npy, n, |v: u16| i64::from(v)).map_err(err)?),
        (TypeChar::Uint, 4) => Values::Int(collect(npy, n, |v: u32| i64::from(v)).map_err(err)?),
        (TypeChar::Uint, 8) => {
            Values::Int(collect(npy, n, |v: u64| i64::try_from(v).unwrap_or(i64::MAX)).map_err(err)?)
        }
        _ => return Err(bad(path, name, "float32, float64, an integer type, bool or uint8", &header.descr)),
    })
}

/// Reads array `name` of the `.npz` archive at `path`: its shape and its values in C order, or
/// `None` if the archive has no such array. The header is checked against the archive before any
/// data is read, and the entry's checksum verified.
///
/// # Errors
/// An unreadable file, archive or array, naming the file and the array.
pub fn read_array(path: &Path, name: &'static str) -> Result<Option<(Vec<usize>, Values)>> {
    Ok(NpzReader::open(path)?.read(name)?.map(|a| (a.shape, a.values)))
}

/// The values of one array to write, borrowed.
#[derive(Debug, Clone, Copy)]
pub enum Data<'a> {
    /// float32 (`<f4`).
    F32(&'a [f32]),
    /// float64 (`<f8`).
    F64(&'a [f64]),
    /// int64 (`<i8`).
    I64(&'a [i64]),
    /// bool (`|b1`).
    Bool(&'a [bool]),
    /// uint8 (`|u1`).
    U8(&'a [u8]),
}

impl Data<'_> {
    fn len(&self) -> usize {
        match self {
            Data::F32(v) => v.len(),
            Data::F64(v) => v.len(),
            Data::I64(v) => v.len(),
            Data::Bool(v) => v.len(),
            Data::U8(v) => v.len(),
        }
    }
}

/// Writes `arrays` (name, shape, values in C order) as the `.npz` archive `path`, which `np.load`
/// reads; atomically ([`crate::write_atomic`]: a temporary file, fsync, rename, fsync of the
/// directory), so that `path` is the old file or the new one, never a torn one.
///
/// # Errors
/// A shape that does not hold its values (naming the array), or an I/O error naming the path.
pub fn write_arrays(path: &Path, arrays: &[(&str, &[usize], Data<'_>)]) -> Result<()> {
    for (name, shape, data) in arrays {
        if shape.iter().try_fold(1usize, |a, &d| a.checked_mul(d)) != Some(data.len()) {
            return Err(DefenderError::Format {
                path: path.to_owned(),
                what: format!("array '{name}': shape {shape:?} does not hold its {} values", data.len()),
            });
        }
    }
    crate::atomic::write_atomic(path, |w| {
        let mut npz = NpzWriter::new(w, path);
        for &(name, shape, data) in arrays {
            match data {
                Data::F32(v) => npz.write(name, shape, v)?,
                Data::F64(v) => npz.write(name, shape, v)?,
                Data::I64(v) => npz.write(name, shape, v)?,
                Data::Bool(v) => npz.write(name, shape, v)?,
                Data::U8(v) => npz.write(name, shape, v)?,
            }
        }
        npz.finish()?;
        Ok(())
    })
}

/// Fortran-ordered `rows x cols` values to C order.
fn transpose(values: Values, rows: usize, cols: usize) -> Values {
    fn t<T: Copy>(v: Vec<T>, rows: usize, cols: usize) -> Vec<T> {
        let mut out = Vec::with_capacity(v.len());
        for r in 0..rows {
            for c in 0..cols {
                out.push(v[c * rows + r]);
            }
        }
        out
    }
    match values {
        Values::F32(v) => Values::F32(t(v, rows, cols)),
        Values::F64(v) => Values::F64(t(v, rows, cols)),
        Values::Int(v) => Values::Int(t(v, rows, cols)),
        Values::Bool(v) => Values::Bool(t(v, rows, cols)),
        Values::U8(v) => Values::U8(t(v, rows, cols)),
    }
}

/// Writes arrays into a `.npz` archive that `np.load` reads (stored, not compressed, like
/// `np.savez`; zip64 for large entries).
pub(crate) struct NpzWriter<W: Write + Seek> {
    path: PathBuf,
    zip: zip::ZipWriter<W>,
}

impl<W: Write + Seek> NpzWriter<W> {
    pub fn new(writer: W, path: &Path) -> Self {
        Self { path: path.to_owned(), zip: zip::ZipWriter::new(writer) }
    }

    fn err(&self, name: &str, e: impl std::fmt::Display) -> DefenderError {
        DefenderError::Format { path: self.path.clone(), what: format!("writing array '{name}': {e}") }
    }

    /// Writes one array of any type npyz serialises with its default dtype (`<f4`, `<i8`, `|b1`, `|u1`).
    pub fn write<T: npyz::AutoSerialize + Copy>(
        &mut self,
        name: &str,
        shape: &[usize],
        values: &[T],
    ) -> Result<()> {
        let bytes = values.len() as u64 * std::mem::size_of::<T>() as u64;
        let options = zip::write::SimpleFileOptions::default()
            .compression_method(zip::CompressionMethod::Stored)
            .large_file(bytes >= u64::from(u32::MAX) / 2);
        self.zip.start_file(format!("{name}.npy"), options).map_err(|e| self.err(name, e))?;
        let shape: Vec<u64> = shape.iter().map(|&d| d as u64).collect();
        let mut writer = npyz::WriteOptions::new()
            .default_dtype()
            .shape(&shape)
            .writer(&mut self.zip)
            .begin_nd()
            .map_err(|e| DefenderError::Format {
                path: self.path.clone(),
                what: format!("writing array '{name}': {e}"),
            })?;
        writer.extend(values.iter().copied()).map_err(|e| DefenderError::io(&self.path, e))?;
        writer.finish().map_err(|e| DefenderError::io(&self.path, e))
    }

    /// Finishes the archive and returns the inner writer.
    pub fn finish(self) -> Result<W> {
        let path = self.path.clone();
        self.zip
            .finish()
            .map_err(|e| DefenderError::Format { path, what: format!("finishing the archive: {e}") })
    }
}
