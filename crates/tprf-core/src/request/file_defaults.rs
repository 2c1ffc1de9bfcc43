//! A scene file's render settings merged into a request, in one place: a Mitsuba
//! file's film (size, `temporal_bins`, `start_opl`, `bin_width_opl`), its sampler's
//! `sample_count`, its integrator's `max_depth`, `camera_unwarp` and NLOS origins, and
//! its `phasor_hdr_film`'s band ([`FileSettings`]) stand in for the request fields its
//! front end was not given. The command line, a batch manifest's job, Python and the
//! window all merge through [`RenderRequest::with_file_defaults`].

use super::RenderRequest;
use crate::export::phasor::PhasorBand;
use crate::scene::{FileSetting, FileSettings};
use std::fmt;

/// One request field a scene file set: the field (`max_bounces`) and what was taken,
/// from where (`4 (scene.xml:12 <integer name="max_depth">)`).
#[derive(Clone, Debug, PartialEq)]
pub struct FileNote {
    /// The request field (its serialised name, as `tprf render`'s option: `t0`).
    pub field: &'static str,
    /// The value taken and where the file says it.
    pub taken: String,
}

impl FileNote {
    /// The note with the field named by `name` (the command line's `--max-bounces`).
    pub fn text_with(&self, name: impl Fn(&str) -> String) -> String {
        format!("{} {}", name(self.field), self.taken)
    }
}

impl fmt::Display for FileNote {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.text_with(str::to_string))
    }
}

