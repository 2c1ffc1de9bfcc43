//! Texture images decoded under a memory budget and kept at most [`MAX_TEXTURE_SIDE`]
//! pixels a side.
//!
//! A larger image is reduced while it is decoded, by the smallest whole factor `f` that
//! brings both sides within the limit: each texel is the mean of its `f x f` block of
//! pixels (fewer at the right and bottom edges), colour averaged in linear light for sRGB
//! textures (base colour, emission) so that a block keeps its mean albedo, as stored for
//! linear ones (metallic-roughness), alpha as stored in both.
//!
//! What decoding holds beyond the encoded bytes and the texture kept (`4 B` a texel) is
//! at most [`MAX_WORK_MULTIPLE`] times that texture:
//! - PNG is decoded row by row (the png crate): a reduced image adds one row of sums (16 B
//!   a texel of one row) and the decoder's two rows; an interlaced (Adam7) image, whose
//!   rows come in seven passes over the whole image, adds the sums of every texel (16 B a
//!   texel, 4 times the texture). A 20000 x 20000 PNG becomes a 6667 x 6667 texture
//!   (178 MB) without ever holding its 400 M pixels.
//! - JPEG is decoded whole (zune-jpeg, behind the image crate, has no row-by-row mode):
//!   its pixels (1 or 3 B each), and for a progressive JPEG its coefficients (about twice
//!   that). A JPEG whose whole decode would be more than [`MAX_WORK_MULTIPLE`] times the
//!   texture it leaves is refused, naming the sizes and what to do.
//!
//! The whole need is checked against the memory budget (`crate::budget`) from the
//! header, before any pixel is decoded.

use super::validate::invalid;
use crate::budget;
use crate::scene::{SceneError, Texture};
use std::borrow::Cow;
use std::io::{BufRead, Read, Seek};
use std::sync::OnceLock;

/// The longest side a texture is kept at, pixels: 8192 (256 MiB of RGBA8), the largest
/// texture most GPUs sample and more than a transient render's pixels resolve.
pub const MAX_TEXTURE_SIDE: u32 = 8192;

/// The largest reduction factor: beyond it (a side over 524 288 pixels) an image is
/// refused from its header. Sums of up to 64 x 64 pixels in f32 are exact to 2.5e-4,
/// below half an 8-bit step.
pub const MAX_REDUCTION: u32 = 64;

/// What decoding may hold beyond the encoded bytes and the texture kept, in units of that
/// texture's bytes.
pub const MAX_WORK_MULTIPLE: u64 = 4;

/// How a texture's RGB channels encode their values (alpha is linear in both).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(super) enum Encoding {
    /// sRGB-encoded colour: base colour and emissive textures.
    Srgb,
    /// Linear data: the metallic-roughness texture.
    Linear,
}

/// An encoded image: bytes in memory (a `data:` URI, a buffer view) or an open regular
/// file, read as it is decoded.
pub(super) enum Encoded<'a> {
    Bytes(Cow<'a, [u8]>),
    File { file: std::fs::File, len: u64 },
}

/// A decoded texture and the image it came from.
pub(super) struct Decoded {
    pub texture: Texture,
    /// The image's size, pixels.
    pub source: (u32, u32),
    /// The reduction factor (1: kept whole).
    pub factor: u32,
}

