//! tprf-core's errors as Python exceptions, each carrying the core's message with its
//! causes ("a: b: c", as the CLI prints them).

use pyo3::PyErr;
use pyo3::exceptions::{PyFileNotFoundError, PyOSError, PyValueError};

/// The message of `e` and its causes, a cause its parent's message already ends with
/// left out.
pub fn message_chain(e: &(dyn std::error::Error + 'static)) -> String {
    let mut text = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        let more = c.to_string();
        if !text.ends_with(&more) {
            text.push_str(": ");
            text.push_str(&more);
        }
        cause = c.source();
    }
    text
}

/// `e` as a Python exception: `FileNotFoundError` or `OSError` when an I/O error is at its
/// root, else `ValueError` (bad input: a field out of range, a broken file).
pub fn to_py(e: &(dyn std::error::Error + 'static)) -> PyErr {
    let text = message_chain(e);
    let mut cause: Option<&(dyn std::error::Error + 'static)> = Some(e);
    while let Some(c) = cause {
        if let Some(io) = c.downcast_ref::<std::io::Error>() {
            return if io.kind() == std::io::ErrorKind::NotFound {
                PyFileNotFoundError::new_err(text)
            } else {
                PyOSError::new_err(text)
            };
        }
        cause = c.source();
    }
    PyValueError::new_err(text)
}

/// A `Result` whose error is one of the core's, into one Python takes.
pub trait IntoPy<T> {
    fn py_err(self) -> pyo3::PyResult<T>;
}

impl<T, E: std::error::Error + 'static> IntoPy<T> for Result<T, E> {
    fn py_err(self) -> pyo3::PyResult<T> {
        self.map_err(|e| to_py(&e))
    }
}
