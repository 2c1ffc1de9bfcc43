//! `tprf render`'s ambient image: the scene's ambient light group (a sun, a sky given by
//! `--sky`, lamps tagged ambient) rendered once as steady radiance per pixel, written
//! beside the cube as `ambient.npy` and `ambient.png` (or into `tprf.zarr` as the array
//! `ambient`), and described in `tprf.json`.

use std::path::Path;
use std::time::Instant;

use anyhow::{Result, bail};
use tprf_core::export::ambient::{AMBIENT_UNITS, AmbientMetadata};
use tprf_core::export::{self, CubeFormat, zarr};
use tprf_core::scene::Scene;
use tprf_core::transport::Renderer;
use tprf_core::transport::ambient::{AmbientImage, render_ambient};

/// `--sky L`: a constant sky of radiance `L` W m^-2 sr^-1 in every band, added to the
/// scene's ambient group (replacing a sky the scene gives). Refused when negative or
/// not finite.
pub fn apply_sky(scene: &mut Scene, sky: Option<f64>) -> Result<()> {
    let Some(l) = sky else { return Ok(()) };
    if !(l.is_finite() && l >= 0.0 && l <= f32::MAX as f64) {
        bail!("--sky must be a finite radiance >= 0 in W m^-2 sr^-1 (got {l})");
    }
    scene.ambient.sky_radiance = [l as f32; 3];
    Ok(())
}

/// The ambient image and its metadata when the scene has an ambient group (`None`
/// otherwise), at `spp` samples per pixel.
pub fn render(
    renderer: &Renderer,
    width: usize,
    height: usize,
    spp: u32,
) -> Result<Option<(AmbientImage, AmbientMetadata)>> {
    let group = &renderer.scene().ambient;
    if group.is_empty() {
        return Ok(None);
    }
    let start = Instant::now();
    let image = render_ambient(renderer, width, height, spp);
    if image.non_finite > 0 {
        bail!(
            "the ambient image had {} NaN or infinite contributions: a sun, sky or ambient \
             lamp overflows; nothing was written",
            image.non_finite
        );
    }
    eprintln!(
        "ambient image: {} at {spp} spp in {:.1} s (mean {:.4e} W m^-2 sr^-1{})",
        group.describe().join(", "),
        start.elapsed().as_secs_f64(),
        image.radiance.iter().map(|&v| v as f64).sum::<f64>() / image.radiance.len().max(1) as f64,
        image.error_estimate.map_or(String::new(), |e| format!(
            ", error estimate {:.2} %",
            100.0 * e
        ))
    );
    let meta = AmbientMetadata {
        file: String::new(),
        units: AMBIENT_UNITS.into(),
        lights: group.describe(),
        spp,
        error_estimate: image.error_estimate,
    };
    Ok(Some((image, meta)))
}

/// The file name the metadata records for `format`.
pub fn file_name(format: CubeFormat) -> String {
    match format {
        CubeFormat::Zarr => format!("{}/ambient", zarr::ZARR_NAME),
        _ => export::ambient::AMBIENT_NPY.into(),
    }
}

/// Write the image into the render folder `dir` (after the cube: a Zarr cube's group
/// must exist) and its PNG.
pub fn write(dir: &Path, format: CubeFormat, image: &AmbientImage) -> Result<()> {
    let zarr = format == CubeFormat::Zarr;
    export::ambient::write_ambient(dir, zarr, image.width, image.height, &image.radiance)?;
    Ok(())
}