/// Decode PNG or JPEG (`mime` as the file declares it, else guessed from the bytes) to an
/// RGBA8 [`Texture`], values as stored (sRGB decoding happens at lookup), reduced to at
/// most [`MAX_TEXTURE_SIDE`] a side; `what` names the image in messages ("images[0]
/// 'a.png'"), `file` the glTF file.
pub(super) fn decode_texture(
    file: &str,
    what: &str,
    mime: Option<&str>,
    encoded: Encoded<'_>,
    encoding: Encoding,
) -> Result<Decoded, SceneError> {
    use image::ImageFormat;
    let err = |m: String| invalid(file, format!("{what}: {m}"));
    let io = |e: std::io::Error| err(format!("cannot read the image: {e}"));
    let (mut magic, mut source) = ([0u8; 8], encoded);
    let magic_len = match &mut source {
        Encoded::Bytes(bytes) => {
            let n = bytes.len().min(magic.len());
            magic[..n].copy_from_slice(&bytes[..n]);
            n
        }
        Encoded::File { file, .. } => {
            let n = read_up_to(file, &mut magic).map_err(io)?;
            file.rewind().map_err(io)?;
            n
        }
    };
    let format = match mime {
        Some("image/png") => ImageFormat::Png,
        Some("image/jpeg") => ImageFormat::Jpeg,
        _ => match image::guess_format(&magic[..magic_len]) {
            Ok(f @ (ImageFormat::Png | ImageFormat::Jpeg)) => f,
            _ => return Err(err("not a PNG or JPEG image".into())),
        },
    };
    let ctx = Context {
        file,
        what,
        encoding,
    };
    match (format, source) {
        (ImageFormat::Png, Encoded::Bytes(bytes)) => ctx.png(std::io::Cursor::new(&bytes[..])),
        (ImageFormat::Png, Encoded::File { file: f, .. }) => ctx.png(std::io::BufReader::new(f)),
        (_, Encoded::Bytes(bytes)) => ctx.jpeg(&bytes),
        (_, Encoded::File { file: f, len }) => {
            budget::check(
                len,
                &ctx.subject(),
                format_args!("reading {len} bytes of JPEG"),
            )?;
            let mut bytes = Vec::new();
            bytes
                .try_reserve_exact(len as usize)
                .map_err(|_| err(format!("cannot allocate {len} bytes to read it")))?;
            f.take(len).read_to_end(&mut bytes).map_err(io)?;
            ctx.jpeg(&bytes)
        }
    }
}

/// Read into `buf` until it is full or the file ends; the bytes read.
fn read_up_to(file: &mut std::fs::File, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut n = 0;
    while n < buf.len() {
        match file.read(&mut buf[n..]) {
            Ok(0) => break,
            Ok(k) => n += k,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(n)
}

/// The size a `width x height` image is kept at.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Grid {
    width: u32,
    height: u32,
    /// Reduction factor: the smallest that brings both sides within [`MAX_TEXTURE_SIDE`].
    factor: u32,
    out_width: u32,
    out_height: u32,
}

impl Grid {
    fn new(width: u32, height: u32) -> Grid {
        let factor = width
            .div_ceil(MAX_TEXTURE_SIDE)
            .max(height.div_ceil(MAX_TEXTURE_SIDE))
            .max(1);
        Grid {
            width,
            height,
            factor,
            out_width: width.div_ceil(factor),
            out_height: height.div_ceil(factor),
        }
    }

    fn out_texels(&self) -> u64 {
        u64::from(self.out_width) * u64::from(self.out_height)
    }

    /// Bytes of the texture kept: RGBA8.
    fn texture_bytes(&self) -> u64 {
        self.out_texels() * 4
    }

    /// "20000 x 20000 pixels into a 6667 x 6667 texture", or "20 x 10 pixels".
    fn describe(&self) -> String {
        let (w, h) = (self.width, self.height);
        if self.factor == 1 {
            format!("{w} x {h} pixels")
        } else {
            format!(
                "{w} x {h} pixels into a {} x {} texture",
                self.out_width, self.out_height
            )
        }
    }
}

/// Bytes of f32 RGBA sums per texel while a reduced image is decoded.
const SUM_BYTES_PER_TEXEL: u64 = 16;

/// The image being decoded, for messages and the budget.
struct Context<'a> {
    file: &'a str,
    what: &'a str,
    encoding: Encoding,
}

