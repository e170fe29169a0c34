//! numpy <-> Rust conversions with error messages that name the argument and its expected shape.

use numpy::{PyArray1, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyAnyMethods;

use crate::DefenderError;

/// `numpy.asarray(obj, dtype=dtype)`, named `what` in errors.
fn asarray<'py>(obj: &Bound<'py, PyAny>, dtype: &str, what: &str) -> PyResult<Bound<'py, PyAny>> {
    let py = obj.py();
    let np = py.import("numpy")?;
    np.call_method1("asarray", (obj, np.getattr(dtype)?))
        .map_err(|e| DefenderError::new_err(format!("{what}: cannot be read as a {dtype} numpy array ({e})")))
}

fn shape_of(a: &Bound<'_, PyAny>) -> String {
    a.getattr("shape").and_then(|s| s.str().map(|s| s.to_string())).unwrap_or_else(|_| "?".into())
}

/// Copies a 1-D array of `len` values (any real dtype, or a sequence) into `out` as f64.
pub(crate) fn read_vec_f64(
    obj: &Bound<'_, PyAny>,
    what: &str,
    len: usize,
    out: &mut Vec<f64>,
) -> PyResult<()> {
    out.clear();
    // Fast paths: contiguous float64 and float32 arrays (what Gymnasium environments and agents
    // pass every step). `as_slice` skips rust-numpy's borrow tracking (a shared-capsule lookup per
    // call, most of the cost of reading a 3-element action): sound here because the GIL is held,
    // no Rust reference into the array exists, and the values are copied before any Python code
    // can run and change them.
    if let Ok(a) = obj.cast::<PyArray1<f64>>()
        && a.len() == len
        // SAFETY: see above.
        && let Ok(s) = unsafe { a.as_slice() }
    {
        out.extend_from_slice(s);
        return Ok(());
    }
    if let Ok(a) = obj.cast::<PyArray1<f32>>()
        && a.len() == len
        // SAFETY: see above.
        && let Ok(s) = unsafe { a.as_slice() }
    {
        out.extend(s.iter().map(|&v| f64::from(v)));
        return Ok(());
    }
    let a = asarray(obj, "float64", what)?;
    let a = a.cast::<numpy::PyArrayDyn<f64>>().map_err(PyErr::from)?;
    if a.ndim() != 1 || a.len() != len {
        return Err(DefenderError::new_err(format!(
            "{what}: expected a 1-D array of {len} values, got shape {}",
            shape_of(a.as_any())
        )));
    }
    let r = a.try_readonly()?;
    out.extend(r.as_array().iter().copied());
    Ok(())
}

/// A 2-D float32 matrix (row-major) read from any array-like; `cols` is checked when given.
/// A 1-D array is taken as one column when `one_d_is_column` (univariate sequences).
pub(crate) fn read_mat_f32(
    obj: &Bound<'_, PyAny>,
    what: &str,
    cols: Option<usize>,
    one_d_is_column: bool,
) -> PyResult<(Vec<f32>, usize, usize)> {
    let a = asarray(obj, "float32", what)?;
    let a = a.cast::<numpy::PyArrayDyn<f32>>().map_err(PyErr::from)?;
    let shape = a.shape().to_vec();
    let (rows, c) = match (shape.as_slice(), one_d_is_column) {
        ([r, c], _) => (*r, *c),
        ([r], true) => (*r, 1),
        _ => {
            let expected = match cols {
                Some(c) => format!("a 2-D array of shape (rows, {c})"),
                None => "a 2-D array (rows, dim)".into(),
            };
            return Err(DefenderError::new_err(format!("{what}: expected {expected}, got shape {shape:?}")));
        }
    };
    if let Some(expected) = cols
        && c != expected
    {
        return Err(DefenderError::new_err(format!(
            "{what}: expected {expected} columns, got shape {shape:?}"
        )));
    }
    let r = a.try_readonly()?;
    let data: Vec<f32> = r.as_array().iter().copied().collect();
    if let Some(i) = data.iter().position(|v| !v.is_finite()) {
        let cols = c.max(1);
        return Err(DefenderError::new_err(format!(
            "{what}: row {}, column {} is not finite ({})",
            i / cols,
            i % cols,
            data[i]
        )));
    }
    Ok((data, rows, c))
}

/// A 1-D array of `dtype` (`"float32"`, `"int64"`, `"bool"`) read from any array-like.
pub(crate) fn read_1d<'py, T: numpy::Element + Copy>(
    obj: &Bound<'py, PyAny>,
    what: &str,
    dtype: &str,
) -> PyResult<Vec<T>> {
    let a = asarray(obj, dtype, what)?;
    let a = a.cast::<numpy::PyArrayDyn<T>>().map_err(PyErr::from)?;
    if a.ndim() != 1 {
        return Err(DefenderError::new_err(format!(
            "{what}: expected a 1-D array, got shape {}",
            shape_of(a.as_any())
        )));
    }
    let r = a.try_readonly()?;
    Ok(r.as_array().iter().copied().collect())
}

/// A new 2-D numpy array from row-major data.
pub(crate) fn mat<'py, T: numpy::Element + Copy>(
    py: Python<'py>,
    data: Vec<T>,
    rows: usize,
    cols: usize,
) -> PyResult<Bound<'py, PyAny>> {
    let a = PyArray1::from_vec(py, data);
    Ok(a.reshape([rows, cols])?.into_any())
}
