//! The sensor, its film and sampler, and the integrator: tprf's camera, and the render
//! settings the file carries ([`FileSettings`]).
//!
//! - `perspective` (and `thinlens`, rendered as a pinhole): `to_world` maps Mitsuba's
//!   camera space (+Z forward, +Y up, +X the image's left) to the world; the field of
//!   view follows Mitsuba's `fov` and `fov_axis` (`x`, the default, `y`, `diagonal`,
//!   `smaller`, `larger`) or `focal_length` (on a 36 x 24 mm film's diagonal), converted
//!   to tprf's vertical one with the film's aspect. tprf's camera does not clip
//!   (`far_clip` is noted when given), but mitransient counts a path's optical length
//!   from the near clip plane (`near_clip`, default 0.01), where Mitsuba starts camera
//!   rays: the film's window starts at `start_opl + near_clip` of tprf's optical path,
//!   so a bin holds the light of mitransient's bin on the image's axis (off the axis at
//!   angle a, mitransient's arrivals are earlier by `near_clip (1 / cos a - 1)` more).
//! - Films `hdrfilm` (width, height; default 768 x 576) and mitransient's
//!   `transient_hdr_film` (also `temporal_bins`, default 2048; `bin_width_opl`, default
//!   0.003; `start_opl`, default 0: tprf's time window is
//!   `t0 = (start_opl + near_clip) / c`, `dt = bin_width_opl / c`). A pixel in tprf is
//!   the mean over its square (Mitsuba's `box` reconstruction filter); another
//!   `<rfilter>` (the `gaussian` default) is noted.
//! - mitransient's `phasor_hdr_film`: read as `transient_hdr_film` (`temporal_bins`
//!   default 4096), with `wl_mean` (default 100) and `wl_sigma` (default 1000) in the
//!   settings: the render writes the cube and its phasors at mitransient's frequencies
//!   (`export::phasor`).
//! - The sampler's `sample_count` is the samples per pixel.
//! - Integrators `path`, `transient_path` and the path tracers that also handle media:
//!   Mitsuba's `max_depth` counts the segments of a path, the camera's first, so tprf's
//!   largest number of scattering events is `max_depth - 1` (`max_depth` 2: direct light
//!   only, tprf's `--max-bounces 1`); -1, every bounce. Its default is -1 for `path`
//!   and 6 for mitransient's `transient_path`.

use super::Builder;
use super::transform::is_affine;
use super::xml::{Object, Prop, err};
use crate::scene::{Camera, FileSetting, FovAxis, SceneError, TimeOrigin};
use glam::{Affine3A, DMat3, DMat4, DVec3};

/// Mitsuba's default film size.
const DEFAULT_WIDTH: i64 = 768;
const DEFAULT_HEIGHT: i64 = 576;
/// Mitsuba's default `near_clip` of a perspective sensor, scene units.
const NEAR_CLIP_DEFAULT: f64 = 0.01;

/// Where a setting came from: its property, or the object whose default it is.
fn origin(o: &Object, p: Option<&Prop>) -> String {
    match p {
        Some(p) => format!("{} <{} name=\"{}\">", p.loc, p.value.tag(), p.name),
        None => format!("{} {} (Mitsuba's default)", o.loc, o.describe()),
    }
}

/// A positive integer setting `name` of `o` (default `default`).
fn count(o: &Object, name: &str, default: i64) -> Result<FileSetting<u64>, SceneError> {
    let (v, p) = o.integer(name, default)?;
    if v < 1 {
        let loc = p.map_or(o.loc.clone(), |p| p.loc.clone());
        return Err(err(
            &loc,
            format!("{name} {v} of {} must be at least 1", o.describe()),
        ));
    }
    Ok(FileSetting {
        value: v as u64,
        from: origin(o, p),
    })
}

