//! Spectra from colours: a band at a wavelength takes its value of an RGB quantity from a
//! smooth spectrum that has that colour, by Jakob & Hanika's model ("A Low-Dimensional
//! Function Space for Efficient Spectral Upsampling", Computer Graphics Forum 38(2),
//! 2019): a reflectance spectrum is a sigmoid of a quadratic in the wavelength,
//!
//! `R(lambda) = S(c0 t^2 + c1 t + c2)`, `S(x) = 1/2 + x / (2 sqrt(1 + x^2))`,
//! `t = (lambda - 360 nm) / 470 nm`,
//!
//! whose coefficients make the spectrum's linear sRGB colour under CIE D65 (CIE 1931 2°
//! observer, 5 nm steps from 360 to 830 nm) the colour asked for. A colour given in the
//! scene is fitted on its own ([`coefficients`]: Gauss-Newton in CIELAB, as the paper's
//! optimiser, along a path from grey); a texel's, met per hit, is read from a table over
//! the colour cube computed once per process on first use ([`table`]: [`TABLE_RES`]
//! steps along each axis of the paper's parametrisation, warm-started along the
//! brightness, trilinear between its entries).
//!
//! Round trip (tested): a colour of the cube's interior, upsampled and integrated back to
//! linear sRGB, is within 1e-5 of where it started by its own fit, within
//! [`ROUND_TRIP_TOLERANCE`] through the table (docs/dispersion.md gives the figures).
//!
//! Greys are exact: `(v, v, v)` is the flat spectrum `v` at every wavelength (the
//! model's `c0 = c1 = 0`), so a grey material or white light is the same in every band.
//! Quantities that are not reflectances (emission, intensities, coefficients: a largest
//! component above 1) take the paper's scaled form `s R(rgb / s)` with `s` twice the
//! largest component, which keeps the spectrum as bright as the colour asks.

use rayon::prelude::*;
use std::sync::OnceLock;

/// The wavelength range of the colour-matching data, nm: a band's wavelength must lie in it.
pub const LAMBDA_MIN_NM: f64 = 360.0;
pub const LAMBDA_MAX_NM: f64 = 830.0;

/// The Fraunhofer d line (helium), nm: where a glass catalogue's `n_d` is measured, and
/// the wavelength at which a dispersive index is read for the red, green, blue and grey
/// bands (which have none of their own).
pub const D_LINE_NM: f64 = 587.56;

/// Steps along each axis of the coefficient table (the paper's tables have 64).
pub const TABLE_RES: usize = 32;

/// The largest difference, per linear sRGB component, between a colour and its
/// upsampled spectrum's colour that the round-trip test accepts.
pub const ROUND_TRIP_TOLERANCE: f64 = 3e-3;

/// A wavelength in nanometres, in `[LAMBDA_MIN_NM, LAMBDA_MAX_NM]`.
#[derive(Clone, Copy, Debug)]
pub struct Wavelength {
    nm: f32,
}

impl PartialEq for Wavelength {
    fn eq(&self, other: &Wavelength) -> bool {
        self.nm.to_bits() == other.nm.to_bits()
    }
}
impl Eq for Wavelength {}

impl Wavelength {
    /// A wavelength of `nm` nanometres; refused outside the colour-matching range.
    pub fn from_nm(nm: f64) -> Result<Wavelength, String> {
        if !(nm.is_finite() && (LAMBDA_MIN_NM..=LAMBDA_MAX_NM).contains(&nm)) {
            return Err(format!(
                "wavelength {nm} nm is outside [{LAMBDA_MIN_NM}, {LAMBDA_MAX_NM}] nm (the CIE \
                 colour-matching range the spectra are defined over)"
            ));
        }
        Ok(Wavelength { nm: nm as f32 })
    }

    /// The wavelength in nanometres.
    pub fn nm(self) -> f64 {
        self.nm as f64
    }

    /// The wavelength in micrometres (dispersion formulas take it so).
    pub fn um(self) -> f64 {
        self.nm as f64 * 1e-3
    }

    /// Parse `550nm`, `0.55um` (or `µm`), or a bare number of nanometres.
    pub fn parse(s: &str) -> Result<Wavelength, String> {
        let t = s.trim();
        let (num, scale) = if let Some(v) = t.strip_suffix("nm") {
            (v, 1.0)
        } else if let Some(v) = t.strip_suffix("um").or_else(|| t.strip_suffix("µm")) {
            (v, 1e3)
        } else {
            (t, 1.0)
        };
        let x: f64 = num
            .trim()
            .parse()
            .map_err(|_| format!("'{s}' is not a wavelength (e.g. 550nm or 0.55um)"))?;
        Wavelength::from_nm(x * scale)
    }

