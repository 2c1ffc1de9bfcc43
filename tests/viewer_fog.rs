//! The window's Fog section on `builtin:fog`, driven as a user would with egui_kittest:
//! a visibility typed (and the slider) restarts the render with the request's medium of
//! extinction 3.912 / V, the old film on screen until the new one has light; a bad value
//! is a message and restarts nothing; "The scene's fog" renders the scene's own again;
//! "Window out to 2 V" renders the time axis out to twice the visibility.
//! With `TPRF_SCREENSHOTS=1` the ignored test `fog_screenshot` writes `screenshots/fog.png`.

use eframe::egui::{Event, Key, Modifiers, Vec2};
use egui_kittest::Harness;
use egui_kittest::kittest::{NodeT, Queryable};
use std::sync::Arc;
use std::time::{Duration, Instant};
use tprf::viewer::{Mode, Selection, Start, TprfApp, ViewerSettings};
use tprf_core::film::FilmSnapshot;
use tprf_core::request::worker::WorkerState;
use tprf_core::scene::Medium;
use tprf_core::scene::medium::MOR_EXTINCTION;
use tprf_core::sensor::Sensor;
use tprf_core::units::C_M_PER_S;

fn fog_settings(width: usize, height: usize, bins: usize, spp: u64) -> ViewerSettings {
    ViewerSettings {
        scene: "builtin:fog".into(),
        width,
        height,
        bins,
        spp_target: spp,
        ..ViewerSettings::default()
    }
}

fn harness(settings: ViewerSettings) -> Harness<'static, TprfApp> {
    Harness::builder()
        .with_size(Vec2::new(1280.0, 800.0))
        .build_eframe(move |cc| TprfApp::with_settings(cc, settings, Start::Default))
}

/// Step until the render is done; with `old`, assert every frame that a film is on
/// screen and, while the new render has none, that it is `old`.
fn wait_done(h: &mut Harness<'static, TprfApp>, old: Option<&Arc<FilmSnapshot>>) {
    let start = Instant::now();
    loop {
        h.step();
        if let Some(old) = old {
            let snap = h
                .state()
                .snapshot()
                .expect("a film on screen after a fog change");
            if h.state().showing_previous_camera() {
                assert!(Arc::ptr_eq(&snap, old), "the film kept is not the old one");
            }
        }
        match h.state().status().map(|s| s.state) {
            Some(WorkerState::Done)
                if h.state().snapshot().is_some() && !h.state().showing_previous_camera() =>
            {
                break;
            }
            Some(WorkerState::Failed(e)) => panic!("render failed: {e}"),
            _ => {}
        }
        assert!(
            start.elapsed() < Duration::from_secs(300),
            "the render did not finish"
        );
        std::thread::sleep(Duration::from_millis(10));
    }
    h.run_steps(2);
}

/// Focus the field labelled `label`, replace its text with `text` and press Enter.
fn type_and_enter(h: &mut Harness<'static, TprfApp>, label: &str, text: &str) {
    h.get_by_label(label).focus();
    h.step();
    let key = |key, modifiers| Event::Key {
        key,
        physical_key: None,
        pressed: true,
        repeat: false,
        modifiers,
    };
    h.event(key(Key::A, Modifiers::COMMAND));
    h.step();
    h.get_by_label(label).type_text(text);
    h.step();
    h.event(key(Key::Enter, Modifiers::NONE));
    h.run_steps(2);
}

/// The request's scene-wide medium (`None`: the scene's own).
fn request_medium(h: &Harness<'static, TprfApp>) -> Option<Medium> {
    h.state()
        .request()
        .expect("a render")
        .medium_override()
        .expect("a medium the request accepts")
        .flatten()
}

/// The sum of the film: every pixel's steady radiance.
fn total(snap: &FilmSnapshot) -> f64 {
    (0..snap.height())
        .flat_map(|y| (0..snap.width()).map(move |x| (x, y)))
        .map(|(x, y)| snap.pixel(x, y).iter().map(|&v| f64::from(v)).sum::<f64>())
        .sum()
}