impl Context<'_> {
    fn err(&self, m: String) -> SceneError {
        invalid(self.file, format!("{}: {m}", self.what))
    }

    fn subject(&self) -> String {
        format!("{} of {}", self.what, self.file)
    }

    /// The grid for an image's header size; refuses an empty image and one that would
    /// need more than [`MAX_REDUCTION`].
    fn grid(&self, width: u32, height: u32) -> Result<Grid, SceneError> {
        if width == 0 || height == 0 {
            return Err(self.err(format!("the image is {width} x {height} pixels")));
        }
        let grid = Grid::new(width, height);
        if grid.factor > MAX_REDUCTION {
            let most = u64::from(MAX_TEXTURE_SIDE) * u64::from(MAX_REDUCTION);
            return Err(self.err(format!(
                "the image is {width} x {height} pixels: textures are kept at most \
                 {MAX_TEXTURE_SIDE} pixels a side, and reduced on load from at most {most}; \
                 reduce it first"
            )));
        }
        Ok(grid)
    }

    /// Budget `work_bytes` of decoding plus the texture kept, before any pixel is decoded.
    fn check_budget(&self, grid: &Grid, work_bytes: u64) -> Result<(), SceneError> {
        let need = grid.texture_bytes().saturating_add(work_bytes);
        budget::check(
            need,
            &self.subject(),
            format_args!("decoding {}", grid.describe()),
        )?;
        Ok(())
    }

    /// Decode a PNG row by row (interlaced ones pass by pass) into its reduced texture.
    fn png<R: BufRead + Seek>(&self, reader: R) -> Result<Decoded, SceneError> {
        let mut decoder = png::Decoder::new(reader);
        let header = decoder
            .read_header_info()
            .map_err(|e| self.err(format!("cannot read the image header: {e}")))?;
        let (width, height, interlaced) = (header.width, header.height, header.interlaced);
        let grid = self.grid(width, height)?;
        // Palette and low-bit grey to 8 bits, tRNS to alpha (as the image crate does).
        decoder.set_transformations(png::Transformations::EXPAND);
        let mut reader = decoder
            .read_info()
            .map_err(|e| self.err(format!("cannot read the image header: {e}")))?;
        let (color, depth) = reader.output_color_type();
        let layout = Layout::of_png(color, depth)
            .ok_or_else(|| self.err(format!("unsupported PNG format {color:?} {depth:?}")))?;
        // The decoder's own rows: the current one and the previous, unfiltered.
        let rows = 2 * u64::from(width) * layout.bytes_per_pixel() as u64;
        let sums = match (grid.factor, interlaced) {
            (1, _) => 0,
            (_, false) => u64::from(grid.out_width) * SUM_BYTES_PER_TEXEL,
            (_, true) => grid.out_texels() * SUM_BYTES_PER_TEXEL,
        };
        self.check_budget(&grid, rows + sums)?;
        let mut reducer =
            Reducer::new(grid, layout, self.encoding, interlaced).map_err(|m| self.err(m))?;
        let cannot = |e: png::DecodingError| self.err(format!("cannot decode: {e}"));
        if interlaced {
            for (pass, line) in adam7_rows(width, height) {
                let Some(row) = reader.next_interlaced_row().map_err(cannot)? else {
                    return Err(self.err("the image data ends early".into()));
                };
                let expected = png::Adam7Info::new(pass.number, line, width);
                if !matches!(row.interlace(), png::InterlaceInfo::Adam7(info) if *info == expected)
                {
                    return Err(self.err("its interlaced rows come out of order".into()));
                }
                let y = line * pass.y_step + pass.y_offset;
                reducer.add_samples(y, pass.x_offset, pass.x_step, row.data());
            }
        } else {
            for y in 0..height {
                let Some(row) = reader.next_row().map_err(cannot)? else {
                    return Err(self.err("the image data ends early".into()));
                };
                reducer.add_samples(y, 0, 1, row.data());
            }
        }
        Ok(reducer.finish())
    }

    /// Decode a JPEG whole, then reduce it; refused when that would hold more than
    /// [`MAX_WORK_MULTIPLE`] times the texture kept.
    fn jpeg(&self, bytes: &[u8]) -> Result<Decoded, SceneError> {
        use image::ImageDecoder;
        let decoder = image::codecs::jpeg::JpegDecoder::new(std::io::Cursor::new(bytes))
            .map_err(|e| self.err(format!("cannot read the image header: {e}")))?;
        let (width, height) = decoder.dimensions();
        let grid = self.grid(width, height)?;
        let layout = Layout::of_image(decoder.color_type()).ok_or_else(|| {
            self.err(format!(
                "unsupported JPEG format {:?}",
                decoder.color_type()
            ))
        })?;
        let pixels = decoder.total_bytes();
        // The decoder's copy of the input, its pixels, and a progressive JPEG's
        // coefficients (i16 per sample of each component: at most twice the pixels).
        let progressive = jpeg_is_progressive(bytes);
        let coefficients = if progressive { 2 * pixels } else { 0 };
        let work = (bytes.len() as u64)
            .saturating_add(pixels)
            .saturating_add(coefficients);
        let decode = pixels.saturating_add(coefficients);
        if decode > MAX_WORK_MULTIPLE.saturating_mul(grid.texture_bytes()) {
            let kind = if progressive { "progressive " } else { "" };
            return Err(self.err(format!(
                "a {kind}JPEG of {width} x {height} pixels is decoded whole, {} to keep a \
                 {} x {} texture of {} (textures are kept at most {MAX_TEXTURE_SIDE} pixels a \
                 side), more than {MAX_WORK_MULTIPLE} times it: reduce the image to at most \
                 {MAX_TEXTURE_SIDE} pixels a side, or save it as PNG, which is reduced row by \
                 row as it is read",
                budget::format_bytes(decode),
                grid.out_width,
                grid.out_height,
                budget::format_bytes(grid.texture_bytes()),
            )));
        }
        self.check_budget(&grid, work)?;
        let mut pixels_buf = Vec::new();
        pixels_buf
            .try_reserve_exact(pixels as usize)
            .map_err(|_| self.err(format!("cannot allocate {pixels} bytes to decode it")))?;
        pixels_buf.resize(pixels as usize, 0);
        decoder
            .read_image(&mut pixels_buf)
            .map_err(|e| self.err(format!("cannot decode: {e}")))?;
        let mut reducer =
            Reducer::new(grid, layout, self.encoding, false).map_err(|m| self.err(m))?;
        let stride = width as usize * layout.bytes_per_pixel();
        for (y, row) in pixels_buf.chunks_exact(stride).enumerate() {
            reducer.add_samples(y as u32, 0, 1, row);
        }
        drop(pixels_buf);
        Ok(reducer.finish())
    }
}

