//! Where a path's clock starts: on the camera's side ([`TimeOrigin`]: the pinhole, the
//! near plane, the first surface seen) and on the light's ([`PulseOrigin`]: the light,
//! or the first surface it lights). tprf's default is the physical one, the pinhole and
//! the light (the times a real camera sees for a pulse leaving the light at t = 0);
//! the others are mitransient's conventions (`near_clip`, `camera_unwarp`,
//! `account_first_and_last_bounces`), so its files render to its cubes bin for bin.

use serde::{Deserialize, Serialize};

/// Where a path's optical length (and so its arrival time) is counted from, on the
/// camera's side.
///
/// - `Pinhole`: from the camera's pinhole: the time a real camera sees (tprf's default).
/// - `NearPlane`: from the near clip plane, as Mitsuba starts camera rays and mitransient
///   counts: a ray at angle `a` to the optical axis starts `near_m / cos a` from the
///   pinhole, so its arrivals are that much optical path earlier.
/// - `FirstHit`: from the camera ray's first surface (mitransient's `camera_unwarp`):
///   the camera's own leg left out, so every pixel sees its events in world time.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum TimeOrigin {
    #[default]
    Pinhole,
    NearPlane,
    FirstHit,
}

/// When the pulse starts, on the light's side.
///
/// - `Light`: it leaves the light at t = 0 (tprf's default, DESIGN.md).
/// - `FirstHit`: it is at the first surface it lights at t = 0: the leg from the light
///   to that surface is left out (an NLOS laser's spot fires at t = 0; mitransient's
///   `account_first_and_last_bounces` false, with `TimeOrigin::FirstHit` for the
///   camera's leg).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum PulseOrigin {
    #[default]
    Light,
    FirstHit,
}

impl TimeOrigin {
    pub const ALL: [TimeOrigin; 3] = [
        TimeOrigin::Pinhole,
        TimeOrigin::NearPlane,
        TimeOrigin::FirstHit,
    ];

    /// The option's spelling: `pinhole`, `near-plane`, `first-hit`.
    pub fn name(self) -> &'static str {
        match self {
            TimeOrigin::Pinhole => "pinhole",
            TimeOrigin::NearPlane => "near-plane",
            TimeOrigin::FirstHit => "first-hit",
        }
    }
}

impl PulseOrigin {
    pub const ALL: [PulseOrigin; 2] = [PulseOrigin::Light, PulseOrigin::FirstHit];

    /// The option's spelling: `light`, `first-hit`.
    pub fn name(self) -> &'static str {
        match self {
            PulseOrigin::Light => "light",
            PulseOrigin::FirstHit => "first-hit",
        }
    }
}

impl std::fmt::Display for TimeOrigin {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::fmt::Display for PulseOrigin {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// A time or pulse origin that is none of the names it may take.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("'{given}' is not a {what}: {choices}")]
pub struct UnknownOrigin {
    pub given: String,
    what: &'static str,
    choices: &'static str,
}

impl std::str::FromStr for TimeOrigin {
    type Err = UnknownOrigin;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        TimeOrigin::ALL
            .into_iter()
            .find(|o| o.name() == s.trim().to_ascii_lowercase())
            .ok_or_else(|| UnknownOrigin {
                given: s.to_string(),
                what: "time origin",
                choices: "pinhole, near-plane or first-hit",
            })
    }
}

impl std::str::FromStr for PulseOrigin {
    type Err = UnknownOrigin;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        PulseOrigin::ALL
            .into_iter()
            .find(|o| o.name() == s.trim().to_ascii_lowercase())
            .ok_or_else(|| UnknownOrigin {
                given: s.to_string(),
                what: "pulse origin",
                choices: "light or first-hit",
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn origins_parse_their_names() {
        for o in TimeOrigin::ALL {
            assert_eq!(o.name().parse::<TimeOrigin>(), Ok(o));
        }
        for o in PulseOrigin::ALL {
            assert_eq!(o.name().parse::<PulseOrigin>(), Ok(o));
        }
        assert!("camera".parse::<TimeOrigin>().is_err());
        assert!("pinhole".parse::<PulseOrigin>().is_err());
    }
}