#[test]
fn the_fog_visibility_restarts_with_its_extinction_and_bad_values_are_messages() {
    let mut h = harness(fog_settings(24, 16, 64, 2));
    wait_done(&mut h, None);
    assert_eq!(
        request_medium(&h),
        None,
        "the scene's own fog to start with"
    );
    assert_eq!(
        h.get_by_label("Visibility (m)").value().as_deref(),
        Some("50")
    );
    let old = h.state().snapshot().unwrap();

    // A thicker fog: the request's medium is 3.912 / V, all scattering, g kept.
    let v = 17.5;
    type_and_enter(&mut h, "Visibility (m)", &v.to_string());
    let m = request_medium(&h).expect("the window's fog in the request");
    assert_eq!(m.sigma_t_per_m(), [(MOR_EXTINCTION / v) as f32; 3]);
    assert_eq!(m.sigma_a_per_m, [0.0; 3]);
    assert_eq!(m.g, 0.9);
    wait_done(&mut h, Some(&old));
    let new = h.state().snapshot().unwrap();
    assert!(!Arc::ptr_eq(&new, &old));
    // Denser fog: more of the laser's light comes back from it (its backscatter) than
    // from the targets it now hides; the film changed.
    let (t0, t1) = (total(&old), total(&new));
    assert!((t1 - t0).abs() > 0.05 * t0, "film totals {t0} and {t1}");
    assert_eq!(
        h.get_by_label("Visibility (m)").value().as_deref(),
        Some("17.5")
    );

    // Bad values: a message naming the field, no restart (the render stays done, with
    // the same request).
    let request = h.state().request().unwrap();
    for (label, text, named) in [
        ("Visibility (m)", "-5", "fog visibility '-5'"),
        ("Visibility (m)", "far", "fog visibility 'far'"),
        ("g", "1", "fog g '1'"),
        ("Albedo", "2", "fog albedo '2'"),
    ] {
        let before = h.state().messages().len();
        type_and_enter(&mut h, label, text);
        let messages = &h.state().messages()[before..];
        assert!(
            messages.iter().any(|m| m.starts_with(named)),
            "{text}: {messages:?}"
        );
        assert_eq!(h.state().request().unwrap(), request);
        assert!(
            matches!(h.state().status().map(|s| s.state), Some(WorkerState::Done)),
            "a bad value restarted the render"
        );
        h.get_by_label("Revert fog").click();
        h.run_steps(2);
    }

    // Albedo and g typed: the request's medium has them, the visibility kept exactly.
    type_and_enter(&mut h, "g", "0");
    let m = request_medium(&h).unwrap();
    assert_eq!(
        (m.g, m.sigma_t_per_m()),
        (0.0, [(MOR_EXTINCTION / v) as f32; 3])
    );
    wait_done(&mut h, None);

    // The scene's own fog again.
    h.get_by_label("The scene's fog").click();
    h.run_steps(2);
    assert_eq!(request_medium(&h), None);
    wait_done(&mut h, None);
    assert_eq!(
        h.get_by_label("Visibility (m)").value().as_deref(),
        Some("50")
    );

    // The window out to 2 V = 100 m: light's round trip 200 m from t = 0.
    h.get_by_label("Window out to 100 m (2 V)").click();
    h.run_steps(2);
    let r = h.state().request().unwrap();
    assert_eq!(r.t0_s, Some(0.0));
    let range_m = r.dt_s.unwrap() * r.bins as f64 * C_M_PER_S / 2.0;
    assert!((range_m - 100.0).abs() < 1e-9, "{range_m} m");
    wait_done(&mut h, None);
}

/// A scene in clear air offers a fog: the Cornell box (bounding diagonal 0.96 m)
/// suggests a visibility of 9.6 m, and "Add fog" renders it in that fog (the request's
/// medium, extinction 3.912 / 9.6 per metre): its backscatter and attenuation change the
/// film, which then keeps the light only the fog gives (before the walls' first return).
#[test]
fn a_scene_in_clear_air_can_be_given_fog() {
    let mut h = harness(ViewerSettings {
        scene: "builtin:cornell".into(),
        width: 8,
        height: 8,
        bins: 64,
        spp_target: 8,
        t0: "0 ns".into(),
        dt: "100 ps".into(),
        ..ViewerSettings::default()
    });
    wait_done(&mut h, None);
    h.get_by_label("Fog: clear air").click();
    h.run_steps(2);
    let clear = h.state().snapshot().unwrap();
    assert!(request_medium(&h).is_none());
    let suggested: f64 = h
        .get_by_label("Visibility (m)")
        .accesskit_node()
        .value()
        .expect("the visibility field's text")
        .parse()
        .unwrap();
    let diag = f64::from(
        tprf_core::scene::builtin::load("cornell")
            .unwrap()
            .bounds()
            .diagonal_m(),
    );
    assert!(
        (suggested - 10.0 * diag).abs() <= 0.05 * 10.0 * diag,
        "{suggested} vs {diag}"
    );
    h.get_by_label("Add fog").click();
    h.run_steps(2);
    let m = request_medium(&h).expect("the fog is the request's medium");
    let want = 3.912 / suggested;
    assert!((f64::from(m.sigma_t_per_m()[0]) - want).abs() < 1e-4 * want);
    wait_done(&mut h, Some(&clear));
    let fog = h.state().snapshot().unwrap();
    // The fog's backscatter arrives before any wall's light: in clear air every bin
    // before the first lit one is exactly empty; in fog (extinction 0.39 / m, the
    // camera 0.8 m from the box) those bins hold the light scattered on the way. (A
    // change of the total alone is within 8 spp's noise: in-scattering makes up for much
    // of what the fog takes away.)
    let pixels = |s: &FilmSnapshot| {
        (0..s.height())
            .flat_map(|y| (0..s.width()).map(move |x| (x, y)))
            .map(|(x, y)| s.pixel(x, y))
            .collect::<Vec<_>>()
    };
    let first_lit = pixels(&clear)
        .iter()
        .filter_map(|p| p.iter().position(|&v| v > 0.0))
        .min()
        .expect("the clear film has light");
    let early = |s: &FilmSnapshot| -> f64 {
        pixels(s)
            .iter()
            .map(|p| p[..first_lit].iter().map(|&v| f64::from(v)).sum::<f64>())
            .sum()
    };
    assert!(
        first_lit > 0,
        "light in the first bin: no early bins to check"
    );
    assert_eq!(early(&clear), 0.0);
    let (early_fog, all_fog) = (early(&fog), total(&fog));
    assert!(
        early_fog > 1e-3 * all_fog,
        "the fog's backscatter before bin {first_lit}: {early_fog} of {all_fog}"
    );
    assert!(h.query_by_label_contains("clear air").is_none());
}