/// Whether a JPEG's frame is progressive or of a kind other than baseline and extended
/// sequential (SOF0, SOF1): those may hold coefficients for the whole image. Read from
/// the markers before the first scan; `true` where that cannot be told.
fn jpeg_is_progressive(bytes: &[u8]) -> bool {
    let mut at = 2; // after SOI
    loop {
        // Markers: 0xFF, fill bytes 0xFF, then the code.
        let Some(&0xFF) = bytes.get(at) else {
            return true;
        };
        let mut code_at = at + 1;
        while bytes.get(code_at) == Some(&0xFF) {
            code_at += 1;
        }
        let Some(&code) = bytes.get(code_at) else {
            return true;
        };
        match code {
            0xC0 | 0xC1 => return false,
            0xC2 | 0xC3 | 0xC5..=0xC7 | 0xC9..=0xCB | 0xCD..=0xCF => return true,
            0xDA => return true, // a scan before any frame header
            0x01 | 0xD0..=0xD7 => at = code_at + 1,
            _ => {
                let (Some(&hi), Some(&lo)) = (bytes.get(code_at + 1), bytes.get(code_at + 2))
                else {
                    return true;
                };
                at = code_at + 1 + usize::from(u16::from_be_bytes([hi, lo]));
            }
        }
    }
}

/// One Adam7 pass: which pixels of the image its rows hold (PNG specification, 8.2).
#[derive(Clone, Copy)]
struct Pass {
    number: u8,
    x_offset: u32,
    x_step: u32,
    y_offset: u32,
    y_step: u32,
}

/// The seven passes: (x offset, x step, y offset, y step).
const ADAM7: [(u32, u32, u32, u32); 7] = [
    (0, 8, 0, 8),
    (4, 8, 0, 8),
    (0, 4, 4, 8),
    (2, 4, 0, 4),
    (0, 2, 2, 4),
    (1, 2, 0, 2),
    (0, 1, 1, 2),
];

/// The rows an interlaced `width x height` PNG holds, in file order: each pass's lines,
/// passes without pixels left out (as the png crate yields them).
fn adam7_rows(width: u32, height: u32) -> impl Iterator<Item = (Pass, u32)> {
    (1u8..)
        .zip(ADAM7)
        .flat_map(move |(number, (xo, xs, yo, ys))| {
            let pass = Pass {
                number,
                x_offset: xo,
                x_step: xs,
                y_offset: yo,
                y_step: ys,
            };
            let samples = width.saturating_sub(xo).div_ceil(xs);
            let lines = if samples == 0 {
                0
            } else {
                height.saturating_sub(yo).div_ceil(ys)
            };
            (0..lines).map(move |line| (pass, line))
        })
}

