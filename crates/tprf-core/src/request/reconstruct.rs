//! One reconstruction of a hidden scene, described once: [`ReconstructRequest`] is what
//! `tprf nlos reconstruct CAPTURE` does, as data (the capture, the method, the voxel
//! volume, the phasor-field wavelength, the threads), serialised with its option names,
//! which are also the keys of a batch manifest's `[[reconstruct]]` jobs and Python's
//! `tprf.nlos.reconstruct` keywords. The volume is one [`VolumeSpec`] (centre, size,
//! voxels) whether typed as `--volume CX,CY,CZ:SX,SY,SZ:NX,NY,NZ`, as a manifest's table
//! or in the window's three fields ([`VolumeSpec::from_parts`]).
//! [`ReconstructRequest::run_on`] reconstructs a capture in memory,
//! [`ReconstructRequest::run`] the one its `capture` names, and
//! [`ReconstructRequest::write_folder`] writes `volume.npy`, `volume.json` (which embeds
//! the request) and the max-intensity projections.

use super::{Problem, from_text};
use crate::nlos::NlosError;
use crate::nlos::files::{LoadedCapture, read_capture, write_reconstruction_folder_with};
use crate::nlos::reconstruct::{GridFrame, Method, Reconstruction, Volume, Wave, reconstruct};
use crate::units::C_M_PER_S;
use serde::{Deserialize, Deserializer, Serialize};
use std::path::{Path, PathBuf};

/// A reconstruction: `tprf nlos reconstruct`'s options as data (a field left out takes
/// its default).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ReconstructRequest {
    /// The capture: a `tprf nlos` output folder, or an HDF5 file in tal's format (Python:
    /// or a capture in memory, [`ReconstructRequest::run_on`]).
    pub capture: PathBuf,
    /// `bp` (back-projection), `fbp` (filtered back-projection: the default), `fk`
    /// (f-k migration, confocal captures) or `pf` (phasor fields).
    #[serde(deserialize_with = "from_text")]
    pub method: Method,
    /// The voxel volume (unset: the sensor grid's extent and lattice, from the wall to
    /// the farthest depth the time axis reaches: [`Volume::default_for`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub volume: Option<VolumeSpec>,
    /// Central wavelength of the phasor-field kernel (fbp, pf), metres (`wavelength`: a
    /// number of metres, or text with a length unit, `"5cm"`); unset: four grid spacings.
    /// Its Gaussian's sigma is it over sqrt(2).
    #[serde(
        rename = "wavelength",
        deserialize_with = "length_m",
        skip_serializing_if = "Option::is_none"
    )]
    pub wavelength_m: Option<f64>,
    /// Worker threads (unset: one per core).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub threads: Option<usize>,
}

impl Default for ReconstructRequest {
    fn default() -> Self {
        ReconstructRequest {
            capture: PathBuf::new(),
            method: Method::Fbp,
            volume: None,
            wavelength_m: None,
            threads: None,
        }
    }
}

/// A voxel volume as asked for: centre (world, metres), size along the wall's `u`, `v`
/// and normal `n` (metres), voxels along them. Read from a table of the three, or from
/// the command line's text `CX,CY,CZ:SX,SY,SZ:NX,NY,NZ`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct VolumeSpec {
    pub center: [f32; 3],
    pub size: [f32; 3],
    pub voxels: [usize; 3],
}

/// The table form of a [`VolumeSpec`].
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct VolumeTable {
    center: [f32; 3],
    size: [f32; 3],
    voxels: [usize; 3],
}

impl<'de> Deserialize<'de> for VolumeSpec {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<VolumeSpec, D::Error> {
        #[derive(Deserialize)]
        #[serde(untagged)]
        enum Form {
            Text(String),
            Table(VolumeTable),
        }
        match Form::deserialize(d)? {
            Form::Text(t) => t.parse().map_err(serde::de::Error::custom),
            Form::Table(t) => Ok(VolumeSpec {
                center: t.center,
                size: t.size,
                voxels: t.voxels,
            }),
        }
    }
}

impl std::str::FromStr for VolumeSpec {
    type Err = String;

