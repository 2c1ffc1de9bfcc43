//! The paper's Figures 5, 6 and 7 from the 1-D world of its Figure 4
//! (`assets/oned/figure4.json`) through the full-waveform LiDAR preset, as SVG plots:
//! the TPRF (weighted impulses), the TPRF convolved with the Gaussian light, and the
//! box-gated measurements. Writes `docs/sensor/figure{5,6,7}.svg`.
//!
//! Run: `cargo run --release --example sensor_figures`.

use std::fmt::Write as _;
use std::path::Path;

use tprf_core::film::TimeAxis;
use tprf_core::oned::{ImpulseOptions, World, binned};
use tprf_core::sensor::{Sensor, SensorModel};

const W: f64 = 640.0;
const H: f64 = 240.0;
const LEFT: f64 = 60.0;
const BOTTOM: f64 = 40.0;
const TOP: f64 = 30.0;
const RIGHT: f64 = 20.0;

/// A plot frame: x in ns over `[x0, x1]`, y over `[0, y1]`.
struct Frame {
    x0: f64,
    x1: f64,
    y1: f64,
}

impl Frame {
    fn x(&self, t_ns: f64) -> f64 {
        LEFT + (t_ns - self.x0) / (self.x1 - self.x0) * (W - LEFT - RIGHT)
    }

    fn y(&self, v: f64) -> f64 {
        H - BOTTOM - v / self.y1 * (H - BOTTOM - TOP)
    }

    /// The SVG header and title.
    fn open(&self, title: &str) -> String {
        format!(
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{W}\" height=\"{H}\" \
             font-family=\"sans-serif\" font-size=\"12\">\n\
             <rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n\
             <text x=\"{}\" y=\"18\" text-anchor=\"middle\" font-size=\"14\">{title}</text>\n",
            W / 2.0
        )
    }

    /// Axes, ticks and labels (drawn over the data).
    fn axes(&self, ylabel: &str) -> String {
        let (xa, xb, ya, yb) = (LEFT, W - RIGHT, H - BOTTOM, TOP);
        let mut s =
            format!("<path d=\"M{xa} {yb} V{ya} H{xb}\" stroke=\"black\" fill=\"none\"/>\n");
        let mut t = (self.x0 / 50.0).ceil() * 50.0;
        while t <= self.x1 {
            let x = self.x(t);
            let _ = writeln!(
                s,
                "<path d=\"M{x:.1} {ya} v5\" stroke=\"black\"/>\
                 <text x=\"{x:.1}\" y=\"{}\" text-anchor=\"middle\">{t:.0}</text>",
                ya + 18.0
            );
            t += 50.0;
        }
        for v in [0.0, 0.5 * self.y1, self.y1] {
            let y = self.y(v);
            let _ = writeln!(
                s,
                "<path d=\"M{xa} {y:.1} h-5\" stroke=\"black\"/>\
                 <text x=\"{}\" y=\"{:.1}\" text-anchor=\"end\">{}</text>",
                xa - 7.0,
                y + 4.0,
                if v == 0.0 {
                    "0".to_string()
                } else {
                    format!("{v:.2}")
                }
            );
        }
        let _ = writeln!(
            s,
            "<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">time after the pulse (ns)</text>\n\
             <text x=\"{}\" y=\"{}\" text-anchor=\"start\">{ylabel}</text>",
            (xa + xb) / 2.0,
            H - 6.0,
            xa + 8.0,
            yb + 4.0,
        );
        s
    }
}

