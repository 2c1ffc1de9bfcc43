//! The window's Phasor tab, driven with egui_kittest: a cube folder written with
//! `--phasor` shows its `phasor.npy` (the readout under the pointer checked against the
//! file, the frequency slider's words against `phasor.json`, the arrows stepping it); a
//! live render shows the phasors of its film at the band typed (checked against
//! `export::phasor::phasor_image`), a bad band is a message; a Mitsuba file with a
//! `phasor_hdr_film` sets the band.
//! With `TPRF_SCREENSHOTS=1` the ignored test `phasor_screenshot` writes
//! `screenshots/phasor.png`.

use eframe::egui::{Event, Key, Modifiers, Pos2, Vec2};
use egui_kittest::Harness;
use egui_kittest::kittest::{NodeT, Queryable};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};
use tprf::viewer::phasor::maths::{PhasorPlanes, frequency_label, phase_color, phase_rgba};
use tprf::viewer::{Mode, Start, TprfApp, ViewerSettings};
use tprf_core::export::phasor::{PhasorBand, PhasorMetadata, phasor_image};
use tprf_core::film::TimeFilter;
use tprf_core::request::worker::WorkerState;

fn repo() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn tempdir(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("viewer-phasor-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn harness(settings: ViewerSettings, start: Start) -> Harness<'static, TprfApp> {
    Harness::builder()
        .with_size(Vec2::new(1280.0, 800.0))
        .build_eframe(move |cc| TprfApp::with_settings(cc, settings, start))
}

fn wait_done(h: &mut Harness<'static, TprfApp>) {
    let start = Instant::now();
    loop {
        h.step();
        match h.state().status().map(|s| s.state) {
            Some(WorkerState::Done) if h.state().snapshot().is_some() => break,
            Some(WorkerState::Failed(e)) => panic!("render failed: {e}"),
            _ => {}
        }
        assert!(
            start.elapsed() < Duration::from_secs(120),
            "render did not finish"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    h.run_steps(2);
}

/// The label (or value) of the node whose label contains `part`.
fn label_with(h: &Harness<'static, TprfApp>, part: &str) -> String {
    let node = h.get_by_label_contains(part).accesskit_node();
    node.label()
        .filter(|l| l.contains(part))
        .or_else(|| node.value())
        .unwrap_or_default()
}

fn number_after(text: &str, key: &str) -> f64 {
    let rest = &text[text
        .find(key)
        .unwrap_or_else(|| panic!("{key:?} not in {text:?}"))
        + key.len()..];
    let word = rest.trim_start().split([' ', '°']).next().unwrap();
    word.parse()
        .unwrap_or_else(|e| panic!("{word:?} in {text:?}: {e}"))
}

fn pixel_pos(
    h: &Harness<'static, TprfApp>,
    label: &str,
    x: usize,
    y: usize,
    w: usize,
    hgt: usize,
) -> Pos2 {
    let rect = h.get_by_label(label).rect();
    Pos2::new(
        rect.min.x + (x as f32 + 0.5) * rect.width() / w as f32,
        rect.min.y + (y as f32 + 0.5) * rect.height() / hgt as f32,
    )
}

/// Hover pixel `(x, y)` of the amplitude image and read the readout's |P| and arg P.
fn readout(
    h: &mut Harness<'static, TprfApp>,
    x: usize,
    y: usize,
    w: usize,
    hgt: usize,
) -> (f64, f64) {
    let pos = pixel_pos(h, "phasor amplitude image", x, y, w, hgt);
    h.hover_at(pos);
    h.run_steps(2);
    let text = label_with(h, &format!("row {y}, column {x} ·"));
    (number_after(&text, "|P|"), number_after(&text, "arg P"))
}

fn key(h: &mut Harness<'static, TprfApp>, k: Key) {
    h.event(Event::Key {
        key: k,
        physical_key: None,
        pressed: true,
        repeat: false,
        modifiers: Modifiers::NONE,
    });
    h.run_steps(2);
}

/// A cube folder written with `--phasor`: the tab shows its file's frequency (the
/// slider's words against `phasor.json`: per metre, and the wavelength), the readout of
/// a pixel equals the file's amplitude and phase, both images have colour bars (the
/// phase in degrees on a cyclic map), and the right arrow steps the frequency.
#[test]
fn a_cube_folders_phasors_show_as_amplitude_and_phase() {
    let dir = tempdir("cube");
    let out = dir.join("cube");
    let (w, hgt) = (24usize, 16usize);
    let o = Command::new(env!("CARGO_BIN_EXE_tprf"))
        .args(["render", "builtin:cornell", "--out"])
        .arg(&out)
        .args([
            "--width", "24", "--height", "16", "--bins", "64", "--spp", "8",
        ])
        .args(["--phasor", "1m:0.2m"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let meta: PhasorMetadata =
        serde_json::from_slice(&std::fs::read(out.join("phasor.json")).unwrap()).unwrap();
    let (shape, data) = tprf_core::export::read_npy_f32(&out.join("phasor.npy")).unwrap();
    let nf = shape[2] as usize;
    assert!(nf >= 3, "{nf} frequencies");
    let settings = ViewerSettings {
        mode: Mode::Phasor,
        phasor_index: 1,
        ..ViewerSettings::default()
    };
    let mut h = harness(settings, Start::Cube(out.clone()));
    h.run_steps(3);
    label_with(&h, "phasors of the cube folder (phasor.npy)");
    // The frequency shown, in words.
    let f = meta.frequencies_per_m[1];
    let words = label_with(&h, "m⁻¹ ·");
    let wl = number_after(&words, "λ");
    assert!((wl - 1.0 / f.abs()).abs() <= 1e-3 * wl, "{words}: f {f}");
    assert!(
        (number_after(&words, "") - f).abs() <= 1e-3 * f.abs(),
        "{words}"
    );
    // The brightest pixel at this frequency, from the file.
    let at = |x: usize, y: usize, j: usize| {
        let i = ((y * w + x) * nf + j) * 2;
        (f64::from(data[i]), f64::from(data[i + 1]))
    };
    let (px, py) = (0..w * hgt)
        .map(|p| (p % w, p / w))
        .max_by(|a, b| {
            let m = |q: (usize, usize)| {
                let (re, im) = at(q.0, q.1, 1);
                re.hypot(im)
            };
            m(*a).total_cmp(&m(*b))
        })
        .unwrap();
    let (re, im) = at(px, py, 1);
    let (amp, deg) = readout(&mut h, px, py, w, hgt);
    assert!(re.hypot(im) > 0.0);
    assert!(
        (amp - re.hypot(im)).abs() <= 1e-3 * re.hypot(im),
        "|P| {amp} against {}",
        re.hypot(im)
    );
    let want_deg = im.atan2(re).to_degrees();
    assert!(
        (deg - want_deg).abs() <= 0.1,
        "arg {deg} against {want_deg}"
    );
    let phase_bar = label_with(&h, "colour bar: phasor phase");
    assert!(
        phase_bar.ends_with("-180.0 … 180.0 °, linear"),
        "{phase_bar}"
    );
    let amp_bar = label_with(&h, "colour bar: phasor amplitude");
    assert!(amp_bar.ends_with("W m⁻² sr⁻¹, linear"), "{amp_bar}");
    // The right arrow shows the next frequency.
    key(&mut h, Key::ArrowRight);
    assert_eq!(h.state().settings.phasor_index, 2);
    let words = label_with(&h, "m⁻¹ ·");
    let f2 = meta.frequencies_per_m[2];
    assert!(
        (number_after(&words, "λ") - 1.0 / f2.abs()).abs() <= 1e-3 / f2.abs(),
        "{words}"
    );
}

/// A live render: the tab computes its film's phasors at the band's frequencies (the
/// readout against `phasor_image` of the film on screen); a band typed changes them, a
/// malformed one is a message and changes nothing.
#[test]
fn a_live_render_shows_its_films_phasors_at_the_band_typed() {
    let (side, bins) = (16usize, 48usize);
    let band = PhasorBand {
        wl_mean_m: 2.0,
        wl_sigma_m: 1.0,
    };
    let settings = ViewerSettings {
        scene: "builtin:cornell".into(),
        width: side,
        height: side,
        bins,
        spp_target: 8,
        mode: Mode::Phasor,
        phasor: Some(band),
        ..ViewerSettings::default()
    };
    let mut h = harness(settings, Start::Default);
    wait_done(&mut h);
    let snap = h.state().snapshot().unwrap();
    let axis = snap.axis();
    let meta = PhasorMetadata::new(band, axis.t0_s, axis.dt_s, bins, TimeFilter::Box).unwrap();
    let j = h
        .state()
        .settings
        .phasor_index
        .min(meta.frequencies_per_m.len() - 1);
    let image = phasor_image(&snap, meta.frequencies_per_m[j], TimeFilter::Box);
    let (px, py) = (side / 2, side / 2 + 2);
    let [re, im] = image[py * side + px];
    let (amp, deg) = readout(&mut h, px, py, side, side);
    assert!(re.hypot(im) > 0.0);
    assert!(
        (amp - re.hypot(im)).abs() <= 1e-3 * re.hypot(im),
        "{amp} against {}",
        re.hypot(im)
    );
    assert!((deg - im.atan2(re).to_degrees()).abs() <= 0.1);
    // A new band, typed.
    let field = "Band wl_mean:wl_sigma (m of optical path)";
    let type_and_enter = |h: &mut Harness<'static, TprfApp>, text: &str| {
        h.get_by_label(field).focus();
        h.step();
        h.event(Event::Key {
            key: Key::A,
            physical_key: None,
            pressed: true,
            repeat: false,
            modifiers: Modifiers::COMMAND,
        });
        h.step();
        h.get_by_label(field).type_text(text);
        h.step();
        key(h, Key::Enter);
    };
    type_and_enter(&mut h, "3:0.5");
    assert_eq!(
        h.state().settings.phasor,
        Some(PhasorBand {
            wl_mean_m: 3.0,
            wl_sigma_m: 0.5
        })
    );
    type_and_enter(&mut h, "3");
    label_with(&h, "is not WL_MEAN:WL_SIGMA");
    assert_eq!(h.state().settings.phasor.map(|b| b.wl_mean_m), Some(3.0));
}

/// mitransient's example file opened in the window sets the tab's band from its film.
#[test]
fn a_phasor_film_sets_the_band() {
    let xml = repo().join("assets/mitsuba/mitransient/cornell-box/cbox_diffuse_freq.xml");
    let h = harness(
        ViewerSettings::default(),
        Start::Scene(xml.to_str().unwrap().into()),
    );
    assert_eq!(
        h.state().settings.phasor,
        Some(PhasorBand {
            wl_mean_m: 100.0,
            wl_sigma_m: 100.0
        })
    );
    assert!(
        h.state()
            .messages()
            .iter()
            .any(|m| m.contains("phasor band 100:100 m")),
        "{:?}",
        h.state().messages()
    );
}

/// `TPRF_SCREENSHOTS=1 cargo test --release --test viewer_phasor -- --ignored
/// phasor_screenshot` writes `screenshots/phasor.png`: mitransient's example
/// (`cbox_diffuse_freq.xml`, 128 x 128, 256 spp, its 4000 bins of 1 m) rendered by
/// `tprf render`, its folder opened, at 0.01 per metre (wavelength 100 m).
#[test]
#[ignore = "writes screenshots/; run by hand"]
fn phasor_screenshot() {
    if std::env::var_os("TPRF_SCREENSHOTS").is_none() {
        eprintln!("set TPRF_SCREENSHOTS=1 to write screenshots/");
        return;
    }
    let dir = tempdir("shot");
    let out = dir.join("cube");
    let xml = repo().join("assets/mitsuba/mitransient/cornell-box/cbox_diffuse_freq.xml");
    let o = Command::new(env!("CARGO_BIN_EXE_tprf"))
        .arg("render")
        .arg(&xml)
        .arg("--out")
        .arg(&out)
        .args(["--width", "128", "--height", "128", "--spp", "256"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let settings = ViewerSettings {
        mode: Mode::Phasor,
        // Index 20 of the 41: fftfreq index 40, 0.01 per metre.
        phasor_index: 20,
        ..ViewerSettings::default()
    };
    let mut h = harness(settings, Start::Cube(out));
    h.remove_cursor();
    h.run_steps(4);
    let shots = repo().join("screenshots");
    std::fs::create_dir_all(&shots).unwrap();
    let mut img = h.render().expect("a wgpu adapter for screenshots");
    tprf::viewer::over_background(&mut img, &h.ctx.global_style().visuals);
    img.save(shots.join("phasor.png")).unwrap();
}

/// Amplitude and phase of known phasors: 3 + 4i is 5 at atan2(4, 3); -1 is pi.
#[test]
fn planes_are_modulus_and_argument() {
    let p = PhasorPlanes::from_complex(&[[3.0, 4.0], [-1.0, 0.0], [0.0, -2.0]]);
    assert_eq!(p.amplitude, [5.0, 1.0, 2.0]);
    assert!((f64::from(p.phase_rad[0]) - 4f64.atan2(3.0)).abs() < 1e-7);
    assert!((f64::from(p.phase_rad[1]) - std::f64::consts::PI).abs() < 1e-6);
    assert!((f64::from(p.phase_rad[2]) + std::f64::consts::FRAC_PI_2).abs() < 1e-6);
}

/// Frequency j of a [pixels, F, 2] array is its (2j, 2j+1) pair per pixel.
#[test]
fn a_frequency_is_cut_from_the_array() {
    // Two pixels, three frequencies.
    let data = [1., 0., 0., 2., 5., 5., -3., 0., 0., 0., 1., 1.];
    let p = PhasorPlanes::from_array(&data, 3, 1);
    assert_eq!(p.amplitude, [2.0, 0.0]);
    assert!((f64::from(p.phase_rad[0]) - std::f64::consts::FRAC_PI_2).abs() < 1e-6);
    assert_eq!(
        PhasorPlanes::from_array(&data, 3, 3),
        PhasorPlanes::default()
    );
    assert_eq!(
        PhasorPlanes::from_array(&data[..5], 3, 0),
        PhasorPlanes::default()
    );
}

/// The phase colours wrap: -pi and pi are one colour, a small step is a small change,
/// opposite phases differ.
#[test]
fn phase_colours_are_cyclic() {
    use std::f64::consts::PI;
    let d = |a: [u8; 3], b: [u8; 3]| {
        a.iter()
            .zip(b)
            .map(|(x, y)| (f64::from(*x) - f64::from(y)).abs())
            .fold(0.0, f64::max)
    };
    assert!(d(phase_color(-PI), phase_color(PI)) <= 1.0);
    assert!(d(phase_color(0.1), phase_color(0.1 + 2.0 * PI)) <= 1.0);
    for k in 0..360 {
        let a = -PI + k as f64 * PI / 180.0;
        assert!(
            d(phase_color(a), phase_color(a + PI / 180.0)) <= 12.0,
            "{a}"
        );
    }
    assert!(d(phase_color(0.0), phase_color(PI)) >= 100.0);
    assert!(d(phase_color(PI / 2.0), phase_color(-PI / 2.0)) >= 100.0);
}

/// A dark pixel's phase is black; a lit one takes its colour.
#[test]
fn dark_pixels_have_no_phase_colour() {
    let p = PhasorPlanes {
        amplitude: vec![1.0, 1e-9],
        phase_rad: vec![0.5, 0.5],
    };
    let rgba = phase_rgba(&p, 1e-6);
    assert_eq!(&rgba[..3], &phase_color(0.5));
    assert_eq!(&rgba[4..7], &[0, 0, 0]);
    assert_eq!((rgba[3], rgba[7]), (255, 255));
}

/// 0.01 per metre of optical path is c / 100 m = 2.998 MHz.
#[test]
fn frequencies_read_in_three_units() {
    let s = frequency_label(0.01);
    assert!(s.contains("2.998 MHz"), "{s}");
    assert!(s.contains("λ 100 m"), "{s}");
    assert!(frequency_label(0.0).contains("DC"));
    assert!(frequency_label(-0.5).contains("λ 2 m"));
}
