//! Polarization: Stokes vectors, Mueller matrices, the rotation of their reference
//! frames, and the Fresnel Mueller matrices of smooth interfaces.
//!
//! Conventions (Mitsuba 3's, `include/mitsuba/render/mueller.h` and `fresnel.h`, so that
//! files compare with mitransient's polarized variants):
//!
//! - A Stokes vector `S = (S0, S1, S2, S3)` is radiance (or flux: it carries the unit of
//!   what it weights) and means something only with a *reference frame*: a unit vector
//!   `x` orthogonal to the direction of travel `forward`, and `y = forward x x`. The
//!   triple `(x, y, forward)` is right-handed: the observer, looking back along the beam
//!   towards its source, sees `x` and `y` as a usual right/up pair. Light whose electric
//!   field oscillates along `cos(psi) x + sin(psi) y` has `S1 = S0 cos 2 psi`,
//!   `S2 = S0 sin 2 psi`; `S3 > 0` is right-circular in Mitsuba's (Collett's) sense.
//! - A direction's *implicit* frame is [`frames::stokes_basis`]: the first tangent of
//!   Duff et al.'s orthonormal basis around `forward` (Mitsuba's `coordinate_system`,
//!   the same as [`crate::transport::bsdf::Frame`]'s `t`). Stokes vectors and Mueller
//!   matrices in the transport are expressed in these frames, so no frame is stored.
//! - Mueller matrices act on column Stokes vectors, `S_out = M S_in`; a chain of
//!   elements met in the order `A` then `B` is `B A`.
//! - Refractive indices follow Mitsuba's `fresnel_polarized`: `eta = n_t / n_i`, the
//!   index beyond the interface over the index on the incident side (greater than 1 for
//!   light entering glass from air); a conductor's `eta + i k` with `k >= 0` as Mitsuba's
//!   files give it (the complex index `eta - i k` inside, as Mitsuba's Fresnel code
//!   takes it). Reflection amplitudes use the Verdet sign of `a_p` (`a_p = -a_s` at
//!   normal incidence), the frame's `x` is the s direction (perpendicular to the plane of
//!   incidence).

pub mod complex;
pub mod frames;
pub mod fresnel;
pub mod mueller;
pub mod stokes;

pub use mueller::Mueller;
pub use stokes::Stokes;