    /// Its name in files and on the command line: `550nm`.
    pub fn name(self) -> String {
        format!("{}nm", self.nm)
    }

    /// The value at this wavelength of the smooth spectrum whose colour is the linear
    /// sRGB triple `rgb` (see the module's notes: greys flat and exact, black 0, a
    /// largest component above 1 by the scaled form). Negative components count as 0.
    pub fn pick(self, rgb: [f32; 3]) -> f32 {
        let c = rgb.map(|v| if v > 0.0 { v } else { 0.0 });
        let m = c[0].max(c[1]).max(c[2]);
        if m <= 0.0 || !m.is_finite() {
            return if m.is_finite() { 0.0 } else { m };
        }
        if c[0] == c[1] && c[1] == c[2] {
            return m;
        }
        let lambda = self.nm as f64;
        if m <= 1.0 {
            coefficients(c.map(f64::from)).eval(lambda) as f32
        } else {
            let s = 2.0 * m as f64;
            (s * coefficients(c.map(|v| v as f64 / s)).eval(lambda)) as f32
        }
    }

    /// [`Wavelength::pick`] by the table's interpolated coefficients instead of a fit of
    /// their own: for colours met per hit (a texture's), where a fit would cost tens of
    /// microseconds. Within [`ROUND_TRIP_TOLERANCE`] of the fit's colour; the table is
    /// built on the first call.
    pub fn pick_fast(self, rgb: [f32; 3]) -> f32 {
        let c = rgb.map(|v| if v > 0.0 { v } else { 0.0 });
        let m = c[0].max(c[1]).max(c[2]);
        if m <= 0.0 || !m.is_finite() {
            return if m.is_finite() { 0.0 } else { m };
        }
        if c[0] == c[1] && c[1] == c[2] {
            return m;
        }
        let lambda = self.nm as f64;
        if m <= 1.0 {
            table().coefficients(c.map(f64::from)).eval(lambda) as f32
        } else {
            let s = 2.0 * m as f64;
            (s * table().coefficients(c.map(|v| v as f64 / s)).eval(lambda)) as f32
        }
    }

    /// The CIE 1931 luminous efficiency `ybar` at this wavelength (1 at 555 nm), linearly
    /// interpolated between the 5 nm table's rows.
    pub fn ybar(self) -> f64 {
        cmf_at(self.nm as f64)[1]
    }
}

/// `S(x) = 1/2 + x / (2 sqrt(1 + x^2))`: the model's sigmoid, from 0 to 1.
#[inline]
pub fn sigmoid(x: f64) -> f64 {
    if x.is_infinite() {
        return if x > 0.0 { 1.0 } else { 0.0 };
    }
    0.5 + x / (2.0 * (1.0 + x * x).sqrt())
}

/// The model's coefficients `[c0, c1, c2]` of the quadratic in `t = (lambda - 360 nm) /
/// 470 nm`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Coefficients(pub [f64; 3]);

impl Coefficients {
    /// `R(lambda)`, the reflectance at `lambda_nm`.
    #[inline]
    pub fn eval(&self, lambda_nm: f64) -> f64 {
        let t = (lambda_nm - LAMBDA_MIN_NM) / (LAMBDA_MAX_NM - LAMBDA_MIN_NM);
        let [c0, c1, c2] = self.0;
        sigmoid((c0 * t + c1) * t + c2)
    }
}