/// How a decoded row's pixels are laid out: 1 to 4 channels (grey, grey + alpha, RGB,
/// RGBA) of 8 or 16 bits (16-bit samples big-endian, as PNG stores them).
#[derive(Clone, Copy, Debug)]
struct Layout {
    channels: usize,
    sixteen: bool,
}

impl Layout {
    fn of_png(color: png::ColorType, depth: png::BitDepth) -> Option<Layout> {
        use png::ColorType as C;
        let channels = match color {
            C::Grayscale => 1,
            C::GrayscaleAlpha => 2,
            C::Rgb => 3,
            C::Rgba => 4,
            C::Indexed => return None, // expanded to RGB(A) by EXPAND
        };
        let sixteen = match depth {
            png::BitDepth::Eight => false,
            png::BitDepth::Sixteen => true,
            _ => return None, // expanded to 8 bits by EXPAND
        };
        Some(Layout { channels, sixteen })
    }

    fn of_image(color: image::ColorType) -> Option<Layout> {
        use image::ColorType as C;
        let channels = match color {
            C::L8 => 1,
            C::La8 => 2,
            C::Rgb8 => 3,
            C::Rgba8 => 4,
            _ => return None,
        };
        Some(Layout {
            channels,
            sixteen: false,
        })
    }

    fn bytes_per_pixel(&self) -> usize {
        self.channels * if self.sixteen { 2 } else { 1 }
    }

    /// A pixel's RGBA samples (grey repeated, alpha opaque where absent), each in
    /// `0..=255` or `0..=65535`.
    fn rgba(&self, px: &[u8]) -> [u16; 4] {
        let sample = |k: usize| -> u16 {
            if self.sixteen {
                let hi = px.get(2 * k).copied().unwrap_or(0);
                let lo = px.get(2 * k + 1).copied().unwrap_or(0);
                u16::from_be_bytes([hi, lo])
            } else {
                u16::from(px.get(k).copied().unwrap_or(0))
            }
        };
        let opaque = if self.sixteen { u16::MAX } else { 255 };
        match self.channels {
            1 => {
                let g = sample(0);
                [g, g, g, opaque]
            }
            2 => {
                let g = sample(0);
                [g, g, g, sample(1)]
            }
            3 => [sample(0), sample(1), sample(2), opaque],
            _ => [sample(0), sample(1), sample(2), sample(3)],
        }
    }

    /// A pixel as RGBA8, exactly as the image crate converts it (16 bits rounded to the
    /// nearest 8-bit value: `(v + 128) / 257`).
    fn rgba8(&self, px: &[u8]) -> [u8; 4] {
        self.rgba(px).map(|v| {
            if self.sixteen {
                ((u32::from(v) + 128) / 257) as u8
            } else {
                v as u8
            }
        })
    }
}

/// The sRGB transfer function's inverse: encoded value in [0, 1] -> linear (IEC 61966-2-1).
fn srgb_to_linear(c: f64) -> f64 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Linear value of each 8-bit sRGB code.
fn srgb8_lut() -> &'static [f32; 256] {
    static LUT: OnceLock<[f32; 256]> = OnceLock::new();
    LUT.get_or_init(|| std::array::from_fn(|i| srgb_to_linear(i as f64 / 255.0) as f32))
}

/// Linear value of each 16-bit sRGB code.
fn srgb16_lut() -> &'static [f32] {
    static LUT: OnceLock<Vec<f32>> = OnceLock::new();
    LUT.get_or_init(|| {
        (0..=u16::MAX)
            .map(|i| srgb_to_linear(f64::from(i) / 65535.0) as f32)
            .collect()
    })
}

/// The 8-bit sRGB code whose linear value is nearest `linear`: the mean of a block keeps
/// its linear value as closely as eight bits allow.
fn linear_to_srgb8(linear: f32) -> u8 {
    let lut = srgb8_lut();
    let above = lut.partition_point(|&l| l < linear).min(255);
    let below = above.saturating_sub(1);
    let pick = match (lut.get(below), lut.get(above)) {
        (Some(&b), Some(&a)) if linear - b <= a - linear => below,
        _ => above,
    };
    pick as u8
}