impl RenderRequest {
    /// Take each setting the scene file carries (`file`: [`crate::scene::file_settings`]
    /// or [`crate::scene::load_with_settings`]) into the field its front end was not
    /// given (`given(key)` false, keys as the request is serialised: `width`, `t0`,
    /// `max_bounces` ...); a field given keeps its value. Returns what was taken.
    ///
    /// - `width`, `height`, `bins`, `max_bounces`, `min_bounces`: the file's value (one too large for
    ///   the field saturates, and [`RenderRequest::validate`] refuses it by name);
    /// - `time_origin` and `pulse_origin` first, then `t0` for the time origin the
    ///   request ends with ([`FileSettings::t0_opl_m_for`]), and `dt`: metres of
    ///   optical path, `t = opl_m / c` seconds;
    /// - `spp`: only when nothing else ends the render (no `seconds`, `error_target` or
    ///   `until_stopped`);
    /// - `phasor`: the `phasor_hdr_film`'s `wl_mean:wl_sigma` when the file gives both;
    /// - `polarized`: true under a `stokes` integrator.
    pub fn with_file_defaults(
        &mut self,
        file: &FileSettings,
        given: impl Fn(&str) -> bool,
    ) -> Vec<FileNote> {
        let mut notes = Vec::new();
        let mut take = |field: &'static str, s: &Option<FileSetting<u64>>| {
            let s = s.as_ref().filter(|_| !given(field))?;
            notes.push(FileNote {
                field,
                taken: format!("{} ({})", s.value, s.from),
            });
            Some(s.value)
        };
        let size = |v: u64| usize::try_from(v).unwrap_or(usize::MAX);
        if let Some(v) = take("width", &file.width) {
            self.width = size(v);
        }
        if let Some(v) = take("height", &file.height) {
            self.height = size(v);
        }
        if let Some(v) = take("bins", &file.bins) {
            self.bins = size(v);
        }
        let ends_otherwise =
            self.seconds.is_some() || self.error_target.is_some() || self.until_stopped;
        if !ends_otherwise && let Some(v) = take("spp", &file.spp) {
            self.spp = Some(v);
        }
        let max_bounces = file.max_bounces.as_ref().map(|s| FileSetting {
            value: u64::from(s.value),
            from: s.from.clone(),
        });
        if let Some(v) = take("max_bounces", &max_bounces) {
            self.max_bounces = u32::try_from(v).unwrap_or(u32::MAX);
        }
        let min_bounces = file.min_bounces.as_ref().map(|s| FileSetting {
            value: u64::from(s.value),
            from: s.from.clone(),
        });
        if let Some(v) = take("min_bounces", &min_bounces) {
            self.min_bounces = u32::try_from(v).unwrap_or(u32::MAX);
        }
        if let Some(s) = file.time_origin.as_ref().filter(|_| !given("time_origin")) {
            notes.push(FileNote {
                field: "time_origin",
                taken: format!("{} ({})", s.value, s.from),
            });
            self.time_origin = s.value;
        }
        if let Some(s) = file
            .pulse_origin
            .as_ref()
            .filter(|_| !given("pulse_origin"))
        {
            notes.push(FileNote {
                field: "pulse_origin",
                taken: format!("{} ({})", s.value, s.from),
            });
            self.pulse_origin = s.value;
        }
        let mut opl = |field: &'static str, s: Option<FileSetting<f64>>| {
            let s = s.filter(|_| !given(field))?;
            notes.push(FileNote {
                field,
                taken: format!("{}m of optical path ({})", s.value, s.from),
            });
            Some(s.value / crate::units::C_M_PER_S)
        };
        if let Some(t0_s) = opl("t0", file.t0_opl_m_for(self.time_origin)) {
            self.t0_s = Some(t0_s);
        }
        if let Some(dt_s) = opl("dt", file.dt_opl_m.clone()) {
            self.dt_s = Some(dt_s);
        }
        if let Some(s) = file.polarized.as_ref().filter(|_| !given("polarized")) {
            notes.push(FileNote {
                field: "polarized",
                taken: format!("{} ({})", s.value, s.from),
            });
            self.polarized = s.value;
        }
        if !given("phasor")
            && let (Some(mean), Some(sigma)) = (&file.phasor_wl_mean_m, &file.phasor_wl_sigma_m)
        {
            notes.push(FileNote {
                field: "phasor",
                taken: format!(
                    "{}:{} (wl_mean {}, wl_sigma {})",
                    mean.value, sigma.value, mean.from, sigma.from
                ),
            });
            self.phasor = Some(PhasorBand {
                wl_mean_m: mean.value,
                wl_sigma_m: sigma.value,
            });
        }
        notes
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{PulseOrigin, TimeOrigin};
    use crate::units::C_M_PER_S;

    fn set<T>(value: T, from: &str) -> Option<FileSetting<T>> {
        Some(FileSetting {
            value,
            from: from.into(),
        })
    }

    /// A file as mitransient's examples write one: a film of 40 x 30 pixels and 300
    /// bins from 1.5 m of optical path (a near clip of 0.25 m) in bins of 0.01 m,
    /// 16 samples, depth 4, first-hit origins and a phasor band.
    fn file() -> FileSettings {
        FileSettings {
            width: set(40, "w"),
            height: set(30, "h"),
            bins: set(300, "b"),
            t0_opl_m: set(1.5, "start_opl"),
            near_clip_m: set(0.25, "near_clip"),
            dt_opl_m: set(0.01, "bin_width_opl"),
            spp: set(16, "sample_count"),
            max_bounces: set(4, "max_depth"),
            phasor_wl_mean_m: set(100.0, "wl_mean"),
            phasor_wl_sigma_m: set(50.0, "wl_sigma"),
            ..FileSettings::default()
        }
    }

    /// Nothing given: every setting taken, times as optical path over c, the window
    /// moved by the near clip from the pinhole; each named in a note.
    #[test]
    fn a_file_fills_what_was_not_given() {
        let mut r = RenderRequest::new("x.xml");
        let notes = r.with_file_defaults(&file(), |_| false);
        assert_eq!((r.width, r.height, r.bins), (40, 30, 300));
        assert_eq!((r.spp, r.max_bounces), (Some(16), 4));
        assert_eq!(r.t0_s, Some((1.5 + 0.25) / C_M_PER_S));
        assert_eq!(r.dt_s, Some(0.01 / C_M_PER_S));
        assert_eq!(
            r.phasor,
            Some(PhasorBand {
                wl_mean_m: 100.0,
                wl_sigma_m: 50.0
            })
        );
        let fields: Vec<_> = notes.iter().map(|n| n.field).collect();
        assert_eq!(
            fields,
            [
                "width",
                "height",
                "bins",
                "spp",
                "max_bounces",
                "t0",
                "dt",
                "phasor"
            ]
        );
        assert_eq!(notes[0].to_string(), "width 40 (w)");
        assert_eq!(
            notes[6].text_with(|f| format!("--{f}")),
            "--dt 0.01m of optical path (bin_width_opl)"
        );
    }

    /// A field given keeps its value (even the default's), and a given time origin
    /// decides where the file's window starts.
    #[test]
    fn what_was_given_wins() {
        let mut r = RenderRequest {
            time_origin: TimeOrigin::NearPlane,
            ..RenderRequest::new("x.xml")
        };
        let given = ["width", "spp", "time_origin", "phasor"];
        let mut f = file();
        f.time_origin = set(TimeOrigin::FirstHit, "camera_unwarp");
        f.pulse_origin = set(PulseOrigin::FirstHit, "account");
        let notes = r.with_file_defaults(&f, |k| given.contains(&k));
        assert_eq!((r.width, r.height, r.spp, r.phasor), (256, 30, None, None));
        assert_eq!(r.time_origin, TimeOrigin::NearPlane);
        assert_eq!(r.pulse_origin, PulseOrigin::FirstHit);
        // From the near plane, the file's start_opl as it is.
        assert_eq!(r.t0_s, Some(1.5 / C_M_PER_S));
        assert!(notes.iter().all(|n| !given.contains(&n.field)));
    }

    /// The file's sample count does not replace another end of the render.
    #[test]
    fn spp_only_when_nothing_else_ends_the_render() {
        for r in [
            RenderRequest {
                seconds: Some(1.0),
                ..RenderRequest::new("x.xml")
            },
            RenderRequest {
                error_target: Some(0.01),
                ..RenderRequest::new("x.xml")
            },
            RenderRequest {
                until_stopped: true,
                ..RenderRequest::new("x.xml")
            },
        ] {
            let mut r = r;
            let notes = r.with_file_defaults(&file(), |_| false);
            assert_eq!(r.spp, None);
            assert!(notes.iter().all(|n| n.field != "spp"));
        }
    }

    /// No settings (a glTF or built-in scene): the request unchanged.
    #[test]
    fn no_file_settings_change_nothing() {
        let mut r = RenderRequest::new("builtin:cornell");
        let before = r.clone();
        assert!(
            r.with_file_defaults(&FileSettings::default(), |_| false)
                .is_empty()
        );
        assert_eq!(r, before);
    }
}
