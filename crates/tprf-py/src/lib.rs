//! The `tprf` Python package's native module (`tprf._tprf`): tprf-core's renders, cubes,
//! sensors and NLOS captures and reconstructions as Python objects and numpy arrays. The Python layer (`python/tprf/`)
//! adds the progress bar, unit strings and the Dask driver; everything that computes is
//! here, in the core's own functions, with the GIL released.

mod cube;
mod differentiable;
mod errors;
mod nlos;
mod render;
mod sensor;

use pyo3::prelude::*;

#[pymodule]
fn _tprf(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<cube::Cube>()?;
    m.add_function(wrap_pyfunction!(cube::load, m)?)?;
    m.add_class::<render::Renderer>()?;
    m.add_class::<differentiable::Differentiable>()?;
    m.add_function(wrap_pyfunction!(render::render, m)?)?;
    m.add_function(wrap_pyfunction!(render::resolve_request, m)?)?;
    m.add_class::<nlos::NlosCapture>()?;
    m.add_class::<nlos::NlosVolume>()?;
    m.add_function(wrap_pyfunction!(nlos::capture, m)?)?;
    m.add_function(wrap_pyfunction!(nlos::reconstruct, m)?)?;
    m.add_class::<sensor::PySensor>()?;
    m.add_class::<sensor::SensorPart>()?;
    m.add_class::<sensor::Measurement>()?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