    /// `CX,CY,CZ:SX,SY,SZ:NX,NY,NZ`; the error says which part is wrong.
    fn from_str(text: &str) -> Result<VolumeSpec, String> {
        let parts: Vec<&str> = text.split(':').collect();
        let [c, s, n] = parts.as_slice() else {
            return Err(format!(
                "'{text}': expected CX,CY,CZ:SX,SY,SZ:NX,NY,NZ (centre, size, voxels)"
            ));
        };
        VolumeSpec::from_parts(c, s, n)
    }
}

impl std::fmt::Display for VolumeSpec {
    /// The command line's form, which its `FromStr` reads back.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let [cx, cy, cz] = self.center;
        let [sx, sy, sz] = self.size;
        let [nx, ny, nz] = self.voxels;
        write!(f, "{cx},{cy},{cz}:{sx},{sy},{sz}:{nx},{ny},{nz}")
    }
}

impl VolumeSpec {
    /// The volume of three texts, each three numbers separated by commas or spaces:
    /// the centre, the size and the voxels (the window's three fields, the command
    /// line's three parts). The error names the part and what to type
    /// (`centre '0, 0': type three numbers, x, y, z in metres`).
    pub fn from_parts(center: &str, size: &str, voxels: &str) -> Result<VolumeSpec, String> {
        Ok(VolumeSpec {
            center: triple(center, "centre", "x, y, z in metres")?,
            size: triple(size, "size", "along u, v, n in metres")?,
            voxels: triple(voxels, "voxels", "whole numbers along u, v, n")?,
        })
    }

    /// The spec of a volume (its centre, size and voxels).
    pub fn of(v: &Volume) -> VolumeSpec {
        VolumeSpec {
            center: v.center,
            size: v.size_m,
            voxels: v.voxels,
        }
    }

    /// The volume in the wall's frame `frame` ([`Volume::new`]: refused when empty,
    /// too large, or reaching the wall's plane or behind it).
    pub fn volume_in(&self, frame: &GridFrame) -> Result<Volume, NlosError> {
        Volume::new(frame, glam::Vec3::from(self.center), self.size, self.voxels)
    }
}

/// Three values separated by commas or spaces; the error names `what`.
fn triple<T: std::str::FromStr>(text: &str, what: &str, hint: &str) -> Result<[T; 3], String> {
    let bad = || format!("{what} '{}': type three numbers, {hint}", text.trim());
    let v: Vec<T> = text
        .split(|c: char| c == ',' || c.is_whitespace())
        .filter(|s| !s.is_empty())
        .map(|s| s.parse::<T>())
        .collect::<Result<_, _>>()
        .map_err(|_| bad())?;
    v.try_into().map_err(|_| bad())
}

/// A length: a number of metres, or text with a unit of length (or of time, as optical
/// path: `c t`); `"5cm"` is `parse_time_s("5cm") c` metres, as the command line reads it.
fn length_m<'de, D: Deserializer<'de>>(d: D) -> Result<Option<f64>, D::Error> {
    #[derive(Deserialize)]
    #[serde(untagged)]
    enum Length {
        Metres(f64),
        Text(String),
    }
    match Option::<Length>::deserialize(d)? {
        None => Ok(None),
        Some(Length::Metres(m)) => Ok(Some(m)),
        Some(Length::Text(t)) => parse_length_m(&t)
            .map(Some)
            .map_err(serde::de::Error::custom),
    }
}

/// Text with a length unit (`5cm`, `0.1m`; a time is its optical path) in metres: the
/// one reading of `--wavelength`.
pub fn parse_length_m(text: &str) -> Result<f64, String> {
    crate::units::parse_time_s(text).map(|t| t * C_M_PER_S)
}

