//! Image files as Mitsuba's `bitmap` texture reads them: decoded (PNG, JPEG, OpenEXR)
//! within the memory budget, into tprf's sRGB-encoded RGBA8 textures or, for a
//! projector's irradiance, linear RGB. Shared by the BSDFs' textures, the projector and
//! the parallel prefetch.

use crate::budget;
use crate::scene::{ImageWrap, IrradianceImage, SceneError, Texture};
use std::path::Path;

/// 8-bit sRGB to linear [0, 1] (the sRGB transfer function).
fn from_srgb8(v: u8) -> f32 {
    let c = v as f32 / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Linear [0, 1] to 8-bit sRGB.
pub(super) fn to_srgb8(v: f32) -> u8 {
    let v = v.clamp(0.0, 1.0);
    let s = if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0 + 0.5) as u8
}

/// Read and decode an image file (PNG, JPEG, OpenEXR), its decoded size budgeted before
/// any pixel is read.
fn decode_image(path: &Path, what: &str) -> Result<image::DynamicImage, SceneError> {
    use image::{DynamicImage, ImageDecoder};
    let bytes = budget::read_file(path, what).map_err(|e| match e {
        budget::BudgetError::Io { path, source } => SceneError::Io {
            path: format!("{} ({what})", path.display()),
            source,
        },
        e => SceneError::Budget(e),
    })?;
    let bad = |m: String| SceneError::Invalid(format!("{} ({what}): {m}", path.display()));
    let mut reader = image::ImageReader::new(std::io::Cursor::new(&bytes))
        .with_guessed_format()
        .map_err(|e| bad(e.to_string()))?;
    reader.no_limits();
    let decoder = reader.into_decoder().map_err(|e| {
        bad(format!(
            "cannot read the image (tprf reads PNG, JPEG and OpenEXR textures): {e}"
        ))
    })?;
    let (w, h) = decoder.dimensions();
    if w == 0 || h == 0 {
        return Err(bad(format!("the image is {w} x {h} pixels")));
    }
    let pixels = u64::from(w) * u64::from(h);
    budget::check(
        decoder
            .total_bytes()
            .saturating_add(pixels.saturating_mul(16)),
        what,
        format_args!("decoding {w} x {h} pixels"),
    )?;
    DynamicImage::from_decoder(decoder).map_err(|e| bad(format!("cannot decode: {e}")))
}

/// Whether `image` holds 8-bit channels (sRGB-encoded as stored, unless read raw).
fn is_eight_bit(image: &image::DynamicImage) -> bool {
    use image::DynamicImage;
    matches!(
        image,
        DynamicImage::ImageLuma8(_)
            | DynamicImage::ImageLumaA8(_)
            | DynamicImage::ImageRgb8(_)
            | DynamicImage::ImageRgba8(_)
    )
}

/// Decode an image file into linear RGB values, as Mitsuba's `bitmap` texture reads
/// them: 8-bit files decoded from sRGB (`raw`: their values `v / 255` as they are),
/// 16-bit and floating-point ones (OpenEXR) as stored, unclamped.
pub(super) fn decode_linear_rgb(
    path: &Path,
    what: &str,
    raw: bool,
) -> Result<IrradianceImage, SceneError> {
    let image = decode_image(path, what)?;
    let (width, height) = (image.width(), image.height());
    let eight_bit = is_eight_bit(&image);
    let rgb = if eight_bit && !raw {
        image
            .into_rgba8()
            .pixels()
            .map(|p| [0, 1, 2].map(|i| from_srgb8(p.0[i])))
            .collect()
    } else {
        image
            .into_rgba32f()
            .pixels()
            .map(|p| [p.0[0], p.0[1], p.0[2]])
            .collect()
    };
    Ok(IrradianceImage {
        width,
        height,
        rgb,
        wrap: ImageWrap::Repeat,
    })
}

/// Decode an image file into an sRGB-encoded RGBA8 [`Texture`]: 8-bit files as stored
/// (`raw`: their values are linear, encoded to sRGB), 16-bit and floating-point ones
/// (OpenEXR) from linear values. The decoded size is budgeted before any pixel is read.
pub(super) fn decode_bitmap(path: &Path, what: &str, raw: bool) -> Result<Texture, SceneError> {
    let image = decode_image(path, what)?;
    let (w, h) = (image.width(), image.height());
    let eight_bit = is_eight_bit(&image);
    let rgba8: Vec<[u8; 4]> = if eight_bit && !raw {
        image.into_rgba8().pixels().map(|p| p.0).collect()
    } else {
        // Linear values: 8-bit raw data as v / 255, 16-bit and float data as they are.
        image
            .into_rgba32f()
            .pixels()
            .map(|p| {
                let [r, g, b, a] = p.0;
                [
                    to_srgb8(r),
                    to_srgb8(g),
                    to_srgb8(b),
                    (a.clamp(0.0, 1.0) * 255.0 + 0.5) as u8,
                ]
            })
            .collect()
    };
    Ok(Texture {
        width: w,
        height: h,
        rgba8,
    })
}