fn write(path: &Path, svg: String) {
    if let Err(e) = std::fs::write(path, svg + "</svg>\n") {
        panic!("cannot write {}: {e}", path.display());
    }
    println!("wrote {}", path.display());
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let world = match World::from_path(&root.join("assets/oned/figure4.json")) {
        Ok(w) => w,
        Err(e) => panic!("{e}"),
    };
    let impulses = world.impulses(&ImpulseOptions::default());
    let axis = match TimeAxis::new(50e-9, 0.1e-9, 2560) {
        Ok(a) => a,
        Err(e) => panic!("{e}"),
    };
    let cube: Vec<f32> = binned(&impulses, axis.t0_s, axis.dt_s, axis.bins)
        .iter()
        .map(|&v| v as f32)
        .collect();
    let model = match Sensor::builtin("lidar").and_then(|s| SensorModel::new(s, axis)) {
        Ok(m) => m,
        Err(e) => panic!("{e}"),
    };
    let trace = match model.pixel_trace(&cube) {
        Ok(t) => t,
        Err(e) => panic!("{e}"),
    };
    let meas = match model.measure(&cube, 1, 1) {
        Ok(m) => m,
        Err(e) => panic!("{e}"),
    };
    let out = root.join("docs/sensor");
    if let Err(e) = std::fs::create_dir_all(&out) {
        panic!("{e}");
    }
    let frame = |y1: f64| Frame {
        x0: 50.0,
        x1: 306.0,
        y1,
    };

    // Figure 5: the TPRF, weighted impulses.
    let f = frame(0.35);
    let mut s = f.open("Figure 5: TPRF of the 1-D world (impulses)");
    for i in impulses.iter().filter(|i| i.time_s < axis.end_s()) {
        let x = f.x(i.time_s * 1e9);
        let _ = writeln!(
            s,
            "<path d=\"M{x:.1} {:.1} V{:.1}\" stroke=\"#1f4e9c\" stroke-width=\"2\"/>\
             <circle cx=\"{x:.1}\" cy=\"{:.1}\" r=\"3\" fill=\"#1f4e9c\"/>",
            f.y(0.0),
            f.y(i.weight),
            f.y(i.weight)
        );
    }
    s += &f.axes("weight (fraction of the pulse)");
    write(&out.join("figure5.svg"), s);

    // Figure 6: (TPRF * Light) on the bins, as power (divided by the bin width).
    let peak = trace.tprf_light.iter().fold(0.0f64, |m, v| m.max(*v)) / axis.dt_s;
    let f = frame(1.1 * peak * 1e-9);
    let mut s = f.open("Figure 6: TPRF * Light (Gaussian pulse, FWHM 2 ns, centred at 5 ns)");
    let mut d = String::new();
    for (b, v) in trace.tprf_light.iter().enumerate() {
        let _ = write!(
            d,
            "{}{:.1} {:.1} ",
            if b == 0 { "M" } else { "L" },
            f.x(axis.bin_center_s(b) * 1e9),
            f.y(v / axis.dt_s * 1e-9)
        );
    }
    let _ = writeln!(
        s,
        "<path d=\"{d}\" stroke=\"#b03a2e\" stroke-width=\"1.5\" fill=\"none\"/>"
    );
    s += &f.axes("flux (fraction of the pulse per ns)");
    write(&out.join("figure6.svg"), s);

    // Figure 7: one bar per 1 ns box gate.
    let peak = meas.values.iter().fold(0.0f32, |m, v| m.max(*v));
    let f = frame(1.1 * f64::from(peak));
    let mut s = f.open("Figure 7: measurements M_i, 1 ns box gates");
    for (g, v) in model.gates().iter().zip(&meas.values) {
        let Some((a, b)) = g.support_s() else {
            continue;
        };
        if *v <= 0.0 {
            continue;
        }
        let (xa, xb) = (f.x(a * 1e9), f.x(b * 1e9));
        let _ = writeln!(
            s,
            "<rect x=\"{xa:.2}\" y=\"{:.2}\" width=\"{:.2}\" height=\"{:.2}\" \
             fill=\"#2e7d32\"/>",
            f.y(f64::from(*v)),
            (xb - xa).max(0.5),
            f.y(0.0) - f.y(f64::from(*v))
        );
    }
    s += &f.axes("M_i (fraction of the pulse)");
    write(&out.join("figure7.svg"), s);
}