/// Why a reconstruction cannot be made or written.
#[derive(Debug, thiserror::Error)]
pub enum ReconstructError {
    /// A field's value is not allowed; the message names it.
    #[error("{0}")]
    Invalid(Problem),
    #[error(transparent)]
    Nlos(#[from] NlosError),
    #[error("cannot start the reconstruction's threads")]
    Threads(#[source] rayon::ThreadPoolBuildError),
}

fn invalid(field: &'static str, text: impl Into<String>) -> ReconstructError {
    ReconstructError::Invalid(Problem::field(field).text(text))
}

impl ReconstructRequest {
    /// A reconstruction of the capture at `capture` with every other field at its
    /// default.
    pub fn new(capture: impl Into<PathBuf>) -> ReconstructRequest {
        ReconstructRequest {
            capture: capture.into(),
            ..ReconstructRequest::default()
        }
    }

    /// Check the fields before the capture is read; the error names the field.
    pub fn validate(&self) -> Result<(), ReconstructError> {
        if let Some(v) = &self.volume {
            if v.voxels.contains(&0) {
                return Err(invalid(
                    "volume",
                    format!(": {:?} voxels; at least 1 along each axis", v.voxels),
                ));
            }
            if !(v.center.iter().all(|c| c.is_finite())
                && v.size.iter().all(|s| s.is_finite() && *s > 0.0))
            {
                return Err(invalid(
                    "volume",
                    format!(
                        ": centre {:?} and size {:?} must be finite, the size > 0",
                        v.center, v.size
                    ),
                ));
            }
        }
        if let Some(w) = self.wavelength_m
            && !(w.is_finite() && w > 0.0)
        {
            return Err(invalid(
                "wavelength",
                format!(" {w} m must be a finite length > 0 (e.g. 5cm)"),
            ));
        }
        if self.threads == Some(0) {
            return Err(invalid("threads", " must be at least 1"));
        }
        Ok(())
    }

    /// The phasor-field kernel asked for (`None`: the method's default).
    pub fn wave(&self) -> Option<Wave> {
        self.wavelength_m.map(|m| Wave {
            wavelength_m: m,
            sigma_m: m / std::f64::consts::SQRT_2,
        })
    }

    /// The volume of capture `c`: `volume` in the capture's frame, or the default one.
    pub fn volume_of(&self, c: &LoadedCapture) -> Result<Volume, ReconstructError> {
        let frame = GridFrame::of(c)?;
        Ok(match &self.volume {
            None => Volume::default_for(c, &frame)?,
            Some(spec) => spec.volume_in(&frame)?,
        })
    }

    /// Reconstruct the capture `c` (in memory; `capture` is not read) in the request's
    /// thread pool.
    pub fn run_on(&self, c: &LoadedCapture) -> Result<Reconstruction, ReconstructError> {
        self.validate()?;
        let volume = self.volume_of(c)?;
        let wave = self.wave();
        let mut pool = rayon::ThreadPoolBuilder::new();
        if let Some(n) = self.threads {
            pool = pool.num_threads(n);
        }
        let pool = pool.build().map_err(ReconstructError::Threads)?;
        Ok(pool.install(|| reconstruct(c, self.method, &volume, wave))?)
    }

    /// Read the capture `capture` names and reconstruct it.
    pub fn run(&self) -> Result<Reconstruction, ReconstructError> {
        self.validate()?;
        let c = read_capture(&self.capture)?;
        self.run_on(&c)
    }

    /// Write the reconstruction folder `out` (`volume.npy`, `volume.json` with this
    /// request under `request`, `mip_front.png`, `mip_top.png`, `mip_side.png`), staged
    /// beside it and swapped in whole; the capture is never replaced.
    pub fn write_folder(&self, r: &Reconstruction, out: &Path) -> Result<(), ReconstructError> {
        let request = serde_json::to_value(self).map_err(|e| {
            invalid(
                "capture",
                format!(": the request cannot be written as JSON: {e}"),
            )
        })?;
        write_reconstruction_folder_with(r, &self.capture, out, Some(request))?;
        Ok(())
    }

    /// `tprf nlos reconstruct`: the output folder checked first (new, empty or an
    /// earlier tprf output), the capture read and reconstructed, the folder written.
    pub fn reconstruct_to_folder(&self, out: &Path) -> Result<Reconstruction, ReconstructError> {
        self.validate()?;
        crate::export::staging::check_target(out, &[&self.capture]).map_err(NlosError::from)?;
        let r = self.run()?;
        self.write_folder(&r, out)?;
        Ok(r)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A manifest's table: the volume as text or as a table, the wavelength with a
    /// unit; unknown keys refused; written back, it reads the same.
    #[test]
    fn requests_read_toml_with_the_option_names() {
        let r: ReconstructRequest = toml::from_str(
            "capture = \"cap\"\nmethod = \"BP\"\nvolume = \"0,0,1:1.5,1.5,1:12,12,10\"\n\
             wavelength = \"5cm\"\n",
        )
        .unwrap();
        assert_eq!(r.method, Method::Bp);
        let v = r.volume.unwrap();
        assert_eq!(v.center, [0.0, 0.0, 1.0]);
        assert_eq!(v.size, [1.5, 1.5, 1.0]);
        assert_eq!(v.voxels, [12, 12, 10]);
        // 5 cm as the command line reads it: a time, times c.
        assert_eq!(
            r.wavelength_m,
            Some(crate::units::parse_time_s("5cm").unwrap() * C_M_PER_S)
        );
        assert!((r.wavelength_m.unwrap() - 0.05).abs() < 1e-12);
        let back: ReconstructRequest = toml::from_str(&toml::to_string(&r).unwrap()).unwrap();
        assert_eq!(back, r);
        let t: ReconstructRequest = toml::from_str(
            "capture = \"cap\"\n[volume]\ncenter = [0, 0, 1]\nsize = [1.5, 1.5, 1]\nvoxels = [12, 12, 10]\n",
        )
        .unwrap();
        assert_eq!(t.volume, Some(v));
        assert_eq!(t.method, Method::Fbp);
        let e = toml::from_str::<ReconstructRequest>("capture = \"x\"\nmethods = \"bp\"\n")
            .unwrap_err();
        assert!(e.to_string().contains("methods"), "{e}");
        let e = toml::from_str::<ReconstructRequest>("method = \"xyz\"\n").unwrap_err();
        assert!(e.to_string().contains("unknown method 'xyz'"), "{e}");
    }

    /// The three parts, separated by commas or spaces, each named when wrong; the
    /// text form reads back.
    #[test]
    fn volumes_parse_naming_the_part() {
        let v = VolumeSpec::from_parts("0.25 -0.5 1", "2, 1.5, 1", "8,6,4").unwrap();
        assert_eq!(v.center, [0.25, -0.5, 1.0]);
        assert_eq!(v.to_string().parse::<VolumeSpec>().unwrap(), v);
        let e = VolumeSpec::from_parts("0, 0", "1, 1, 1", "4, 4, 4").unwrap_err();
        assert!(e.starts_with("centre '0, 0': type three numbers"), "{e}");
        let e = VolumeSpec::from_parts("0, 0, 1", "1, x, 1", "4, 4, 4").unwrap_err();
        assert!(e.starts_with("size"), "{e}");
        let e = VolumeSpec::from_parts("0, 0, 1", "1, 1, 1", "4, 4, 2.5").unwrap_err();
        assert!(e.starts_with("voxels") && e.contains("whole"), "{e}");
        let e = "0,0,1:1,1,1".parse::<VolumeSpec>().unwrap_err();
        assert!(e.contains("expected CX,CY,CZ:SX,SY,SZ:NX,NY,NZ"), "{e}");
    }

    /// Each refusal names its field.
    #[test]
    fn bad_fields_are_named() {
        let r = ReconstructRequest::new("cap");
        r.validate().unwrap();
        let cases = [
            (
                ReconstructRequest {
                    volume: Some(VolumeSpec {
                        center: [0.0, 0.0, 1.0],
                        size: [1.0, 1.0, 1.0],
                        voxels: [4, 0, 4],
                    }),
                    ..r.clone()
                },
                "volume: [4, 0, 4] voxels",
            ),
            (
                ReconstructRequest {
                    volume: Some(VolumeSpec {
                        center: [0.0, 0.0, 1.0],
                        size: [1.0, -1.0, 1.0],
                        voxels: [4, 4, 4],
                    }),
                    ..r.clone()
                },
                "volume: centre",
            ),
            (
                ReconstructRequest {
                    wavelength_m: Some(0.0),
                    ..r.clone()
                },
                "wavelength 0 m must be",
            ),
            (
                ReconstructRequest {
                    threads: Some(0),
                    ..r.clone()
                },
                "threads must be at least 1",
            ),
        ];
        for (req, want) in cases {
            let got = req.validate().unwrap_err().to_string();
            assert!(got.starts_with(want), "{got:?} should start {want:?}");
        }
    }
}
