//! The phasor tab's numbers, without a window: a frequency's amplitude and phase images
//! from its phasors, their white point, the cyclic colours of a phase, and a frequency
//! in words (per metre of optical path, Hz, wavelength).

use tprf_core::units::C_M_PER_S;

/// One frequency's amplitude `|P|` (the phasor's unit: a bin's, summed) and phase
/// `arg P` in `(-pi, pi]` radians, per pixel, row 0 = top.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PhasorPlanes {
    pub amplitude: Vec<f32>,
    pub phase_rad: Vec<f32>,
}

impl PhasorPlanes {
    /// From phasors `[re, im]` per pixel.
    pub fn from_complex(values: &[[f64; 2]]) -> PhasorPlanes {
        PhasorPlanes {
            amplitude: values.iter().map(|[re, im]| re.hypot(*im) as f32).collect(),
            phase_rad: values.iter().map(|[re, im]| im.atan2(*re) as f32).collect(),
        }
    }

    /// Frequency `j` of `data`, float32 `[pixels, F, 2]` (`phasor.npy`); empty planes
    /// when `j` is not below `F` or the data is not whole pixels.
    pub fn from_array(data: &[f32], frequencies: usize, j: usize) -> PhasorPlanes {
        let stride = frequencies * 2;
        if j >= frequencies || stride == 0 || !data.len().is_multiple_of(stride) {
            return PhasorPlanes::default();
        }
        let values: Vec<[f64; 2]> = data
            .chunks_exact(stride)
            .map(|px| [f64::from(px[2 * j]), f64::from(px[2 * j + 1])])
            .collect();
        PhasorPlanes::from_complex(&values)
    }

    /// The amplitude shown white: the 98th percentile of the positive amplitudes, so
    /// that a light seen directly (a few per cent of the pixels, far brighter than what
    /// it lights) saturates rather than darkens the rest (`None` when every pixel is
    /// dark).
    pub fn white(&self) -> Option<f64> {
        tprf_core::film::quantile_positive(self.amplitude.iter().copied(), 0.98)
    }
}

/// Below this fraction of the white amplitude a pixel's phase is noise: the phase
/// image draws it black.
pub const PHASE_FLOOR: f64 = 1e-3;

/// The cyclic colour of phase `phi` (radians, any turn): a sinebow over `[-pi, pi)`,
/// equal at `-pi` and `pi`.
pub fn phase_color(phi: f64) -> [u8; 3] {
    let t = (phi / std::f64::consts::TAU + 0.5).rem_euclid(1.0);
    let c = colorous::SINEBOW.eval_continuous(t);
    [c.r, c.g, c.b]
}

/// RGBA8 pixels of the phase image: each pixel's [`phase_color`], black where its
/// amplitude is below `floor` (no light to have a phase).
pub fn phase_rgba(planes: &PhasorPlanes, floor: f64) -> Vec<u8> {
    let mut out = vec![255u8; planes.phase_rad.len() * 4];
    for ((px, &phi), &a) in out
        .chunks_exact_mut(4)
        .zip(&planes.phase_rad)
        .zip(&planes.amplitude)
    {
        let rgb = if f64::from(a) > floor && a.is_finite() {
            phase_color(f64::from(phi))
        } else {
            [0, 0, 0]
        };
        px[..3].copy_from_slice(&rgb);
    }
    out
}

/// `v` to 4 significant digits, trailing zeros dropped: `0.01`, `2.998`, `100`.
fn short(v: f64) -> String {
    let s = crate::viewer::axes::format_sig(v, 4);
    if s.contains('.') && !s.contains('e') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// A frequency in words: `0.01 m⁻¹ · 2.998 MHz · λ 100 m` (the DC term: `0 m⁻¹ · DC`).
pub fn frequency_label(f_per_m: f64) -> String {
    let per_m = short(f_per_m);
    if f_per_m == 0.0 {
        return format!("{per_m} m⁻¹ · DC (the steady image)");
    }
    let hz = f_per_m * C_M_PER_S;
    let (scale, unit) = match hz.abs() {
        a if a >= 1e9 => (1e-9, "GHz"),
        a if a >= 1e6 => (1e-6, "MHz"),
        a if a >= 1e3 => (1e-3, "kHz"),
        _ => (1.0, "Hz"),
    };
    format!(
        "{per_m} m⁻¹ · {} {unit} · λ {} m",
        short(hz * scale),
        short(1.0 / f_per_m.abs())
    )
}