/// An 8-bit value of a linear mean in [0, 1].
fn unit_to_u8(x: f32) -> u8 {
    (x * 255.0).round().clamp(0.0, 255.0) as u8
}

/// Builds a texture from decoded rows: kept as they are at factor 1, otherwise summed
/// block by block (linear light for sRGB colour) and each block's mean written once its
/// rows are all in (row by row), or at the end (interlaced images, whose passes revisit
/// every block).
struct Reducer {
    grid: Grid,
    layout: Layout,
    encoding: Encoding,
    /// Sums for every texel (interlaced), else for one row of texels.
    whole: bool,
    /// The texel row the sums hold (row by row only).
    sum_row: u32,
    sums: Vec<[f32; 4]>,
    texels: Vec<[u8; 4]>,
}

impl Reducer {
    fn new(grid: Grid, layout: Layout, encoding: Encoding, whole: bool) -> Result<Reducer, String> {
        let alloc = |n: u64, what: &str| -> Result<usize, String> {
            usize::try_from(n).map_err(|_| format!("cannot allocate {n} {what}"))
        };
        let texels_n = alloc(grid.out_texels(), "texels")?;
        let sums_n = match (grid.factor, whole) {
            (1, _) => 0,
            (_, false) => grid.out_width as usize,
            (_, true) => texels_n,
        };
        let mut texels = Vec::new();
        let mut sums = Vec::new();
        texels
            .try_reserve_exact(texels_n)
            .and_then(|()| sums.try_reserve_exact(sums_n))
            .map_err(|_| format!("cannot allocate a {} texture", grid.describe()))?;
        texels.resize(texels_n, [0; 4]);
        sums.resize(sums_n, [0.0; 4]);
        Ok(Reducer {
            grid,
            layout,
            encoding,
            whole,
            sum_row: 0,
            sums,
            texels,
        })
    }

    /// A pixel's RGBA as values to average: linear light for sRGB colour, else as
    /// stored, in [0, 1].
    fn values(&self, px: &[u8]) -> [f32; 4] {
        let rgba = self.layout.rgba(px);
        let scale = if self.layout.sixteen {
            1.0 / 65535.0
        } else {
            1.0 / 255.0
        };
        let plain = |v: u16| f32::from(v) * scale;
        match self.encoding {
            Encoding::Linear => rgba.map(plain),
            Encoding::Srgb => {
                let colour = |v: u16| {
                    if self.layout.sixteen {
                        srgb16_lut().get(usize::from(v)).copied().unwrap_or(1.0)
                    } else {
                        srgb8_lut().get(usize::from(v)).copied().unwrap_or(1.0)
                    }
                };
                let [r, g, b, a] = rgba;
                [colour(r), colour(g), colour(b), plain(a)]
            }
        }
    }

    /// Add the pixels of one row `y` (top = 0) of the image held by `row`: pixel `i` of
    /// it is at `x = x0 + i dx`. Rows come in order, or (whole sums) in any order.
    fn add_samples(&mut self, y: u32, x0: u32, dx: u32, row: &[u8]) {
        let bpp = self.layout.bytes_per_pixel();
        let (w, f) = (self.grid.width as usize, self.grid.factor);
        let pixels = row.chunks_exact(bpp).take(self.grid.width as usize);
        if f == 1 {
            let base = y as usize * w;
            for (i, px) in pixels.enumerate() {
                let x = x0 as usize + i * dx as usize;
                if let Some(t) = self.texels.get_mut(base + x) {
                    *t = self.layout.rgba8(px);
                }
            }
            return;
        }
        let texel_row = y / f;
        if !self.whole && texel_row != self.sum_row {
            self.write_row(self.sum_row);
            self.sums.fill([0.0; 4]);
            self.sum_row = texel_row;
        }
        let base = if self.whole {
            texel_row as usize * self.grid.out_width as usize
        } else {
            0
        };
        let (f, x0, dx) = (f as usize, x0 as usize, dx as usize);
        for (i, px) in pixels.enumerate() {
            let v = self.values(px);
            if let Some(s) = self.sums.get_mut(base + (x0 + i * dx) / f) {
                for (s, v) in s.iter_mut().zip(v) {
                    *s += v;
                }
            }
        }
    }