/// CIE 1931 2° colour-matching functions `xbar, ybar, zbar` and the CIE D65 illuminant
/// (relative), every 5 nm from 360 to 830 nm (CIE 015:2018's tables, as Mitsuba 3 ships
/// them).
const CIE_5NM: [[f64; 4]; 95] = [
    [0.0001299, 3.917e-06, 0.0006061, 0.4711063],  // 360
    [0.0002321, 6.965e-06, 0.001086, 0.4986362],   // 365
    [0.0004149, 1.239e-05, 0.001946, 0.5261663],   // 370
    [0.0007416, 2.202e-05, 0.003486, 0.5154912],   // 375
    [0.001368, 3.9e-05, 0.006450001, 0.5048162],   // 380
    [0.002236, 6.4e-05, 0.01054999, 0.5284158],    // 385
    [0.004243, 0.00012, 0.02005001, 0.5520164],    // 390
    [0.00765, 0.000217, 0.03621, 0.6939726],       // 395
    [0.01431, 0.000396, 0.06785001, 0.8359299],    // 400
    [0.02319, 0.00064, 0.1102, 0.880027],          // 405
    [0.04351, 0.00121, 0.2074, 0.9241251],         // 410
    [0.07763, 0.00218, 0.3713, 0.9339526],         // 415
    [0.13438, 0.004, 0.6456, 0.9437802],           // 420
    [0.21477, 0.0073, 1.03905, 0.9096904],         // 425
    [0.2839, 0.0116, 1.3856, 0.8756016],           // 430
    [0.3285, 0.01684, 1.62296, 0.9674353],         // 435
    [0.34828, 0.023, 1.74706, 1.05927],            // 440
    [0.34806, 0.0298, 1.7826, 1.120595],           // 445
    [0.3362, 0.038, 1.77211, 1.18193],             // 450
    [0.3187, 0.048, 1.7441, 1.185991],             // 455
    [0.2908, 0.06, 1.6692, 1.190051],              // 460
    [0.2511, 0.0739, 1.5281, 1.175142],            // 465
    [0.19536, 0.09098, 1.28764, 1.160242],         // 470
    [0.1421, 0.1126, 1.0419, 1.165606],            // 475
    [0.09564, 0.13902, 0.8129501, 1.17097],        // 480
    [0.05795001, 0.1693, 0.6162, 1.13505],         // 485
    [0.03201, 0.20802, 0.46518, 1.09913],          // 490
    [0.0147, 0.2586, 0.3533, 1.101867],            // 495
    [0.0049, 0.323, 0.272, 1.104615],              // 500
    [0.0024, 0.4073, 0.2123, 1.096776],            // 505
    [0.0093, 0.503, 0.1582, 1.088938],             // 510
    [0.0291, 0.6082, 0.1117, 1.073725],            // 515
    [0.06327, 0.71, 0.07824999, 1.058512],         // 520
    [0.1096, 0.7932, 0.05725001, 1.073149],        // 525
    [0.1655, 0.862, 0.04216, 1.087796],            // 530
    [0.2257499, 0.9148501, 0.02984, 1.07121],      // 535
    [0.2904, 0.954, 0.0203, 1.054623],             // 540
    [0.3597, 0.9803, 0.0134, 1.052805],            // 545
    [0.4334499, 0.9949501, 0.008749999, 1.050997], // 550
    [0.5120501, 1.0, 0.005749999, 1.030562],       // 555
    [0.5945, 0.995, 0.0039, 1.010127],             // 560
    [0.6784, 0.9786, 0.002749999, 0.9916127],      // 565
    [0.7621, 0.952, 0.0021, 0.9730981],            // 570
    [0.8425, 0.9154, 0.0018, 0.9703394],           // 575
    [0.9163, 0.87, 0.001650001, 0.9675808],        // 580
    [0.9786, 0.8163, 0.0014, 0.9317092],           // 585
    [1.0263, 0.757, 0.0011, 0.8958375],            // 590
    [1.0567, 0.6949, 0.001, 0.9025074],            // 595
    [1.0622, 0.631, 0.0008, 0.9091773],            // 600
    [1.0456, 0.5668, 0.0006, 0.9071206],           // 605
    [1.0026, 0.503, 0.00034, 0.905065],            // 610
    [0.9384, 0.4412, 0.00024, 0.8954668],          // 615
    [0.8544499, 0.381, 0.00019, 0.8858685],        // 620
    [0.7514, 0.321, 0.0001, 0.8635942],            // 625
    [0.6424, 0.265, 4.999999e-05, 0.8413209],      // 630
    [0.5419, 0.217, 3e-05, 0.8433947],             // 635
    [0.4479, 0.175, 2e-05, 0.8454686],             // 640
    [0.3608, 0.1382, 1e-05, 0.8269206],            // 645
    [0.2835, 0.107, 0.0, 0.8083726],               // 650
    [0.2187, 0.0816, 0.0, 0.8093211],              // 655
    [0.1649, 0.061, 0.0, 0.8102696],               // 660
    [0.1212, 0.04458, 0.0, 0.8206901],             // 665
    [0.0874, 0.032, 0.0, 0.8311106],               // 670
    [0.0636, 0.0232, 0.0, 0.8109403],              // 675
    [0.04677, 0.017, 0.0, 0.7907702],              // 680
    [0.0329, 0.01192, 0.0, 0.7475215],             // 685
    [0.0227, 0.00821, 0.0, 0.7042739],             // 690
    [0.01584, 0.005723, 0.0, 0.7138085],           // 695
    [0.01135916, 0.004102, 0.0, 0.7233431],        // 700
    [0.008110916, 0.002929, 0.0, 0.7371808],       // 705
    [0.005790346, 0.002091, 0.0, 0.7510196],       // 710
    [0.004109457, 0.001484, 0.0, 0.6866493],       // 715
    [0.002899327, 0.001047, 0.0, 0.6222789],       // 720
    [0.00204919, 0.00074, 0.0, 0.6641062],         // 725
    [0.001439971, 0.00052, 0.0, 0.7059336],        // 730
    [0.0009999493, 0.0003611, 0.0, 0.7322039],     // 735
    [0.0006900786, 0.0002492, 0.0, 0.7584743],     // 740
    [0.0004760213, 0.0001719, 0.0, 0.7004203],     // 745
    [0.0003323011, 0.00012, 0.0, 0.6423673],       // 750
    [0.0002348261, 8.48e-05, 0.0, 0.5556246],      // 755
    [0.0001661505, 6e-05, 0.0, 0.4688829],         // 760
    [0.000117413, 4.24e-05, 0.0, 0.5718513],       // 765
    [8.307527e-05, 3e-05, 0.0, 0.6748196],         // 770
    [5.870652e-05, 2.12e-05, 0.0, 0.6575333],      // 775
    [4.150994e-05, 1.499e-05, 0.0, 0.640247],      // 780
    [2.935326e-05, 1.06e-05, 0.0, 0.6448997],      // 785
    [2.067383e-05, 7.4657e-06, 0.0, 0.6495523],    // 790
    [1.455977e-05, 5.2578e-06, 0.0, 0.6250456],    // 795
    [1.025398e-05, 3.7029e-06, 0.0, 0.6005399],    // 800
    [7.221456e-06, 2.6078e-06, 0.0, 0.5626955],    // 805
    [5.085868e-06, 1.8366e-06, 0.0, 0.5248521],    // 810
    [3.581652e-06, 1.2934e-06, 0.0, 0.5525376],    // 815
    [2.522525e-06, 9.1093e-07, 0.0, 0.5802233],    // 820
    [1.776509e-06, 6.4153e-07, 0.0, 0.5947276],    // 825
    [1.251141e-06, 4.5181e-07, 0.0, 0.6092331],    // 830
];

