//! The reconstruction volume as typed in the window: centre (world, metres), size along
//! the wall's `u`, `v`, `n` (metres) and voxels along them, the same three triples as
//! `tprf nlos reconstruct --volume CX,CY,CZ:SX,SY,SZ:NX,NY,NZ`, read by the request's
//! [`VolumeSpec`] and validated by [`Volume::new`] (no empty or oversized volume, none
//! reaching the wall or behind it).
//! Pure text to value, tested without a window.

use tprf_core::nlos::reconstruct::{GridFrame, Volume};
use tprf_core::request::VolumeSpec;

/// The volume's three fields as text.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct VolumeText {
    /// `x, y, z` of the centre, world metres.
    pub center: String,
    /// Size along `u, v, n`, metres.
    pub size: String,
    /// Voxels along `u, v, n`.
    pub voxels: String,
}

impl VolumeText {
    /// The fields showing `v`.
    pub fn of(v: &Volume) -> VolumeText {
        let f = |a: [f32; 3]| format!("{}, {}, {}", round4(a[0]), round4(a[1]), round4(a[2]));
        VolumeText {
            center: f(v.center),
            size: f(v.size_m),
            voxels: format!("{}, {}, {}", v.voxels[0], v.voxels[1], v.voxels[2]),
        }
    }

    /// The volume the fields describe in `frame`, or a message naming the field and
    /// what to type: the reconstruction request's volume ([`VolumeSpec`], read as
    /// `tprf nlos reconstruct --volume` and a manifest read it), resolved in the frame.
    pub fn parse(&self, frame: &GridFrame) -> Result<Volume, String> {
        let spec = VolumeSpec::from_parts(&self.center, &self.size, &self.voxels)
            .map_err(|e| format!("volume {e}"))?;
        spec.volume_in(frame).map_err(|e| {
            // The core's message names the command-line flag; here it is the fields.
            e.to_string().replace("--volume: ", "volume: ")
        })
    }
}

/// `v` to four decimals, without trailing zeros (`0.5`, `1.2346`).
fn round4(v: f32) -> String {
    let s = format!("{v:.4}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" { "0".into() } else { s.into() }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn frame() -> GridFrame {
        GridFrame {
            center: Vec3::ZERO,
            u: Vec3::X,
            v: Vec3::Y,
            n: Vec3::Z,
            spacing_m: [0.1, 0.1],
        }
    }

    fn text(c: &str, s: &str, n: &str) -> VolumeText {
        VolumeText {
            center: c.into(),
            size: s.into(),
            voxels: n.into(),
        }
    }

    #[test]
    fn a_volume_round_trips_through_its_text() {
        let v = Volume::new(
            &frame(),
            Vec3::new(0.25, -0.5, 1.0),
            [2.0, 1.5, 1.0],
            [8, 6, 4],
        )
        .unwrap();
        let t = VolumeText::of(&v);
        assert_eq!(t.center, "0.25, -0.5, 1");
        assert_eq!(t.parse(&frame()).unwrap(), v);
        // Spaces alone separate too.
        assert_eq!(
            text("0.25 -0.5 1", "2 1.5 1", "8 6 4")
                .parse(&frame())
                .unwrap(),
            v
        );
    }

    #[test]
    fn bad_volumes_are_messages_naming_the_field() {
        let e = text("0, 0", "1, 1, 1", "4, 4, 4")
            .parse(&frame())
            .unwrap_err();
        assert!(e.contains("centre") && e.contains("three numbers"), "{e}");
        let e = text("0, 0, 1", "1, x, 1", "4, 4, 4")
            .parse(&frame())
            .unwrap_err();
        assert!(e.contains("size"), "{e}");
        let e = text("0, 0, 1", "1, 1, 1", "4, 4, 2.5")
            .parse(&frame())
            .unwrap_err();
        assert!(e.contains("voxels") && e.contains("whole"), "{e}");
        let e = text("0, 0, 1", "1, 1, 1", "4, 0, 4")
            .parse(&frame())
            .unwrap_err();
        assert!(e.starts_with("volume:") && e.contains("voxels"), "{e}");
        let e = text("0, 0, 0.2", "1, 1, 1", "4, 4, 4")
            .parse(&frame())
            .unwrap_err();
        assert!(e.contains("behind the relay wall"), "{e}");
        let e = text("0, 0, 1", "1, -1, 1", "4, 4, 4")
            .parse(&frame())
            .unwrap_err();
        assert!(e.contains("size"), "{e}");
    }
}