    /// Write texel row `r` from its sums: each texel the mean of its block (blocks at the
    /// right and bottom edges hold fewer pixels).
    fn write_row(&mut self, r: u32) {
        let g = self.grid;
        let block_h = g.factor.min(g.height - (r * g.factor).min(g.height));
        let start = if self.whole {
            r as usize * g.out_width as usize
        } else {
            0
        };
        let out = r as usize * g.out_width as usize;
        for i in 0..g.out_width {
            let block_w = g.factor.min(g.width - (i * g.factor).min(g.width));
            let n = (block_w * block_h).max(1) as f32;
            let Some(sum) = self.sums.get(start + i as usize) else {
                continue;
            };
            let [r_, g_, b_, a_] = sum.map(|s| s / n);
            let texel = match self.encoding {
                Encoding::Srgb => [
                    linear_to_srgb8(r_),
                    linear_to_srgb8(g_),
                    linear_to_srgb8(b_),
                    unit_to_u8(a_),
                ],
                Encoding::Linear => [r_, g_, b_, a_].map(unit_to_u8),
            };
            if let Some(t) = self.texels.get_mut(out + i as usize) {
                *t = texel;
            }
        }
    }

    fn finish(mut self) -> Decoded {
        let g = self.grid;
        if g.factor > 1 {
            if self.whole {
                for r in 0..g.out_height {
                    self.write_row(r);
                }
            } else {
                self.write_row(self.sum_row);
            }
        }
        Decoded {
            texture: Texture {
                width: g.out_width,
                height: g.out_height,
                rgba8: self.texels,
            },
            source: (g.width, g.height),
            factor: g.factor,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grids_keep_sides_within_the_limit_by_the_smallest_factor() {
        let g = Grid::new(20_000, 20_000);
        assert_eq!((g.factor, g.out_width, g.out_height), (3, 6667, 6667));
        let g = Grid::new(8192, 100);
        assert_eq!((g.factor, g.out_width, g.out_height), (1, 8192, 100));
        let g = Grid::new(8193, 1);
        assert_eq!((g.factor, g.out_width, g.out_height), (2, 4097, 1));
        let g = Grid::new(3, 16_385);
        assert_eq!((g.factor, g.out_width, g.out_height), (3, 1, 5462));
    }

    #[test]
    fn srgb_codes_round_trip_through_linear() {
        for code in 0..=255u8 {
            let linear = srgb8_lut()[usize::from(code)];
            assert_eq!(linear_to_srgb8(linear), code);
        }
        // Mid-grey in linear light is sRGB code 188 (0.7354 encoded).
        assert_eq!(linear_to_srgb8(0.5), 188);
        assert_eq!(linear_to_srgb8(-1.0), 0);
        assert_eq!(linear_to_srgb8(2.0), 255);
    }

    #[test]
    fn adam7_rows_cover_every_pixel_once() {
        for (w, h) in [(1, 1), (3, 2), (8, 8), (13, 7), (2, 17)] {
            let mut seen = vec![0u32; (w * h) as usize];
            for (pass, line) in adam7_rows(w, h) {
                let y = line * pass.y_step + pass.y_offset;
                let mut x = pass.x_offset;
                while x < w {
                    seen[(y * w + x) as usize] += 1;
                    x += pass.x_step;
                }
            }
            assert!(seen.iter().all(|&n| n == 1), "{w} x {h}: {seen:?}");
        }
    }

    #[test]
    fn jpeg_frame_kinds_are_read_from_the_markers() {
        // SOI, an APP0 segment of 4 bytes, then a frame header.
        let jpeg = |sof: u8| vec![0xFF, 0xD8, 0xFF, 0xE0, 0, 4, 1, 2, 0xFF, sof, 0, 2];
        assert!(!jpeg_is_progressive(&jpeg(0xC0)));
        assert!(!jpeg_is_progressive(&jpeg(0xC1)));
        assert!(jpeg_is_progressive(&jpeg(0xC2)));
        assert!(jpeg_is_progressive(&[0xFF, 0xD8, 0xFF]));
        assert!(jpeg_is_progressive(&[0xFF, 0xD8, 0xFF, 0xE0, 0xFF, 0xFF]));
    }
}