impl Builder<'_> {
    /// The first `<sensor>`: camera, film, sampler.
    pub(super) fn read_sensor(&mut self, k: usize) -> Result<(), SceneError> {
        let o = self.object(k);
        match o.plugin.as_str() {
            "perspective" => {}
            "thinlens" => {
                let _ = (
                    o.float("aperture_radius", 0.0)?,
                    o.float("focus_distance", 0.0)?,
                );
                self.note_at(
                    &o.loc,
                    "<sensor type=\"thinlens\"> rendered as a pinhole (no depth of field)".into(),
                );
            }
            "nlos_capture_meter" => {
                return Err(err(
                    &o.loc,
                    format!(
                        "{} at the scene's top level: mitransient's capture meter belongs inside the relay wall's <shape>",
                        o.describe()
                    ),
                ));
            }
            _ => {
                return Err(Builder::unsupported(
                    o,
                    "tprf renders a perspective pinhole camera",
                ));
            }
        }
        // Sub-objects: the film and the sampler.
        let mut film = None;
        for (p, c) in o.children() {
            p.used.set(true);
            let child = self.object(c);
            match child.tag {
                "film" => film = Some(c),
                "sampler" => {
                    let (spp, at) = child.integer("sample_count", 4)?;
                    if let Some(at) = at {
                        if spp < 1 {
                            return Err(err(
                                &at.loc,
                                format!("sample_count {spp} must be at least 1"),
                            ));
                        }
                        self.settings.spp = Some(FileSetting {
                            value: spp as u64,
                            from: origin(child, Some(at)),
                        });
                    }
                    let _ = child.integer("seed", 0)?;
                }
                // The medium the camera sits in: the scene's (the air).
                "medium" => self.medium = Some(self.medium(c, 1.0)?),
                _ => {
                    return Err(err(
                        &child.loc,
                        format!(
                            "{} inside {} is not supported",
                            child.describe(),
                            o.describe()
                        ),
                    ));
                }
            }
        }
        match film {
            Some(f) => self.read_film(f)?,
            None => {
                self.notes.push(format!(
                    "{}: no <film>: Mitsuba's default hdrfilm, {DEFAULT_WIDTH} x {DEFAULT_HEIGHT}",
                    o.loc
                ));
                self.settings.width = Some(FileSetting {
                    value: DEFAULT_WIDTH as u64,
                    from: origin(o, None),
                });
                self.settings.height = Some(FileSetting {
                    value: DEFAULT_HEIGHT as u64,
                    from: origin(o, None),
                });
            }
        }
        let (fov_rad, fov_axis) = self.fov(o)?;
        // mitransient measures a path's optical length from the near clip plane, where
        // Mitsuba starts camera rays; tprf from the pinhole unless the render asks for
        // `TimeOrigin::NearPlane`. The camera keeps the plane; the settings keep it so a
        // pinhole render's window starts `near_clip` later (`FileSettings::t0_opl_m_for`).
        let near_clip = o.float("near_clip", NEAR_CLIP_DEFAULT)?;
        if !(near_clip >= 0.0 && near_clip.is_finite() && near_clip <= f32::MAX as f64) {
            return Err(err(
                &o.loc,
                format!("{}: near_clip {near_clip} must be >= 0", o.describe()),
            ));
        }
        self.settings.near_clip_m = Some(FileSetting {
            value: near_clip,
            from: origin(o, o.prop("near_clip")),
        });
        if o.prop("far_clip").is_some() {
            let v = o.float("far_clip", 0.0)?;
            self.note_at(
                &o.loc,
                format!("<float name=\"far_clip\" value=\"{v}\"> not applied: tprf's camera sees to infinity"),
            );
        }
        let _ = (
            o.float("focus_distance", 0.0)?,
            o.float("shutter_open", 0.0)?,
            o.float("shutter_close", 0.0)?,
        );
        for p in ["principal_point_offset_x", "principal_point_offset_y"] {
            if o.float(p, 0.0)? != 0.0 {
                return Err(err(
                    &o.loc,
                    format!(
                        "{}: {p} other than 0 is not supported (tprf's principal point is the image centre)",
                        o.describe()
                    ),
                ));
            }
        }
        let m = o.transform("to_world")?;
        let mut camera = self.camera_from(o, &m, fov_rad)?;
        camera.fov_axis = fov_axis;
        camera.near_m = near_clip as f32;
        self.camera = Some(camera);
        Ok(())
    }

    /// The field of view, radians, and the axis it is measured along, as Mitsuba's
    /// `parse_fov` reads them: `fov` along `fov_axis` (x by default), or `focal_length`
    /// (50mm by default) on a 36 x 24 mm film's diagonal. The other axis follows from
    /// whatever film is rendered (`Camera::tan_half_fov`), as in Mitsuba.
    pub(super) fn fov(&self, o: &Object) -> Result<(f64, FovAxis), SceneError> {
        let (fov_deg, axis) = match (o.prop("fov").is_some(), o.prop("focal_length").is_some()) {
            (true, true) => {
                return Err(err(
                    &o.loc,
                    format!("{}: give fov or focal_length, not both", o.describe()),
                ));
            }
            (true, false) => {
                let name = o.string("fov_axis")?.unwrap_or("x").to_ascii_lowercase();
                let axis = match name.as_str() {
                    "x" => FovAxis::X,
                    "y" => FovAxis::Y,
                    "diagonal" => FovAxis::Diagonal,
                    "smaller" => FovAxis::Smaller,
                    "larger" => FovAxis::Larger,
                    other => {
                        return Err(err(
                            &o.loc,
                            format!(
                                "{}: fov_axis \"{other}\" is not one of x, y, diagonal, smaller, larger",
                                o.describe()
                            ),
                        ));
                    }
                };
                (o.float("fov", 0.0)?, axis)
            }
            (false, has_focal) => {
                let f = if has_focal {
                    o.string("focal_length")?.unwrap_or("50mm").to_string()
                } else {
                    "50mm".into()
                };
                let mm = super::xml::parse_f64(f.trim_end_matches("mm"))
                    .ok()
                    .filter(|v| *v > 0.0)
                    .ok_or_else(|| {
                        err(
                            &o.loc,
                            format!(
                                "{}: focal_length \"{f}\" is not of the form <x>mm",
                                o.describe()
                            ),
                        )
                    })?;
                (
                    (36.0f64.hypot(24.0) / (2.0 * mm)).atan().to_degrees() * 2.0,
                    FovAxis::Diagonal,
                )
            }
        };
        if !(fov_deg > 0.0 && fov_deg < 180.0) {
            return Err(err(
                &o.loc,
                format!(
                    "{}: a field of view of {fov_deg} degrees (it must be in (0, 180))",
                    o.describe()
                ),
            ));
        }
        Ok((fov_deg.to_radians(), axis))
    }

    /// tprf's camera (-Z forward, +Y up, +X right) from Mitsuba's `to_world` (+Z
    /// forward, +Y up, +X left), made orthonormal.
    fn camera_from(&mut self, o: &Object, m: &DMat4, fov_rad: f64) -> Result<Camera, SceneError> {
        let bad = || {
            err(
                &o.loc,
                format!(
                    "{}: to_world is not an invertible affine transform",
                    o.describe()
                ),
            )
        };
        if !(m.is_finite() && is_affine(m)) {
            return Err(bad());
        }
        let lin = DMat3::from_mat4(*m);
        let forward = (lin * DVec3::Z).try_normalize().ok_or_else(bad)?;
        let up_raw = lin * DVec3::Y;
        let up = (up_raw - up_raw.dot(forward) * forward)
            .try_normalize()
            .ok_or_else(bad)?;
        let left = up.cross(forward);
        let mirrored = lin.determinant() < 0.0;
        if mirrored {
            self.note_at(
                &o.loc,
                "the sensor's to_world mirrors the image: tprf renders it unmirrored".into(),
            );
        }
        let scaled = (lin.x_axis.length() - 1.0).abs() > 1e-3
            || (lin.y_axis.length() - 1.0).abs() > 1e-3
            || (lin.z_axis.length() - 1.0).abs() > 1e-3;
        if scaled || (lin * DVec3::X).normalize().dot(left).abs() < 0.999 && !mirrored {
            self.note_at(
                &o.loc,
                "the sensor's to_world scales or shears: its rotation is used".into(),
            );
        }
        let eye = m.transform_point3(DVec3::ZERO);
        let v = |d: DVec3| d.as_vec3();
        Ok(Camera {
            world_from_camera: Affine3A::from_cols(
                v(-left).into(),
                v(up).into(),
                v(-forward).into(),
                v(eye).into(),
            ),
            fov_rad: fov_rad as f32,
            fov_axis: FovAxis::X,
            near_m: NEAR_CLIP_DEFAULT as f32,
        })
    }

    /// The film: size and time window into the settings.
    fn read_film(&mut self, k: usize) -> Result<(), SceneError> {
        let f = self.object(k);
        match f.plugin.as_str() {
            "hdrfilm" | "transient_hdr_film" | "phasor_hdr_film" => {}
            _ => return Err(Builder::unsupported(f, "")),
        }
        let width = count(f, "width", DEFAULT_WIDTH)?;
        let height = count(f, "height", DEFAULT_HEIGHT)?;
        for name in [
            "crop_width",
            "crop_height",
            "crop_offset_x",
            "crop_offset_y",
        ] {
            if f.prop(name).is_some() {
                self.note_at(
                    &f.loc,
                    format!("<integer name=\"{name}\"> ignored: tprf renders the whole film"),
                );
            }
        }
        for quiet in [
            "pixel_format",
            "component_format",
            "file_format",
            "sample_border",
            "banner",
            "compensate",
        ] {
            let _ = f.prop(quiet);
        }
        let mut rfilter = None;
        for (p, c) in f.children() {
            p.used.set(true);
            let child = self.object(c);
            if child.tag == "rfilter" {
                rfilter = Some(child);
                for (q, _) in child.props.iter().map(|q| (q, ())) {
                    q.used.set(true);
                }
            } else {
                return Err(err(
                    &child.loc,
                    format!(
                        "{} inside {} is not supported",
                        child.describe(),
                        f.describe()
                    ),
                ));
            }
        }
        match rfilter {
            Some(r) if r.plugin == "box" => {}
            Some(r) => self.note_at(&r.loc, format!("<rfilter type=\"{}\"> read as box: a tprf pixel is the mean over its square", r.plugin)),
            None => self.note_at(&f.loc, format!("{} has no <rfilter>: Mitsuba's default gaussian filter read as box (a tprf pixel is the mean over its square)", f.describe())),
        }
        self.settings.width = Some(width);
        self.settings.height = Some(height);
        let phasor = f.plugin == "phasor_hdr_film";
        if phasor {
            self.read_phasor_band(f)?;
        }
        if f.plugin == "transient_hdr_film" || phasor {
            if f.boolean("exhaustive_scan", false)? {
                return Err(err(
                    &f.loc,
                    "exhaustive_scan (an NLOS capture) is not supported",
                ));
            }
            let _ = (
                f.integer("laser_scan_width", 0)?,
                f.integer("laser_scan_height", 0)?,
            );
            // mitransient's defaults: 2048 bins, and 4096 for the phasor film.
            let bins_default = if phasor { 4096 } else { 2048 };
            self.settings.bins = Some(count(f, "temporal_bins", bins_default)?);
            let opl = |name: &str, default: f64| -> Result<FileSetting<f64>, SceneError> {
                let v = f.float(name, default)?;
                Ok(FileSetting {
                    value: v,
                    from: origin(f, f.props.iter().find(|p| p.name == name)),
                })
            };
            let dt = opl("bin_width_opl", 0.003)?;
            if dt.value <= 0.0 {
                return Err(err(
                    &f.loc,
                    format!("bin_width_opl {} must be > 0", dt.value),
                ));
            }
            self.settings.dt_opl_m = Some(dt);
            self.settings.t0_opl_m = Some(opl("start_opl", 0.0)?);
        }
        Ok(())
    }

    /// mitransient's `phasor_hdr_film`: `wl_mean` (default 100) and `wl_sigma` (default
    /// 1000), metres of optical path, into the settings (the phasors a render writes).
    fn read_phasor_band(&mut self, f: &Object) -> Result<(), SceneError> {
        for (i, (name, default)) in [("wl_mean", 100.0), ("wl_sigma", 1000.0)]
            .into_iter()
            .enumerate()
        {
            let v = f.float(name, default)?;
            let p = f.props.iter().find(|p| p.name == name);
            if !(v.is_finite() && v > 0.0) {
                let loc = p.map_or(f.loc.clone(), |p| p.loc.clone());
                return Err(err(
                    &loc,
                    format!(
                        "{name} {v} of {} must be > 0 (a wavelength in metres of optical path)",
                        f.describe()
                    ),
                ));
            }
            let setting = Some(FileSetting {
                value: v,
                from: origin(f, p),
            });
            if i == 0 {
                self.settings.phasor_wl_mean_m = setting;
            } else {
                self.settings.phasor_wl_sigma_m = setting;
            }
        }
        Ok(())
    }

    /// The `<integrator>`: its depth into the settings.
    pub(super) fn read_integrator(&mut self, k: usize) -> Result<(), SceneError> {
        let o = self.object(k);
        if o.plugin == "stokes" {
            // Mitsuba's `stokes` wraps the integrator that renders: Stokes vectors of its
            // radiance (mitransient's polarized examples).
            let loc = o.loc.clone();
            let from = format!("{} {}", o.loc, o.describe());
            let inner = o
                .children()
                .find(|&(_, c)| self.object(c).tag == "integrator");
            let Some((p, c)) = inner else {
                return Err(err(
                    &loc,
                    "<integrator type=\"stokes\"> needs the integrator it wraps inside it",
                ));
            };
            p.used.set(true);
            self.settings.polarized = Some(FileSetting { value: true, from });
            return self.read_integrator(c);
        }
        let default_depth = match o.plugin.as_str() {
            "path" | "volpath" | "volpathmis" => -1,
            "transient_path" | "transient_prbvolpath" | "prb" | "prb_basic" | "prbvolpath" => 6,
            "direct" => 2,
            "transient_nlos_path" => return self.read_nlos_integrator(k),
            _ => {
                return Err(Builder::unsupported(
                    o,
                    "tprf's integrator is a path tracer (path, transient_path; stokes around one)",
                ));
            }
        };
        if o.plugin == "direct" {
            self.note_at(&o.loc, "<integrator type=\"direct\"> rendered as a path tracer with one bounce (max_depth 2)".into());
        }
        let (depth, at) = o.integer("max_depth", default_depth)?;
        let loc = at.map_or(o.loc.clone(), |p| p.loc.clone());
        match depth {
            -1 => {}
            0 => {
                return Err(err(
                    &loc,
                    "max_depth 0 renders nothing (1: emitters seen directly, 2: direct light, -1: every bounce)",
                ));
            }
            d if d < -1 => {
                return Err(err(
                    &loc,
                    format!("max_depth {d} must be -1 (every bounce) or at least 1"),
                ));
            }
            d => {
                let bounces = u32::try_from(d - 1).unwrap_or(u32::MAX);
                self.settings.max_bounces = Some(FileSetting {
                    value: bounces,
                    from: format!(
                        "{} (max_depth {d}: Mitsuba counts the camera segment, so {bounces} scattering events)",
                        origin(o, at)
                    ),
                });
            }
        }
        let _ = o.integer("rr_depth", 5)?;
        let _ = o.string("temporal_filter")?;
        if o.string("temporal_filter")? == Some("gaussian") {
            self.note_at(
                &o.loc,
                "temporal_filter \"gaussian\" read as box (mitransient 1.3 also bins with a box)"
                    .into(),
            );
        }
        let _ = o.float("gaussian_stddev", 0.0)?;
        let _ = o.integer("block_size", 0)?;
        let unwarp = o.prop("camera_unwarp");
        if o.boolean("camera_unwarp", false)? {
            self.settings.time_origin = Some(FileSetting {
                value: TimeOrigin::FirstHit,
                from: origin(o, unwarp),
            });
        }
        for name in ["discard_direct_light", "discard_direct_paths"] {
            if o.boolean(name, false)? {
                self.note_at(&o.loc, format!("{name} not applied: tprf records every bounce (--bounces-separate splits them)"));
            }
        }
        if o.boolean("hide_emitters", false)? {
            self.note_at(
                &o.loc,
                "hide_emitters not applied: tprf shows emitters seen directly".into(),
            );
        }
        Ok(())
    }
}
