//! mitransient's NLOS scenes (as tal writes them, `tal/render/mitsuba3_transient_nlos.py`),
//! read into [`NlosFileSettings`] for `tprf nlos`:
//!
//! - the relay wall is the shape holding a `<sensor type="nlos_capture_meter">`: its
//!   `id` names the wall (`relay_wall` without one); the meter's film gives the scan grid
//!   (`width` x `height`, or `original_film_width/height` beside a 1 x 1 film for a
//!   confocal scan) and the time axis (`temporal_bins`, `bin_width_opl`, `start_opl`:
//!   mitransient counts an NLOS path's length from the wall, no near plane), its sampler
//!   the samples per sensor point, `sensor_origin` the SPAD's position;
//! - `<integrator type="transient_nlos_path">`: `capture_type` (single, confocal,
//!   exhaustive: the laser grid the sensor grid, as its `force_equal_illumination_scanning`
//!   default; without it, confocal where the meter has `original_film_width/height`, as
//!   tal writes a confocal scan, else single), `account_first_and_last_bounces` (the
//!   device legs; mitransient's default false; tal writes it on the meter), `max_depth` (it counts the sensor's segment and the two wall vertices:
//!   `max_depth - 3` scattering events in the hidden scene; -1 every one); its sampling
//!   switches (laser sampling, hidden-geometry sampling, filters) are noted, since
//!   `tprf nlos` samples the hidden geometry from each wall point itself;
//! - `<emitter type="projector">`: a light of the scene (for `tprf render`), and the
//!   laser device at its `to_world` translation for `tprf nlos` (which models the laser
//!   itself). Where it points is set per scan point by tal's Python, not by the file: a
//!   single scan's laser point is the wall's centre unless `--laser-point` gives it, or
//!   an older file's meter does (`laser_origin`, `laser_lookat_pixel`, `confocal`);
//! - the same integrator watched by a perspective camera (no capture meter): a scene for
//!   `tprf render`, its legs left out as the integrator's (`settle_camera_nlos`).

use super::xml::Color;
use super::xml::{Object, err};
use super::{Builder, SceneError};
use crate::scene::{
    FileSetting, NlosFileSettings, Projector, PulseOrigin, PunctualLight, TimeOrigin,
};
use glam::DVec3;
use std::sync::Arc;

/// Where a property of `o` was read, or the object whose default it is.
fn from(o: &Object, name: &str) -> String {
    match o.prop(name) {
        Some(p) => format!("{} <{} name=\"{}\">", p.loc, p.value.tag(), p.name),
        None => format!("{} {} (mitransient's default)", o.loc, o.describe()),
    }
}

/// The area, m^2, of the spot projector `light` lights on the nearest of `scene`'s
/// triangles its axis meets: its frustum's cross-section `4 tan_x tan_y D^2` at the
/// distance `D` of the hit, over the cosine of incidence (the frustum small against
/// the surface's curvature). mitransient's `transient_nlos_path` joins paths to the
/// spot as to a point of unit area, so its cube is tprf's divided by this.
pub(super) fn spot_area_m2(scene: &crate::scene::Scene, light: &PunctualLight) -> Option<f64> {
    let p = light.projector.as_ref()?;
    let (o, d) = (light.position.as_dvec3(), p.direction.as_dvec3());
    let mut best: Option<(f64, DVec3)> = None;
    for t in &scene.triangles {
        let [a, b, c] = t.p.map(|v| v.as_dvec3());
        let (e1, e2) = (b - a, c - a);
        let h = d.cross(e2);
        let det = e1.dot(h);
        if det.abs() < 1e-15 {
            continue;
        }
        let s = o - a;
        let u = s.dot(h) / det;
        let q = s.cross(e1);
        let v = d.dot(q) / det;
        let dist = e2.dot(q) / det;
        if u >= 0.0 && v >= 0.0 && u + v <= 1.0 && dist > 0.0 && best.is_none_or(|(b, _)| dist < b)
        {
            best = Some((dist, e1.cross(e2).normalize()));
        }
    }
    let (dist, n) = best?;
    let cos = n.dot(d).abs();
    (cos > 1e-6)
        .then(|| 4.0 * f64::from(p.tan_half_x) * f64::from(p.tan_half_y) * dist * dist / cos)
}