/// The colour-matching functions at `lambda_nm`, linear between the table's rows (0
/// outside it).
fn cmf_at(lambda_nm: f64) -> [f64; 3] {
    let x = (lambda_nm - LAMBDA_MIN_NM) / 5.0;
    if !(x >= 0.0 && x <= (CIE_5NM.len() - 1) as f64) {
        return [0.0; 3];
    }
    let i = (x as usize).min(CIE_5NM.len() - 2);
    let f = x - i as f64;
    let (a, b) = (CIE_5NM[i], CIE_5NM[i + 1]);
    [0, 1, 2].map(|k| a[k] + (b[k] - a[k]) * f)
}

/// CIE XYZ -> linear sRGB (IEC 61966-2-1, D65 white).
const XYZ_TO_SRGB: [[f64; 3]; 3] = [
    [3.240_479, -1.537_150, -0.498_535],
    [-0.969_256, 1.875_991, 0.041_556],
    [0.055_648, -0.204_043, 1.057_311],
];
/// Linear sRGB -> CIE XYZ, the inverse of [`XYZ_TO_SRGB`].
const SRGB_TO_XYZ: [[f64; 3]; 3] = [
    [0.412_453, 0.357_580, 0.180_423],
    [0.212_671, 0.715_160, 0.072_169],
    [0.019_334, 0.119_193, 0.950_227],
];

fn mat3(m: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|r| m[r][0] * v[0] + m[r][1] * v[1] + m[r][2] * v[2])
}