/// `TPRF_SCREENSHOTS=1 cargo test --release --test viewer_fog -- --ignored fog_screenshot`
/// writes `screenshots/fog.png` (the transient view) and `screenshots/fog-spad.png` (the
/// SPAD preset on the same film).
#[test]
#[ignore = "writes screenshots/; run by hand"]
fn fog_screenshot() {
    if std::env::var_os("TPRF_SCREENSHOTS").is_none() {
        eprintln!("set TPRF_SCREENSHOTS=1 to write screenshots/");
        return;
    }
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("screenshots");
    std::fs::create_dir_all(&dir).unwrap();
    let (w, hgt) = (160, 96);
    // A pixel on the car at 35 m in the next lane, and the bin of its return (out and
    // back 70 m: 233 ns, bins of 2.5 ns); the window 0 … 96 m.
    let (x, y) = pixel_env("TPRF_FOG_PIXEL", (54, 50));
    let bin = pixel_env("TPRF_FOG_BIN", (93, 0)).0;
    let settings = ViewerSettings {
        plot_log: true,
        log_image: true,
        t0: "0 ns".into(),
        dt: "2.5 ns".into(),
        ..fog_settings(w, hgt, 256, 512)
    };
    // Taller than the other screenshots: the SPAD's histogram under the pixel's plots.
    let mut h = Harness::builder()
        .with_size(Vec2::new(1280.0, 1000.0))
        .build_eframe(move |cc| TprfApp::with_settings(cc, settings, Start::Default));
    wait_done(&mut h, None);
    {
        let app = h.state_mut();
        app.playing = false;
        app.selection = Some(Selection::pixel(x, y));
        app.bin = bin;
    }
    h.remove_cursor();
    h.run_steps(3);
    let mut img = h.render().expect("a wgpu adapter for screenshots");
    tprf::viewer::over_background(&mut img, &h.ctx.global_style().visuals);
    img.save(dir.join("fog.png")).unwrap();

    {
        let app = h.state_mut();
        app.settings.mode = Mode::Sensor;
        app.settings.sensor = Sensor::builtin("spad").unwrap();
        app.sensor.gate = 0;
        app.sensor.preset_picked();
    }
    h.run_steps(2);
    let snap = h.state().snapshot().unwrap();
    let start = Instant::now();
    while (!h.state().sensor.is_current(&snap) || h.state().sensor.spad_sampling())
        && start.elapsed() < Duration::from_secs(120)
    {
        h.step();
        std::thread::sleep(Duration::from_millis(20));
    }
    h.run_steps(4);
    let mut img = h.render().expect("a wgpu adapter for screenshots");
    tprf::viewer::over_background(&mut img, &h.ctx.global_style().visuals);
    img.save(dir.join("fog-spad.png")).unwrap();
}

/// `x,y` from the environment variable `name`, else `default`.
fn pixel_env(name: &str, default: (usize, usize)) -> (usize, usize) {
    std::env::var(name)
        .ok()
        .and_then(|s| {
            let (a, b) = s.split_once(',')?;
            Some((a.trim().parse().ok()?, b.trim().parse().ok()?))
        })
        .unwrap_or(default)
}

/// `builtin:fog` first opened: the automatic window holds the targets behind the fog
/// (the car in the next lane 35 m away: out and back 233 ns), and the view opens on
/// their returns, not on the backscatter where every pixel peaks. The nearest surface
/// the camera sees is the road 1.2 / tan(10 deg) = 6.8 m ahead (20 degrees field of
/// view, level): the opening slice is after its return (45 ns) and before the car's.
#[test]
fn fog_opens_on_the_returns_of_the_targets_behind_it() {
    let mut h = harness(fog_settings(48, 27, 128, 1));
    h.state_mut().playing = false;
    wait_done(&mut h, None);
    let axis = *h.state().snapshot().unwrap().axis();
    let car_s = 2.0 * 35.0 / C_M_PER_S;
    assert!(
        axis.end_s() >= car_s,
        "{axis:?} ends before the car's return"
    );
    let road_s = 2.0 * 1.2 / 10f64.to_radians().tan() / C_M_PER_S;
    let t = axis.bin_center_s(h.state().bin);
    assert!(
        t >= road_s && t <= car_s,
        "opened at {} ns, not between the road's first return {} ns and the car's {} ns",
        t * 1e9,
        road_s * 1e9,
        car_s * 1e9
    );
    let returns_s = h.state().status().unwrap().surface_returns_s.unwrap();
    assert_eq!(axis.bin_of(returns_s), Some(h.state().bin));
}