impl Builder<'_> {
    /// The file's NLOS capture settings, made where there were none.
    pub(super) fn nlos(&mut self) -> &mut NlosFileSettings {
        self.settings.nlos.get_or_insert_with(Default::default)
    }

    /// The `<sensor type="nlos_capture_meter">` `k` of the relay wall shape named `wall`
    /// (`rectangle`: its `to_world` when the wall is a Mitsuba `rectangle`).
    ///
    /// Older mitransient files (`examples/transient-nlos/nlos_Z.xml`) put the laser on
    /// the meter: `laser_origin` (the device), `laser_lookat_pixel` (the film pixel
    /// `(x, y)` it aims at: on a rectangle the point `(2 (x + 0.5) / W - 1, 2 (y + 0.5) /
    /// H - 1, 0)` of its square, as the meter samples its pixels) and `confocal`; they
    /// are read as the file means them (the integrator's `capture_type` wins).
    pub(super) fn read_capture_meter(
        &mut self,
        k: usize,
        wall: &str,
        wall_from: String,
        rectangle: Option<glam::DMat4>,
    ) -> Result<(), SceneError> {
        let o = self.object(k);
        if self
            .settings
            .nlos
            .as_ref()
            .is_some_and(|n| n.relay_wall.is_some())
        {
            return Err(err(
                &o.loc,
                "a second nlos_capture_meter: tprf captures one relay wall",
            ));
        }
        let mut grid = None;
        let (w, wp) = o.integer("original_film_width", 0)?;
        let (h, hp) = o.integer("original_film_height", 0)?;
        if wp.is_some() || hp.is_some() {
            if w < 1 || h < 1 {
                return Err(err(
                    &o.loc,
                    format!(
                        "original_film_width {w} and original_film_height {h} must be at least 1"
                    ),
                ));
            }
            grid = Some(FileSetting {
                value: [w as u64, h as u64],
                from: from(o, "original_film_width"),
            });
        }
        // tal writes it here (mitransient 1.3 reads it from the integrator, which wins);
        // absent from both, mitransient's default, false.
        let legs = o.boolean("account_first_and_last_bounces", false)?;
        let legs_from = from(o, "account_first_and_last_bounces");
        self.nlos().device_legs.get_or_insert(FileSetting {
            value: legs,
            from: legs_from,
        });
        if let Some(p) = o.vector("sensor_origin")? {
            self.nlos().sensor_origin = Some(FileSetting {
                value: p,
                from: from(o, "sensor_origin"),
            });
        }
        let _ = o.prop("laser_bounce_opl");
        if let Some(p) = o.vector("laser_origin")? {
            self.nlos().laser_origin = Some(FileSetting {
                value: p,
                from: from(o, "laser_origin"),
            });
        }
        let look_at_pixel = o.vector("laser_lookat_pixel")?;
        if o.prop("confocal").is_some() {
            let confocal = o.boolean("confocal", false)?;
            self.nlos().capture_type.get_or_insert(FileSetting {
                value: if confocal { "confocal" } else { "single" }.into(),
                from: from(o, "confocal"),
            });
        }
        for (p, c) in o.children() {
            p.used.set(true);
            let child = self.object(c);
            match child.tag {
                "sampler" => {
                    let (spp, at) = child.integer("sample_count", 4)?;
                    if spp < 1 {
                        return Err(err(
                            &child.loc,
                            format!("sample_count {spp} must be at least 1"),
                        ));
                    }
                    let _ = child.integer("seed", 0)?;
                    self.nlos().spp = Some(FileSetting {
                        value: spp as u64,
                        from: at.map_or_else(
                            || from(child, "sample_count"),
                            |p| format!("{} <integer name=\"sample_count\">", p.loc),
                        ),
                    });
                }
                "film" if child.plugin == "transient_hdr_film" => {
                    let (fw, _) = child.integer("width", 1)?;
                    let (fh, _) = child.integer("height", 1)?;
                    if grid.is_none() {
                        if fw < 1 || fh < 1 {
                            return Err(err(
                                &child.loc,
                                format!(
                                    "the capture meter's film {fw} x {fh} must be at least 1 x 1"
                                ),
                            ));
                        }
                        grid = Some(FileSetting {
                            value: [fw as u64, fh as u64],
                            from: from(child, "width"),
                        });
                    }
                    let (bins, bp) = child.integer("temporal_bins", 2048)?;
                    if bins < 1 {
                        return Err(err(
                            &child.loc,
                            format!("temporal_bins {bins} must be at least 1"),
                        ));
                    }
                    let dt = child.float("bin_width_opl", 0.003)?;
                    if !(dt > 0.0 && dt.is_finite()) {
                        return Err(err(&child.loc, format!("bin_width_opl {dt} must be > 0")));
                    }
                    let t0 = child.float("start_opl", 0.0)?;
                    let n = self.nlos();
                    n.bins = Some(FileSetting {
                        value: bins as u64,
                        from: bp.map_or_else(
                            || from(child, "temporal_bins"),
                            |p| format!("{} <integer name=\"temporal_bins\">", p.loc),
                        ),
                    });
                    n.dt_opl_m = Some(FileSetting {
                        value: dt,
                        from: from(child, "bin_width_opl"),
                    });
                    n.t0_opl_m = Some(FileSetting {
                        value: t0,
                        from: from(child, "start_opl"),
                    });
                    for quiet in ["auto_detect_bins", "pixel_format", "component_format"] {
                        let _ = child.prop(quiet);
                    }
                    for (q, _) in child.children() {
                        q.used.set(true);
                    }
                }
                "film" => {
                    return Err(Builder::unsupported(
                        child,
                        "an NLOS capture is read from a transient_hdr_film",
                    ));
                }
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
        if let Some(px) = look_at_pixel {
            let at = from(o, "laser_lookat_pixel");
            let (Some(m), Some(g)) = (rectangle, &grid) else {
                return Err(err(
                    &o.loc,
                    format!(
                        "laser_lookat_pixel on a relay wall that is not a <shape type=\"rectangle\">: aim the laser with tprf nlos --laser-point X,Y,Z ({at})"
                    ),
                ));
            };
            let [w, h] = g.value.map(|v| v as f64);
            let local = DVec3::new(
                2.0 * (px[0] + 0.5) / w - 1.0,
                2.0 * (px[1] + 0.5) / h - 1.0,
                0.0,
            );
            if !(local.x.abs() <= 1.0 && local.y.abs() <= 1.0) {
                return Err(err(
                    &o.loc,
                    format!(
                        "laser_lookat_pixel ({}, {}) is outside the {w} x {h} film ({at})",
                        px[0], px[1]
                    ),
                ));
            }
            self.nlos().laser_point = Some(FileSetting {
                value: m.transform_point3(local).to_array(),
                from: at,
            });
        }
        let n = self.nlos();
        // A confocal scan is a 1 x 1 film with the grid beside it (as tal writes it; the
        // integrator's capture_type, where given, wins).
        if let Some(g) = grid
            .as_ref()
            .filter(|g| g.from.contains("original_film_width"))
        {
            n.capture_type.get_or_insert(FileSetting {
                value: "confocal".into(),
                from: g.from.clone(),
            });
        }
        n.grid = grid;
        n.relay_wall = Some(FileSetting {
            value: wall.to_string(),
            from: wall_from,
        });
        Ok(())
    }

    /// `<integrator type="transient_nlos_path">`.
    pub(super) fn read_nlos_integrator(&mut self, k: usize) -> Result<(), SceneError> {
        let o = self.object(k);
        let kind = match o.prop("capture_type") {
            None => None,
            Some(p) => Some(match o.string("capture_type") {
                Ok(Some(s)) => s.to_ascii_lowercase(),
                // mitransient's CaptureType: Single = 1, Confocal = 2, Exhaustive = 3.
                _ => match o.integer("capture_type", 0)? {
                    (1, _) => "single".into(),
                    (2, _) => "confocal".into(),
                    (3, _) => "exhaustive".into(),
                    (v, _) => {
                        return Err(err(
                            &p.loc,
                            format!(
                                "capture_type {v}: mitransient's are 1 (single), 2 (confocal), 3 (exhaustive)"
                            ),
                        ));
                    }
                },
            }),
        };
        if let Some(kind) = &kind
            && !["single", "confocal", "exhaustive"].contains(&kind.as_str())
        {
            return Err(err(
                &o.loc,
                format!(
                    "capture_type \"{kind}\": mitransient's are single, confocal and exhaustive"
                ),
            ));
        }
        let kind_from = from(o, "capture_type");
        let legs = match o.prop("account_first_and_last_bounces") {
            Some(_) => Some(FileSetting {
                value: o.boolean("account_first_and_last_bounces", false)?,
                from: from(o, "account_first_and_last_bounces"),
            }),
            None => None,
        };
        let depth_filter = match (o.prop("filter_depth"), o.prop("filter_bounces")) {
            (Some(_), Some(p)) => {
                return Err(err(
                    &p.loc,
                    "filter_depth and filter_bounces both set: give only one (mitransient refuses both too)".to_string(),
                ));
            }
            (Some(_), None) => match o.integer("filter_depth", -1)? {
                (-1, _) => None,
                (d, Some(p)) if d < 1 => {
                    return Err(err(
                        &p.loc,
                        format!("filter_depth {d}: must be 1 or more, or -1"),
                    ));
                }
                (d, _) => Some(FileSetting {
                    value: d as u32,
                    from: from(o, "filter_depth"),
                }),
            },
            (None, Some(_)) => match o.integer("filter_bounces", -1)? {
                (-1, _) => None,
                (b, Some(p)) if b < 0 => {
                    return Err(err(
                        &p.loc,
                        format!("filter_bounces {b}: must be 0 or more, or -1"),
                    ));
                }
                (b, _) => Some(FileSetting {
                    value: b as u32 + 1,
                    from: format!(
                        "{} + 1 (mitransient's filter_depth)",
                        from(o, "filter_bounces")
                    ),
                }),
            },
            (None, None) => None,
        };
        let discard_direct = match o.prop("discard_direct_paths") {
            Some(_) => Some(FileSetting {
                value: o.boolean("discard_direct_paths", false)?,
                from: from(o, "discard_direct_paths"),
            }),
            None => None,
        };
        let _ = o.integer("block_size", 0)?;
        let (depth, dp) = o.integer("max_depth", -1)?;
        let hidden = match depth {
            -1 => None,
            d if d >= 4 => Some(FileSetting { value: u32::try_from(d - 3).unwrap_or(u32::MAX), from: dp.map_or_else(|| from(o, "max_depth"), |p| format!("{} <integer name=\"max_depth\"> - 3 (the sensor's segment and the two wall vertices)", p.loc)) }),
            d => return Err(err(&o.loc, format!("max_depth {d}: an NLOS path needs at least 4 (sensor, wall, hidden surface, wall), or -1"))),
        };
        let mut hints = Vec::new();
        for name in [
            "nlos_laser_sampling",
            "nlos_hidden_geometry_sampling",
            "nlos_hidden_geometry_sampling_do_rroulette",
            "nlos_hidden_geometry_sampling_includes_relay_wall",
            "nlos_hidden_geometry_sampling_max_depth",
            "force_equal_illumination_scanning",
            "illumination_scan_fov",
            "rr_depth",
            "temporal_filter",
            "gaussian_stddev",
            "camera_unwarp",
        ] {
            if o.prop(name).is_some() {
                hints.push(name);
            }
        }
        if !hints.is_empty() {
            self.note_at(&o.loc, format!("<integrator type=\"transient_nlos_path\">: {} not applied: tprf samples the hidden scene its own way (tprf nlos from each wall point, tprf render by joining every path vertex to the laser's spot) and records every path its settings allow", hints.join(", ")));
        }
        let n = self.nlos();
        if let Some(kind) = kind {
            n.capture_type = Some(FileSetting {
                value: kind,
                from: kind_from,
            });
        }
        if legs.is_some() {
            n.device_legs = legs;
        }
        n.hidden_bounces = hidden;
        n.depth_filter = depth_filter;
        n.discard_direct = discard_direct;
        Ok(())
    }

    /// mitransient's NLOS integrator watched through a perspective camera (no capture
    /// meter in the file, as `examples/transient-nlos/nlos-z-simple.xml`): a scene
    /// `tprf render` renders like any other, its projector a light, the legs the
    /// integrator leaves out (`account_first_and_last_bounces` false, mitransient's
    /// default) left out here too: the camera's (`TimeOrigin::FirstHit`) and the
    /// projector's (`PulseOrigin::FirstHit`). The depth is `max_depth - 1` scattering
    /// events, as for `transient_path`. The NLOS capture settings are dropped: the file
    /// is not a `tprf nlos` scene.
    /// Returns whether the file was such a scene.
    pub(super) fn settle_camera_nlos(&mut self) -> bool {
        let has_meter = self
            .parsed
            .objects
            .iter()
            .any(|o| o.tag == "sensor" && o.plugin == "nlos_capture_meter");
        if has_meter || self.camera.is_none() {
            if let Some(n) = &self.settings.nlos {
                let mut unused: Vec<&str> = Vec::new();
                if let Some(d) = &n.depth_filter {
                    unused.push(&d.from);
                }
                if let Some(d) = n.discard_direct.as_ref().filter(|d| d.value) {
                    unused.push(&d.from);
                }
                if !unused.is_empty() {
                    let what = format!(
                        "{}: not applied by tprf nlos, whose capture records every path of up to --max-bounces hidden bounces (tprf render applies them to a camera's view)",
                        unused.join(", ")
                    );
                    self.notes.push(what);
                }
            }
            return false;
        }
        let Some(n) = self.settings.nlos.take() else {
            return false;
        };
        self.settings.nlos_view = true;
        let counted = n.device_legs.as_ref().is_some_and(|l| l.value);
        if !counted {
            let from = n.device_legs.map_or_else(
                || "<integrator type=\"transient_nlos_path\"> (mitransient's default account_first_and_last_bounces false)".to_string(),
                |l| format!("{} false", l.from),
            );
            self.settings.time_origin = Some(FileSetting {
                value: TimeOrigin::FirstHit,
                from: from.clone(),
            });
            self.settings.pulse_origin = Some(FileSetting {
                value: PulseOrigin::FirstHit,
                from,
            });
        }
        if let Some(h) = n.hidden_bounces {
            self.settings.max_bounces = Some(FileSetting {
                value: h.value.saturating_add(2),
                from: format!("{} (max_depth - 1 for a camera's view)", h.from),
            });
        }
        // mitransient's depth at its laser-sampled next-event estimate counts the wall
        // point, each hidden vertex and the laser's spot: tprf's scattering events.
        if let Some(d) = n.depth_filter {
            self.settings.min_bounces = Some(d.clone());
            self.settings.max_bounces = Some(d);
        } else if let Some(d) = n.discard_direct.filter(|d| d.value) {
            self.settings.min_bounces = Some(FileSetting {
                value: 3,
                from: format!(
                    "{} true (only paths through the hidden scene: mitransient's depth > 2)",
                    d.from
                ),
            });
        }
        self.notes.push(format!(
            "{}: mitransient's transient_nlos_path watched by a camera: rendered as any scene, the projector a light, {}",
            self.file,
            if counted {
                "every leg counted (account_first_and_last_bounces true)"
            } else {
                "the camera's and the projector's legs left out of the times, as mitransient (--time-origin first-hit --pulse-origin first-hit)"
            }
        ));
        true
    }

    /// `<emitter type="projector">`: a light of the scene (Mitsuba's projector: `fov`
    /// along `fov_axis` of a square image for a constant `irradiance`, times `scale`,
    /// `to_world` +Z its axis and +Y its up), and the NLOS laser's device position.
    ///
    /// Mitsuba's projector lights a plane across its axis at distance `D` with the same
    /// irradiance `pi E scale / D^2` everywhere inside the frustum (measured with
    /// Mitsuba 3.9.1: a white diffuse plane 1 m away shows radiance `E`): tprf's
    /// projector of on-axis intensity `pi E scale` W/sr.
    pub(super) fn read_projector(&mut self, k: usize) -> Result<(), SceneError> {
        let o = self.object(k);
        let to_world = o.transform("to_world")?;
        let p = to_world.transform_point3(DVec3::ZERO);
        let bad_frame = || {
            err(
                &o.loc,
                format!(
                    "{}: to_world is not an invertible affine transform",
                    o.describe()
                ),
            )
        };
        let z = to_world
            .transform_vector3(DVec3::Z)
            .try_normalize()
            .ok_or_else(bad_frame)?;
        let y_raw = to_world.transform_vector3(DVec3::Y);
        let y = (y_raw - y_raw.dot(z) * z)
            .try_normalize()
            .ok_or_else(bad_frame)?;
        if !(p.is_finite() && z.is_finite()) {
            return Err(bad_frame());
        }
        let image = match o.color("irradiance", None)? {
            Some(Color::Texture(t)) if self.object(t).plugin == "bitmap" => {
                Some(Arc::new(self.irradiance_image(t)?))
            }
            _ => None,
        };
        let irradiance = match &image {
            Some(_) => [1.0; 3],
            None => self.quantity(o, "irradiance")?,
        };
        let scale = o.float("scale", 1.0)?;
        if !(scale.is_finite() && scale >= 0.0) {
            return Err(err(
                &o.loc,
                format!("{}: scale {scale} must be finite and >= 0", o.describe()),
            ));
        }
        // The image's aspect shapes the frustum (a constant irradiance is a 1 x 1 image:
        // square); `fov` along `fov_axis` (or `focal_length`) as a perspective camera's.
        let (fov_rad, axis) = self.fov(o)?;
        let aspect = image
            .as_ref()
            .map_or(1.0, |im| im.width as f32 / im.height as f32);
        let (tan_half_x, tan_half_y) = axis.tan_halves((0.5 * fov_rad as f32).tan(), aspect);
        let intensity = irradiance.map(|e| (std::f64::consts::PI * e * scale) as f32);
        self.lights.push(PunctualLight {
            name: o.id.clone().unwrap_or_else(|| "projector".into()),
            position: p.as_vec3(),
            intensity_w_per_sr: intensity,
            spot: None,
            projector: Some(Projector {
                direction: z.as_vec3(),
                up: y.as_vec3(),
                tan_half_x,
                tan_half_y,
                image,
            }),
        });
        self.projector_origin = Some(FileSetting {
            value: p.to_array(),
            from: format!("{} {} to_world", o.loc, o.describe()),
        });
        Ok(())
    }
}