/// CIE XYZ of a reflectance spectrum `r(lambda)` under D65, `Y = 1` for `r = 1`:
/// `X = sum xbar D65 r / sum ybar D65` over the 5 nm table.
pub fn reflectance_xyz(r: impl Fn(f64) -> f64) -> [f64; 3] {
    let mut xyz = [0.0; 3];
    let mut norm = 0.0;
    for (i, row) in CIE_5NM.iter().enumerate() {
        let v = r(LAMBDA_MIN_NM + 5.0 * i as f64) * row[3];
        for k in 0..3 {
            xyz[k] += row[k] * v;
        }
        norm += row[1] * row[3];
    }
    xyz.map(|x| x / norm)
}

/// Linear sRGB of a reflectance spectrum under D65 ([`reflectance_xyz`]).
pub fn reflectance_rgb(r: impl Fn(f64) -> f64) -> [f64; 3] {
    mat3(&XYZ_TO_SRGB, reflectance_xyz(r))
}

/// CIELAB of `xyz` against the white `white`.
fn lab(xyz: [f64; 3], white: [f64; 3]) -> [f64; 3] {
    let f = |t: f64| {
        const D: f64 = 6.0 / 29.0;
        if t > D * D * D {
            t.cbrt()
        } else {
            t / (3.0 * D * D) + 4.0 / 29.0
        }
    };
    let (fx, fy, fz) = (
        f(xyz[0] / white[0]),
        f(xyz[1] / white[1]),
        f(xyz[2] / white[2]),
    );
    [116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)]
}

/// The XYZ of the flat spectrum 1 under D65: the white of the fit's CIELAB.
fn white_xyz() -> [f64; 3] {
    static W: OnceLock<[f64; 3]> = OnceLock::new();
    *W.get_or_init(|| reflectance_xyz(|_| 1.0))
}

/// The coefficients of the reflectance colour `rgb` (linear sRGB, components in [0,
/// 1]): fitted along a straight path from grey 0.5 (the model's `c = 0`) to `rgb` in
/// [`HOMOTOPY_STEPS`] steps, each fit ([`fit`]) warm-started from the last, so saturated
/// colours converge as the paper's table sweep makes them. Tens of microseconds.
pub fn coefficients(rgb: [f64; 3]) -> Coefficients {
    let mut c = Coefficients([0.0; 3]);
    for k in 1..=HOMOTOPY_STEPS {
        let f = k as f64 / HOMOTOPY_STEPS as f64;
        fit(rgb.map(|v| 0.5 + (v.clamp(0.0, 1.0) - 0.5) * f), &mut c);
    }
    c
}

/// Steps of [`coefficients`]' path from grey.
pub const HOMOTOPY_STEPS: usize = 8;

/// Gauss-Newton on `c` (from its value, the warm start) until the spectrum's CIELAB is
/// within 1e-6 of `rgb`'s, at most 15 steps, as the paper's optimiser: the Jacobian by
/// forward differences, each step a 3 x 3 solve. Returns the final CIELAB distance.
pub fn fit(rgb: [f64; 3], c: &mut Coefficients) -> f64 {
    let white = white_xyz();
    let target = lab(mat3(&SRGB_TO_XYZ, rgb), white);
    let residual = |c: &Coefficients| {
        let got = lab(reflectance_xyz(|l| c.eval(l)), white);
        [0, 1, 2].map(|k| target[k] - got[k])
    };
    let mut r = residual(c);
    for _ in 0..15 {
        let mut jac = [[0.0; 3]; 3];
        const H: f64 = 1e-4;
        for j in 0..3 {
            let mut cj = *c;
            cj.0[j] += H;
            let rj = residual(&cj);
            for (row, (ri, rji)) in jac.iter_mut().zip(r.iter().zip(&rj)) {
                row[j] = (ri - rji) / H; // d(got)/dc = -(d residual)/dc
            }
        }
        let Some(step) = solve3(jac, r) else { break };
        for (cj, sj) in c.0.iter_mut().zip(step) {
            *cj += sj;
        }
        // Keep the quadratic from running off (the paper clamps its coefficients too).
        let m = c.0.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        if m > 200.0 {
            c.0 = c.0.map(|v| v * 200.0 / m);
        }
        r = residual(c);
        if r.iter().map(|v| v * v).sum::<f64>() < 1e-12 {
            break;
        }
    }
    r.iter().map(|v| v * v).sum::<f64>().sqrt()
}

