//! Reading and writing the arrays of a `.npz` archive (numpy's `np.savez` format: a zip of `.npy`
//! files), with the dtype checks the episode-set format needs.

use std::fs::File;
use std::io::{BufReader, Read, Seek, Write};
use std::path::{Path, PathBuf};

use npyz::{DType, NpyFile, Order, TypeChar, WriterBuilder};

use crate::error::{DefenderError, Result};

/// The values of one array, in the dtype the file holds them.
#[derive(Debug, Clone)]
pub(crate) enum Values {
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

/// An open `.npz` archive.
pub(crate) struct NpzReader {
    path: PathBuf,
    zip: zip::ZipArchive<BufReader<File>>,
}

impl NpzReader {
    pub fn open(path: &Path) -> Result<Self> {
        let file = File::open(path).map_err(|e| DefenderError::io(path, e))?;
        let zip = zip::ZipArchive::new(BufReader::new(file)).map_err(|e| DefenderError::Format {
            path: path.to_owned(),
            what: format!("not a .npz (zip) archive: {e}"),
        })?;
        Ok(Self { path: path.to_owned(), zip })
    }

    /// Reads `name`, or `None` if the archive has no such array.
    pub fn read(&mut self, name: &'static str) -> Result<Option<Array>> {
        let path = self.path.clone();
        let entry = match self.zip.by_name(&format!("{name}.npy")) {
            Ok(entry) => entry,
            Err(zip::result::ZipError::FileNotFound) => return Ok(None),
            Err(e) => {
                return Err(DefenderError::Format {
                    path,
                    what: format!("array '{name}': unreadable zip entry: {e}"),
                });
            }
        };
        read_npy(entry, &path, name).map(Some)
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

fn read_npy(reader: impl Read, path: &Path, name: &'static str) -> Result<Array> {
    let npy = NpyFile::new(reader).map_err(|e| DefenderError::Format {
        path: path.to_owned(),
        what: format!("array '{name}': bad .npy: {e}"),
    })?;
    let shape: Vec<usize> = npy.shape().iter().map(|&d| d as usize).collect();
    let order = npy.order();
    let dtype = npy.dtype();
    let descr = dtype.descr();
    let ts = match &dtype {
        DType::Plain(ts) => ts.clone(),
        _ => return Err(bad(path, name, "a plain numeric or bool dtype (no records, no objects)", descr)),
    };
    let size = ts.size_field();
    let data_err = |e: std::io::Error| DefenderError::Format {
        path: path.to_owned(),
        what: format!("array '{name}': {e}"),
    };
    let values = match (ts.type_char(), size) {
        (TypeChar::Float, 4) => Values::F32(npy.into_vec::<f32>().map_err(data_err)?),
        (TypeChar::Float, 8) => Values::F64(npy.into_vec::<f64>().map_err(data_err)?),
        (TypeChar::Bool, 1) => Values::Bool(npy.into_vec::<bool>().map_err(data_err)?),
        (TypeChar::Uint, 1) => Values::U8(npy.into_vec::<u8>().map_err(data_err)?),
        (TypeChar::Int, 1) => {
            Values::Int(npy.into_vec::<i8>().map_err(data_err)?.into_iter().map(i64::from).collect())
        }
        (TypeChar::Int, 2) => {
            Values::Int(npy.into_vec::<i16>().map_err(data_err)?.into_iter().map(i64::from).collect())
        }
        (TypeChar::Int, 4) => {
            Values::Int(npy.into_vec::<i32>().map_err(data_err)?.into_iter().map(i64::from).collect())
        }
        (TypeChar::Int, 8) => Values::Int(npy.into_vec::<i64>().map_err(data_err)?),
        (TypeChar::Uint, 2) => {
            Values::Int(npy.into_vec::<u16>().map_err(data_err)?.into_iter().map(i64::from).collect())
        }
        (TypeChar::Uint, 4) => {
            Values::Int(npy.into_vec::<u32>().map_err(data_err)?.into_iter().map(i64::from).collect())
        }
        (TypeChar::Uint, 8) => Values::Int(
            npy.into_vec::<u64>()
                .map_err(data_err)?
                .into_iter()
                .map(|v| i64::try_from(v).unwrap_or(i64::MAX))
                .collect(),
        ),
        _ => return Err(bad(path, name, "float32, float64, an integer type, bool or uint8", descr)),
    };
    let mut array = Array { shape, values, descr };
    if order == Order::Fortran && array.shape.len() == 2 {
        array.values = transpose(array.values, array.shape[0], array.shape[1]);
    } else if order == Order::Fortran && array.shape.len() > 2 {
        return Err(bad(
            path,
            name,
            "a C-ordered array (or Fortran-ordered with at most 2 dimensions)",
            "Fortran order",
        ));
    }
    Ok(array)
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
