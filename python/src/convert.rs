//! Python values in and numpy arrays out, with errors that name what was wrong.

use numpy::ndarray::{Array2, Array3};
use numpy::{PyArray1, PyArray2, PyArray3, PyArrayDescrMethods, PyArrayMethods, PyUntypedArray, PyUntypedArrayMethods};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;

/// Integer action indices from a list/tuple of ints or an integer numpy array of shape
/// `shape` (`[n]` for one environment, `[envs, agents]` for a vector environment).
pub fn indices(obj: &Bound<'_, PyAny>, what: &str, shape: &[usize]) -> PyResult<Vec<i64>> {
    let needed: usize = shape.iter().product();
    // The fast path: a flat int64 array, read in place (no Python calls).
    if let Ok(arr) = obj.cast::<PyArray1<i64>>()
        && shape.len() == 1
        && let Ok(v) = arr.to_vec()
    {
        return Ok(v);
    }
    if let Ok(arr) = obj.cast::<PyUntypedArray>() {
        let kind = arr.dtype().kind();
        if kind != b'i' && kind != b'u' {
            let dtype = arr.dtype().str().map(|s| s.to_string()).unwrap_or_else(|_| "?".into());
            return Err(PyTypeError::new_err(format!("{what}: an integer array is needed, got dtype {dtype}")));
        }
        // A single environment also takes any flat array; several need the exact shape.
        let ok_shape = arr.shape() == shape || (shape.len() == 1 && arr.ndim() == 1);
        if !ok_shape {
            return Err(PyValueError::new_err(format!("{what}: shape {:?} given, {:?} needed", arr.shape(), shape)));
        }
        let flat = obj.call_method1("astype", ("int64",))?.call_method0("ravel")?;
        let flat = flat.cast::<PyArray1<i64>>().map_err(|e| PyTypeError::new_err(format!("{what}: {e}")))?;
        return flat.to_vec().map_err(|e| PyValueError::new_err(format!("{what}: {e}")));
    }
    if obj.is_instance_of::<pyo3::types::PyString>() {
        return Err(PyTypeError::new_err(format!("{what}: a sequence of integers is needed, got a string")));
    }
    let v: Vec<Bound<'_, PyAny>> = obj.extract().map_err(|_| {
        PyTypeError::new_err(format!("{what}: a sequence of integers or an integer numpy array is needed, got {}", type_name(obj)))
    })?;
    if shape.len() > 1 {
        // Nested sequences for a vector environment: go through numpy for the shape check.
        let np = obj.py().import("numpy")?;
        let arr = np.call_method1("asarray", (obj,))?;
        return indices(&arr, what, shape);
    }
    let mut out = Vec::with_capacity(needed.max(v.len()));
    for (i, x) in v.iter().enumerate() {
        if x.is_instance_of::<pyo3::types::PyFloat>() {
            return Err(PyTypeError::new_err(format!("{what}[{i}]: an integer action index is needed, got the float {x}")));
        }
        out.push(
            x.extract::<i64>()
                .map_err(|_| PyTypeError::new_err(format!("{what}[{i}]: an integer action index is needed, got {}", type_name(x))))?,
        );
    }
    Ok(out)
}

fn type_name(obj: &Bound<'_, PyAny>) -> String {
    obj.get_type().name().map(|n| n.to_string()).unwrap_or_else(|_| "?".into())
}

/// An RGB image as an `H x W x 3` uint8 array.
pub fn image<'py>(py: Python<'py>, img: avacraft_render::RgbImage) -> PyResult<Bound<'py, PyAny>> {
    let (w, h) = (img.width() as usize, img.height() as usize);
    let a = Array3::from_shape_vec((h, w, 3), img.into_raw()).map_err(|e| PyValueError::new_err(e.to_string()))?;
    Ok(PyArray3::from_owned_array(py, a).into_any())
}

/// A flat vector as a `rows x cols` array.
pub fn matrix<'py, T: numpy::Element>(py: Python<'py>, v: Vec<T>, rows: usize, cols: usize) -> PyResult<Bound<'py, PyAny>> {
    // Built as an ndarray and handed over: no reshape call back into Python.
    let a = Array2::from_shape_vec((rows, cols), v).map_err(|e| PyValueError::new_err(e.to_string()))?;
    Ok(PyArray2::from_owned_array(py, a).into_any())
}

/// A value serialised to JSON and parsed by Python's `json` into dicts and lists: the
/// engine's serde shapes are the documented Python shapes.
pub fn to_py<'py, T: serde::Serialize>(py: Python<'py>, v: &T) -> PyResult<Bound<'py, PyAny>> {
    let s = serde_json::to_string(v).map_err(|e| PyValueError::new_err(e.to_string()))?;
    py.import("json")?.call_method1("loads", (s,))
}