/// `x` with `a x = b` (Cramer's rule), `None` when `a` is singular.
fn solve3(a: [[f64; 3]; 3], b: [f64; 3]) -> Option<[f64; 3]> {
    let det = |m: [[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(a);
    if d.abs() < 1e-15 || !d.is_finite() {
        return None;
    }
    let col = |j: usize| {
        let mut m = a;
        for i in 0..3 {
            m[i][j] = b[i];
        }
        det(m) / d
    };
    Some([col(0), col(1), col(2)])
}

/// The coefficient table over the colour cube, in the paper's parametrisation: for the
/// largest component `l` of a colour, its value `z` on a smoothstep-of-smoothstep scale
/// and the other two components over it, `x = rgb[l + 1] / z`, `y = rgb[l + 2] / z`, on
/// a uniform grid.
pub struct Table {
    scale: Vec<f64>,
    coeffs: Vec<Coefficients>,
}

/// The process's table, fitted on first use (in parallel; tens of milliseconds to a
/// second by the machine).
pub fn table() -> &'static Table {
    static T: OnceLock<Table> = OnceLock::new();
    T.get_or_init(|| Table::fit(TABLE_RES))
}

impl Table {
    /// Fit a table of `res` steps per axis: along each (l, x, y) line the brightness runs
    /// up from a fifth of the scale and down from there, each fit warm-started from the
    /// last (the paper's `rgb2spec_opt`).
    pub fn fit(res: usize) -> Table {
        let smooth = |x: f64| x * x * (3.0 - 2.0 * x);
        let scale: Vec<f64> = (0..res)
            .map(|k| smooth(smooth(k as f64 / (res - 1) as f64)))
            .collect();
        let lines: Vec<(usize, usize, usize)> = (0..3)
            .flat_map(|l| (0..res).flat_map(move |j| (0..res).map(move |i| (l, j, i))))
            .collect();
        let fitted: Vec<Vec<Coefficients>> = lines
            .par_iter()
            .map(|&(l, j, i)| {
                let (x, y) = (i as f64 / (res - 1) as f64, j as f64 / (res - 1) as f64);
                let mut out = vec![Coefficients([0.0; 3]); res];
                let start = res / 5;
                let rgb_at = |z: f64| {
                    let mut rgb = [0.0; 3];
                    rgb[l] = z;
                    rgb[(l + 1) % 3] = x * z;
                    rgb[(l + 2) % 3] = y * z;
                    rgb
                };
                let mut c = Coefficients([0.0; 3]);
                for (k, slot) in out.iter_mut().enumerate().skip(start) {
                    fit(rgb_at(scale[k]), &mut c);
                    *slot = c;
                }
                let mut c = Coefficients([0.0; 3]);
                for k in (0..start).rev() {
                    fit(rgb_at(scale[k]), &mut c);
                    out[k] = c;
                }
                out
            })
            .collect();
        // Index ((l * res + k) * res + j) * res + i.
        let mut coeffs = vec![Coefficients([0.0; 3]); 3 * res * res * res];
        for (&(l, j, i), line) in lines.iter().zip(&fitted) {
            for (k, c) in line.iter().enumerate() {
                coeffs[((l * res + k) * res + j) * res + i] = *c;
            }
        }
        Table { scale, coeffs }
    }

    /// The coefficients of `rgb` (components in [0, 1], not all 0): the table's trilinear
    /// interpolation (the paper's `rgb2spec_fetch`).
    pub fn coefficients(&self, rgb: [f64; 3]) -> Coefficients {
        let res = self.scale.len();
        let rgb = rgb.map(|v| v.clamp(0.0, 1.0));
        let l = if rgb[0] >= rgb[1] && rgb[0] >= rgb[2] {
            0
        } else if rgb[1] >= rgb[2] {
            1
        } else {
            2
        };
        let z = rgb[l];
        let last = (res - 1) as f64;
        let x = if z > 0.0 {
            rgb[(l + 1) % 3] / z * last
        } else {
            0.0
        };
        let y = if z > 0.0 {
            rgb[(l + 2) % 3] / z * last
        } else {
            0.0
        };
        let zi = self.scale.partition_point(|&s| s <= z).clamp(1, res - 1) - 1;
        let (xi, yi) = ((x as usize).min(res - 2), (y as usize).min(res - 2));
        let (x1, y1) = (x - xi as f64, y - yi as f64);
        let z1 = ((z - self.scale[zi]) / (self.scale[zi + 1] - self.scale[zi])).clamp(0.0, 1.0);
        let at = |dk: usize, dj: usize, di: usize| {
            self.coeffs[((l * res + zi + dk) * res + yi + dj) * res + xi + di].0
        };
        let mut c = [0.0; 3];
        for (dk, wz) in [(0, 1.0 - z1), (1, z1)] {
            for (dj, wy) in [(0, 1.0 - y1), (1, y1)] {
                for (di, wx) in [(0, 1.0 - x1), (1, x1)] {
                    let w = wz * wy * wx;
                    let v = at(dk, dj, di);
                    for k in 0..3 {
                        c[k] += w * v[k];
                    }
                }
            }
        }
        Coefficients(c)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The flat spectrum 1 is sRGB white to the tables' rounding, so the fit's target and
    /// its white agree.
    #[test]
    fn flat_white_is_srgb_white() {
        let rgb = reflectance_rgb(|_| 1.0);
        for v in rgb {
            assert!((v - 1.0).abs() < 5e-3, "{rgb:?}");
        }
    }

    /// Greys are flat and exact in every band; black is 0.
    #[test]
    fn greys_are_flat() {
        for nm in [400.0, 550.0, 700.0] {
            let w = Wavelength::from_nm(nm).unwrap();
            assert_eq!(w.pick([0.8, 0.8, 0.8]), 0.8);
            assert_eq!(w.pick([5.0, 5.0, 5.0]), 5.0);
            assert_eq!(w.pick([0.0, 0.0, 0.0]), 0.0);
        }
    }

    /// Colours over the cube (a 9-step grid of [0.05, 0.95]^3), upsampled by a fit of
    /// their own and through the table, and integrated back under D65, are within 1e-5
    /// (the fit) and [`ROUND_TRIP_TOLERANCE`] (the table) of where they started; the
    /// largest and mean errors are printed for the docs.
    #[test]
    fn spectra_round_trip_rgb() {
        let t = table();
        let steps: Vec<f64> = (0..9).map(|i| 0.05 + 0.1125 * i as f64).collect();
        let error = |c: Coefficients, rgb: [f64; 3]| {
            let back = reflectance_rgb(|l| c.eval(l));
            (0..3).map(|k| (back[k] - rgb[k]).abs()).fold(0.0, f64::max)
        };
        let (mut worst, mut sum, mut fit_worst, mut fit_sum, mut n) = (0.0f64, 0.0, 0.0f64, 0.0, 0);
        for &r in &steps {
            for &g in &steps {
                for &b in &steps {
                    let e = error(t.coefficients([r, g, b]), [r, g, b]);
                    let f = error(coefficients([r, g, b]), [r, g, b]);
                    (worst, sum) = (worst.max(e), sum + e);
                    (fit_worst, fit_sum) = (fit_worst.max(f), fit_sum + f);
                    n += 1;
                }
            }
        }
        let nf = n as f64;
        println!(
            "round trip over {n} colours: fit worst {fit_worst:.2e} mean {:.2e}; table worst \
             {worst:.2e} mean {:.2e}",
            fit_sum / nf,
            sum / nf
        );
        assert!(fit_worst < 1e-5, "fit worst {fit_worst}");
        assert!(worst < ROUND_TRIP_TOLERANCE, "table worst {worst}");
    }

    /// A saturated colour's spectrum is where its colour says: red high at 650 nm and low
    /// at 450, blue the other way round.
    #[test]
    fn saturated_colours_put_their_light_where_they_say() {
        let (blue, red) = (
            Wavelength::from_nm(450.0).unwrap(),
            Wavelength::from_nm(650.0).unwrap(),
        );
        let r = [0.8, 0.05, 0.05];
        assert!(
            red.pick(r) > 0.7 && blue.pick(r) < 0.1,
            "{} {}",
            red.pick(r),
            blue.pick(r)
        );
        let b = [0.05, 0.05, 0.8];
        assert!(
            blue.pick(b) > 0.5 && red.pick(b) < 0.1,
            "{} {}",
            blue.pick(b),
            red.pick(b)
        );
    }

    #[test]
    fn wavelengths_parse_and_refuse() {
        assert_eq!(Wavelength::parse("550nm").unwrap().nm(), 550.0);
        assert_eq!(Wavelength::parse("0.45um").unwrap().nm(), 450.0);
        assert_eq!(Wavelength::parse(" 600 ").unwrap().nm(), 600.0);
        for bad in ["2000nm", "blue", "-5nm", "NaNnm"] {
            assert!(Wavelength::parse(bad).is_err(), "{bad}");
        }
    }
}
