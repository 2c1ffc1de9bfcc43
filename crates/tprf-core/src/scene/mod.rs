//! Scene: what the world is made of, in world space, metres, one struct.
//!
//! Every loader (glTF files, built-in scenes) produces a [`Scene`]; acceleration and
//! transport only read it. Colours stay RGB here: the transport picks the one band the
//! transient cube records (see [`Channel`]).

pub mod builtin;
pub mod camera;
pub mod density;
pub mod dispersion;
pub mod gltf_load;
pub mod gltf_save;
pub mod luminescence;
pub mod medium;
pub mod mitsuba;
pub mod spectrum;
pub mod time_origin;
pub mod wavelengths;

pub use camera::{Camera, FovAxis};
pub use density::DensityGrid;
pub use luminescence::{DecayComponent, Luminescence};
pub use medium::Medium;
pub use time_origin::{PulseOrigin, TimeOrigin, UnknownOrigin};

use glam::{Vec2, Vec3};
use serde::{Deserialize, Serialize};

/// Bytes one triangle costs from loading through rendering: the scene's [`Triangle`]
/// (36 B) and [`TriangleAttrs`] (68 B), the renderer's BVH and surface records and the
/// BVH build's peak. Measured as peak resident memory over triangles when a large mesh
/// is rendered (docs/benchmarks.md, "Hostile input"). The glTF loader budgets this much
/// per triangle after instancing before it reads any.
pub const BYTES_PER_TRIANGLE: u64 = 400;

/// A triangle in world space (metres). Vertex order gives the geometric normal
/// `(p1 - p0) x (p2 - p0)`, the glTF front face (counter-clockwise).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Triangle {
    pub p: [Vec3; 3],
}

impl Triangle {
    /// Area in m^2.
    pub fn area_m2(&self) -> f32 {
        0.5 * (self.p[1] - self.p[0])
            .cross(self.p[2] - self.p[0])
            .length()
    }
}

/// Per-triangle shading data, kept beside [`Triangle`] with the same index.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleAttrs {
    /// Vertex shading normals (unit length), or `None` to shade with the geometric normal.
    pub normals: Option<[Vec3; 3]>,
    /// Texture coordinates (TEXCOORD_0), zero when the mesh has none.
    pub uv: [Vec2; 3],
    /// Index into [`Scene::materials`].
    pub material: u32,
}

/// How a material's alpha covers the surface (glTF `alphaMode`).
///
/// Coverage `a` in [0, 1]: a fraction `1 - a` of the light passes straight through,
/// unchanged and undelayed (the paper's *virtual* interface, `K = delta(w - w')`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum AlphaMode {
    Opaque,
    /// Covered where alpha >= cutoff, open elsewhere.
    Mask {
        cutoff: f32,
    },
    /// Covered by the fraction alpha.
    Blend,
}

/// A reference to a texture and the TEXCOORD set it reads (only set 0 is loaded).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TextureRef {
    pub texture: u32,
}

/// A material, following glTF 2.0 metallic-roughness and the KHR extensions tprf
/// honours. All factors are linear (not sRGB).
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    /// Linear RGBA base colour factor.
    pub base_color: [f32; 4],
    /// sRGB-encoded base colour texture (RGB multiplies `base_color`, A multiplies alpha).
    pub base_color_texture: Option<TextureRef>,
    pub metallic: f32,
    /// Perceptual roughness in [0, 1] (GGX alpha = roughness^2).
    pub roughness: f32,
    /// Linear texture: G = roughness, B = metallic (glTF convention).
    pub metallic_roughness_texture: Option<TextureRef>,
    /// KHR_materials_specular `specularFactor` (1 without the extension; 0 = pure Lambertian
    /// for a dielectric).
    pub specular_factor: f32,
    /// KHR_materials_specular `specularColorFactor` (linear RGB).
    pub specular_color: [f32; 3],
    /// KHR_materials_transmission `transmissionFactor` in [0, 1].
    pub transmission: f32,
    /// KHR_materials_ior (1.5 without the extension). Light inside travels at c / ior.
    /// With a `dispersion`, its value at the d line.
    pub ior: f32,
    /// The index as a function of wavelength (glTF extras `{"tprf": {"n": {"cauchy":
    /// [A, B_um2]}}}`): a band at a wavelength refracts by its phase index there and
    /// times the inside by its group index ([`dispersion::Dispersion`]). `None`: `ior`
    /// in every band.
    pub dispersion: Option<dispersion::Dispersion>,
    pub alpha_mode: AlphaMode,
    /// Emitted radiance, W / (m^2 sr) per channel: `emissiveFactor x emissive_strength`.
    pub emissive: [f32; 3],
    /// sRGB-encoded emissive texture (multiplies `emissive`).
    pub emissive_texture: Option<TextureRef>,
    /// How the emitted radiance falls with the angle to the surface's normal (an
    /// angular area light: mitransient's `angulararea`); `None`: the same in every
    /// direction (a Lambertian emitter).
    pub emission_falloff: Option<AngularFalloff>,
    pub double_sided: bool,
    /// The back face (the side the normal looks away from) absorbs all light, as
    /// Mitsuba's one-sided BSDFs (`diffuse`, `plastic`, `conductor` and their rough
    /// kinds outside a `twosided`) are black from behind. False (glTF's materials,
    /// whatever their `doubleSided`, which is about culling): both faces scatter alike.
    /// In glTF extras: `{"tprf": {"one_sided": true}}`.
    pub one_sided: bool,
    /// The medium filling the closed mesh this material bounds (its inside: the side
    /// the front faces look away from). With `transmission > 0` the surface refracts as
    /// a dielectric of index `ior` and the medium's `n` is `ior`; with `transmission` 0
    /// the surface is an index-matched boundary (the paper's virtual interface: light
    /// crosses it unchanged, undelayed) around a medium of its own `n`.
    pub medium: Option<Medium>,
    /// How the surface scatters: glTF's metallic-roughness model of the fields above (the
    /// default), or one of Mitsuba's models exactly (the fields above then hold the
    /// nearest metallic-roughness material, which a glTF export writes).
    pub model: SurfaceModel,
    /// Light the surface stores and re-emits later (fluorescence, phosphorescence):
    /// [`Luminescence`]. `None`: every reflection is immediate.
    pub luminescence: Option<Luminescence>,
}

/// The scattering model of a [`Material`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum SurfaceModel {
    /// glTF 2.0 metallic-roughness with the specular, transmission and IOR extensions.
    #[default]
    MetallicRoughness,
    /// Mitsuba 3's `plastic` (`microfacet` `None`: a smooth coat) and `roughplastic`: a
    /// dielectric coat of relative index `eta` (`int_ior / ext_ior`) over a diffuse base
    /// whose light is reflected back inside the coat. The base colour (and its texture) is
    /// `diffuse_reflectance`, `specular_color` the `specular_reflectance`.
    Plastic {
        eta: f32,
        microfacet: Option<Microfacet>,
        /// Mitsuba's `nonlinear`: the internal reflections tint with the base colour.
        nonlinear: bool,
    },
    /// Mitsuba 3's `conductor` (`microfacet` `None`: a mirror) and `roughconductor`: the
    /// Fresnel reflectance of a conductor of complex index `eta + i k` (relative to the
    /// outside), per linear-sRGB channel, times `specular_reflectance`.
    Conductor {
        eta: [f32; 3],
        k: [f32; 3],
        specular_reflectance: [f32; 3],
        microfacet: Option<Microfacet>,
    },
}

/// An isotropic microfacet distribution as Mitsuba 3 defines it
/// (`include/mitsuba/render/microfacet.h`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Microfacet {
    pub distribution: MicrofacetDistribution,
    /// Mitsuba's `alpha`: the RMS slope (Beckmann) or GGX's alpha, >= 0.
    pub alpha: f32,
}

/// Mitsuba's two microfacet normal distributions.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum MicrofacetDistribution {
    Beckmann,
    Ggx,
}

impl Default for Material {
    fn default() -> Self {
        // glTF's default material: white, fully metallic=1 roughness=1 per spec; tprf's
        // default for a primitive with no material is a grey Lambertian instead, which is
        // what a user of a range sensor expects of "no material given".
        Material {
            name: "default".into(),
            base_color: [0.8, 0.8, 0.8, 1.0],
            base_color_texture: None,
            metallic: 0.0,
            roughness: 1.0,
            metallic_roughness_texture: None,
            specular_factor: 0.0,
            specular_color: [1.0; 3],
            transmission: 0.0,
            ior: 1.5,
            dispersion: None,
            alpha_mode: AlphaMode::Opaque,
            emissive: [0.0; 3],
            emissive_texture: None,
            emission_falloff: None,
            double_sided: true,
            one_sided: false,
            medium: None,
            model: SurfaceModel::MetallicRoughness,
            luminescence: None,
        }
    }
}

/// An emitter's angular profile, mitransient's `angulararea`: radiance at angle `theta`
/// to the normal is the full radiance times
/// `1` for `theta <= beam_width`, `(cutoff - theta) / (cutoff - beam_width)` between,
/// and `0` from `cutoff` on (linear in the angle, as Mitsuba's spot light falls).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AngularFalloff {
    /// Half-angle of full emission, radians.
    pub beam_width_rad: f32,
    /// Half-angle where emission reaches zero, radians (at least `beam_width_rad`).
    pub cutoff_rad: f32,
}

impl AngularFalloff {
    /// The profile's factor at `cos_theta`, the cosine of the angle to the normal.
    #[inline]
    pub fn factor(&self, cos_theta: f32) -> f32 {
        if cos_theta >= self.beam_width_rad.cos() {
            1.0
        } else if cos_theta > self.cutoff_rad.cos() {
            let theta = cos_theta.clamp(-1.0, 1.0).acos();
            ((self.cutoff_rad - theta) / (self.cutoff_rad - self.beam_width_rad)).clamp(0.0, 1.0)
        } else {
            0.0
        }
    }

    /// Whether the angles are finite and `0 <= beam_width <= cutoff <= 180` degrees,
    /// the cutoff above 0; else what is wrong.
    pub fn check(&self) -> Result<(), String> {
        let (b, c) = (self.beam_width_rad, self.cutoff_rad);
        if !(b.is_finite() && c.is_finite() && b >= 0.0 && c > 0.0 && c <= std::f32::consts::PI) {
            return Err(format!(
                "beam width {} and cutoff {} degrees must be finite, the cutoff in (0, 180]",
                b.to_degrees(),
                c.to_degrees()
            ));
        }
        if b > c {
            return Err(format!(
                "beam width {} degrees is wider than the cutoff {} degrees",
                b.to_degrees(),
                c.to_degrees()
            ));
        }
        Ok(())
    }
}

impl Material {
    /// A grey-or-coloured pure Lambertian (specularFactor 0), the workhorse of tests.
    pub fn lambertian(name: &str, albedo: [f32; 3]) -> Self {
        Material {
            name: name.into(),
            base_color: [albedo[0], albedo[1], albedo[2], 1.0],
            ..Material::default()
        }
    }

    /// Whether any part of the material emits.
    pub fn is_emissive(&self) -> bool {
        self.emissive.iter().any(|&e| e > 0.0)
    }
}

/// A decoded texture: 8-bit RGBA, row 0 = top (glTF UV (0,0) is the top-left corner).
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    pub width: u32,
    pub height: u32,
    pub rgba8: Vec<[u8; 4]>,
}

/// Spot cone of a KHR_lights_punctual spot light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spot {
    /// Unit direction the spot points to (world space; the light's -Z).
    pub direction: Vec3,
    pub inner_cone_rad: f32,
    pub outer_cone_rad: f32,
}

/// The frustum of a projector (Mitsuba's `projector` emitter, a laser's spot): light
/// leaves the point into a rectangular pyramid around `direction`, with the same
/// irradiance on every point of a plane across it: radiant intensity `I_0 / cos^3 theta`
/// toward a direction at angle `theta` to the axis inside the pyramid, 0 outside
/// (`I_0` the light's `intensity_w_per_sr`).
#[derive(Clone, Debug, PartialEq)]
pub struct Projector {
    /// Unit direction of the axis (world space).
    pub direction: Vec3,
    /// Unit direction of the image's up, across `direction` (world space).
    pub up: Vec3,
    /// Tangents of half the frustum's angles across (x) and up (y).
    pub tan_half_x: f32,
    pub tan_half_y: f32,
    /// The image projected (Mitsuba's `irradiance` bitmap): the irradiance across the
    /// frustum is `I_0` times its value there. `None`: uniform (a value of 1).
    pub image: Option<std::sync::Arc<IrradianceImage>>,
}

/// A projector's image: linear RGB per texel, row 0 the image's top and column 0 its
/// left as seen from behind the projector (Mitsuba's projector: the picture lands
/// upright and unmirrored on a wall facing it), looked up bilinearly between texel
/// centres as Mitsuba's `bitmap` texture.
#[derive(Clone, Debug, PartialEq)]
pub struct IrradianceImage {
    pub width: u32,
    pub height: u32,
    pub rgb: Vec<[f32; 3]>,
    /// What the bilinear lookup reads beyond the edge texels (Mitsuba's `wrap_mode`).
    pub wrap: ImageWrap,
}

/// Texels beyond an image's edge, for a bilinear lookup near it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ImageWrap {
    /// The opposite edge's (Mitsuba's default, `repeat`).
    #[default]
    Repeat,
    /// The edge texel's own (`clamp`).
    Clamp,
}

/// A point or spot light (KHR_lights_punctual), or a projector. The pulse leaves it at
/// t = 0.
#[derive(Clone, Debug, PartialEq)]
pub struct PunctualLight {
    pub name: String,
    pub position: Vec3,
    /// Radiant intensity per channel, W/sr: `color x intensity` (no 683 lm/W factor); a
    /// projector's on its axis.
    pub intensity_w_per_sr: [f32; 3],
    pub spot: Option<Spot>,
    /// A projector's frustum (then `spot` is `None`).
    pub projector: Option<Projector>,
}

/// A directional light (KHR_lights_punctual `directional`, the sun): parallel light
/// from infinitely far away, arriving at every time. Part of the ambient group
/// ([`AmbientLights`]), never pulsed.
#[derive(Clone, Debug, PartialEq)]
pub struct DirectionalLight {
    pub name: String,
    /// Unit direction the light travels in (world space; the light node's -Z).
    pub direction: Vec3,
    /// Irradiance per channel on a surface facing the light, W/m^2: `color x intensity`
    /// (no 683 lm/W factor, as the punctual lights).
    pub irradiance_w_per_m2: [f32; 3],
}

/// The ambient light group: steady light (the sun, a sky, a room lamp) that arrives at
/// every time. The transient render never sees it; it is rendered once as a steady
/// radiance image (`transport::ambient`) and added by the sensor as a constant rate.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AmbientLights {
    /// Point and spot lights tagged ambient (glTF node extras `{"tprf": {"ambient":
    /// true}}`): steady lamps, W/sr as [`PunctualLight`].
    pub lights: Vec<PunctualLight>,
    /// Directional lights (the sun).
    pub directional: Vec<DirectionalLight>,
    /// A constant sky: radiance per channel arriving from every direction that escapes
    /// the scene, W m^-2 sr^-1 (glTF scene extras `{"tprf": {"sky_radiance": L}}`,
    /// `tprf render --sky L`).
    pub sky_radiance: [f32; 3],
}

impl AmbientLights {
    /// Whether the group lights nothing (no light, no sky).
    pub fn is_empty(&self) -> bool {
        self.lights.is_empty()
            && self.directional.is_empty()
            && self.sky_radiance.iter().all(|&v| v == 0.0)
    }

    /// The group's members in words, for metadata: `point 'lamp'`, `directional 'sun'`,
    /// `sky 0.5 W m^-2 sr^-1`.
    pub fn describe(&self) -> Vec<String> {
        let mut out: Vec<String> = self
            .lights
            .iter()
            .map(|l| {
                let kind = match (&l.spot, &l.projector) {
                    (_, Some(_)) => "projector",
                    (Some(_), None) => "spot",
                    (None, None) => "point",
                };
                format!("{kind} '{}' ({:?} W/sr)", l.name, l.intensity_w_per_sr)
            })
            .collect();
        out.extend(self.directional.iter().map(|d| {
            format!(
                "directional '{}' ({:?} W/m^2 along {:?})",
                d.name,
                d.irradiance_w_per_m2,
                d.direction.to_array()
            )
        }));
        if self.sky_radiance.iter().any(|&v| v != 0.0) {
            out.push(format!("sky ({:?} W m^-2 sr^-1)", self.sky_radiance));
        }
        out
    }

    /// Check the group: finite positions, non-negative finite intensities, irradiances
    /// and sky radiance, non-zero directions. The message names the field.
    pub fn validate(&self) -> Result<(), SceneError> {
        let bad = |v: &[f32]| v.iter().any(|x| !x.is_finite() || *x < 0.0);
        for l in &self.lights {
            if !l.position.is_finite() || bad(&l.intensity_w_per_sr) {
                return Err(SceneError::Invalid(format!(
                    "ambient light '{}' has a non-finite position or a negative/non-finite \
                     intensity_w_per_sr {:?}",
                    l.name, l.intensity_w_per_sr
                )));
            }
        }
        for d in &self.directional {
            if bad(&d.irradiance_w_per_m2) {
                return Err(SceneError::Invalid(format!(
                    "directional light '{}': irradiance_w_per_m2 {:?} (color x intensity) is \
                     negative or not finite",
                    d.name, d.irradiance_w_per_m2
                )));
            }
            let len = d.direction.length();
            if !(len.is_finite() && (len - 1.0).abs() < 1e-3) {
                return Err(SceneError::Invalid(format!(
                    "directional light '{}': direction {:?} is not a finite unit vector (a \
                     zero or degenerate node rotation/scale?)",
                    d.name,
                    d.direction.to_array()
                )));
            }
        }
        if bad(&self.sky_radiance) {
            return Err(SceneError::Invalid(format!(
                "sky_radiance {:?} W m^-2 sr^-1 is negative or not finite",
                self.sky_radiance
            )));
        }
        Ok(())
    }
}

/// A named part of the scene: the triangles of one glTF node (its name, else its mesh's),
/// or a named part of a built-in scene. NLOS captures find their relay wall by it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SceneObject {
    pub name: String,
    /// Indices into [`Scene::triangles`] (after instancing and dropped degenerate ones).
    pub triangles: std::ops::Range<usize>,
}

/// The world: triangles, their materials, punctual lights and the camera.
#[derive(Clone, Debug)]
pub struct Scene {
    /// A name for metadata: the file path or `builtin:NAME`.
    pub name: String,
    pub triangles: Vec<Triangle>,
    /// Same length and order as `triangles`.
    pub attrs: Vec<TriangleAttrs>,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    /// The pulsed lights: the pulse leaves each at t = 0.
    pub lights: Vec<PunctualLight>,
    /// The ambient group: steady light, not pulsed (empty for most scenes).
    pub ambient: AmbientLights,
    /// The scene-wide medium (the air: fog, haze, water) around everything, the camera
    /// and the lights in it; `None`: vacuum.
    pub medium: Option<Medium>,
    pub camera: Camera,
    /// Named parts (glTF nodes with meshes), in file order; may be empty.
    pub objects: Vec<SceneObject>,
    /// What the loader decided on its own (a framed camera, a co-located light, dropped
    /// degenerate triangles...). Front ends print these.
    pub notes: Vec<String>,
}

/// Axis-aligned bounds, metres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    pub min: Vec3,
    pub max: Vec3,
}

impl Bounds {
    pub fn diagonal_m(&self) -> f32 {
        (self.max - self.min).length()
    }
    pub fn center(&self) -> Vec3 {
        0.5 * (self.min + self.max)
    }
}

impl Scene {
    /// Bounds of all triangles (and lights and camera).
    pub fn bounds(&self) -> Bounds {
        self.bounds_with_eye(self.camera.position())
    }

    /// Bounds of all triangles and lights and the point `eye` (a camera's position,
    /// metres): [`Scene::bounds`] as seen from another camera.
    pub fn bounds_with_eye(&self, eye: Vec3) -> Bounds {
        let mut min = Vec3::splat(f32::INFINITY);
        let mut max = Vec3::splat(f32::NEG_INFINITY);
        let points = self
            .triangles
            .iter()
            .flat_map(|t| t.p)
            .chain(self.lights.iter().map(|l| l.position))
            .chain(self.ambient.lights.iter().map(|l| l.position))
            .chain(std::iter::once(eye));
        for p in points {
            min = min.min(p);
            max = max.max(p);
        }
        Bounds { min, max }
    }

    /// Bounds of the triangles only (what a framed camera looks at).
    pub fn geometry_bounds(&self) -> Option<Bounds> {
        if self.triangles.is_empty() {
            return None;
        }
        let mut min = Vec3::splat(f32::INFINITY);
        let mut max = Vec3::splat(f32::NEG_INFINITY);
        for p in self.triangles.iter().flat_map(|t| t.p) {
            min = min.min(p);
            max = max.max(p);
        }
        Some(Bounds { min, max })
    }

    /// Frame a camera on the geometry: look at the bounds' centre along -Z from in front
    /// (+Z, glTF's front), slightly above, far enough that the bounding sphere fits the
    /// vertical field of view.
    pub fn framed_camera(&self, yfov_rad: f32) -> Camera {
        let Some(b) = self.geometry_bounds() else {
            return Camera::look_at(Vec3::new(0.0, 0.0, 1.0), Vec3::ZERO, yfov_rad);
        };
        let radius = 0.5 * b.diagonal_m().max(1e-6);
        let dist = radius / (0.5 * yfov_rad).sin();
        let dir = Vec3::new(0.0, 0.15, 1.0).normalize();
        Camera::look_at(b.center() + dir * dist, b.center(), yfov_rad)
    }

    /// A point light at the camera (a LiDAR-style co-located source), bright enough that
    /// a white Lambertian facing it at the geometry's centre has radiance ~1 W/(m^2 sr):
    /// `I = pi d^2` W/sr, since `L = (1/pi) I / d^2`. What a loader adds to a file with
    /// no light.
    pub fn colocated_light(&self) -> PunctualLight {
        let eye = self.camera.position();
        let d = self.geometry_bounds().map_or(1.0, |b| {
            let d = eye.distance(b.center());
            if d > 0.0 { d } else { 0.5 * b.diagonal_m() }
        });
        let d = if d > 0.0 && d.is_finite() { d } else { 1.0 };
        PunctualLight {
            name: "co-located".into(),
            position: eye,
            intensity_w_per_sr: [std::f32::consts::PI * d * d; 3],
            spot: None,
            projector: None,
        }
    }

    /// Uniform scale of everything about the origin (geometry, lights, camera position;
    /// media coefficients over `s`, so optical depths stay). Used to check time-scale
    /// invariance: the TPRF stretches by `s`.
    pub fn scaled(mut self, s: f32) -> Scene {
        for t in &mut self.triangles {
            for p in &mut t.p {
                *p *= s;
            }
        }
        for l in self.lights.iter_mut().chain(&mut self.ambient.lights) {
            l.position *= s;
        }
        self.camera.world_from_camera.translation *= s;
        self.medium = self.medium.take().map(|m| m.scaled(s));
        for m in &mut self.materials {
            m.medium = m.medium.take().map(|m| m.scaled(s));
        }
        self
    }

    /// Give each material medium's density grid without a box the bounds of the
    /// triangles of that material (the mesh it fills); a grid of a material no triangle
    /// uses keeps none, and the scene's check asks for its box.
    pub fn fit_density_boxes(&mut self) {
        for (i, m) in self.materials.iter_mut().enumerate() {
            let Some(d) = m.medium.as_mut().and_then(|md| md.density.as_mut()) else {
                continue;
            };
            if d.bbox_m.is_some() {
                continue;
            }
            let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
            for (t, a) in self.triangles.iter().zip(&self.attrs) {
                if a.material as usize == i {
                    for p in t.p {
                        lo = lo.min(p);
                        hi = hi.max(p);
                    }
                }
            }
            if lo.cmplt(hi).all() {
                d.bbox_m = Some([lo.to_array(), hi.to_array()]);
            }
        }
    }

    /// Multiply every light's intensity (the ambient group's too) and every emitter's
    /// radiance by `k`.
    pub fn with_intensity_scale(mut self, k: f32) -> Scene {
        for l in self.lights.iter_mut().chain(&mut self.ambient.lights) {
            l.intensity_w_per_sr = l.intensity_w_per_sr.map(|v| v * k);
        }
        for d in &mut self.ambient.directional {
            d.irradiance_w_per_m2 = d.irradiance_w_per_m2.map(|v| v * k);
        }
        self.ambient.sky_radiance = self.ambient.sky_radiance.map(|v| v * k);
        for m in &mut self.materials {
            m.emissive = m.emissive.map(|v| v * k);
        }
        self
    }

    /// The triangle indices of every object named `name` (a node instanced twice, or
    /// two nodes of one name, give all their triangles), in order; empty when none is.
    pub fn object_triangles(&self, name: &str) -> Vec<usize> {
        self.objects
            .iter()
            .filter(|o| o.name == name)
            .flat_map(|o| o.triangles.clone())
            .filter(|&i| i < self.triangles.len())
            .collect()
    }

    /// Check the invariants the transport relies on; loaders call this last.
    pub fn validate(&self) -> Result<(), SceneError> {
        if self.triangles.len() != self.attrs.len() {
            return Err(SceneError::Invalid(format!(
                "{} triangles but {} attribute records",
                self.triangles.len(),
                self.attrs.len()
            )));
        }
        for (i, t) in self.triangles.iter().enumerate() {
            if !t.p.iter().all(|p| p.is_finite()) {
                return Err(SceneError::Invalid(format!(
                    "triangle {i} has a non-finite vertex position"
                )));
            }
        }
        for (i, a) in self.attrs.iter().enumerate() {
            if a.material as usize >= self.materials.len() {
                return Err(SceneError::Invalid(format!(
                    "triangle {i} uses material {} of {}",
                    a.material,
                    self.materials.len()
                )));
            }
        }
        if let Some(o) = self
            .objects
            .iter()
            .find(|o| o.triangles.start > o.triangles.end || o.triangles.end > self.triangles.len())
        {
            return Err(SceneError::Invalid(format!(
                "object '{}' names triangles {:?} of {}",
                o.name,
                o.triangles,
                self.triangles.len()
            )));
        }
        for m in &self.materials {
            let bad = |v: &[f32]| v.iter().any(|x| !x.is_finite() || *x < 0.0);
            if bad(&m.emissive) {
                return Err(SceneError::Invalid(format!(
                    "material '{}': emitted radiance {:?} (emissiveFactor x emissive_strength) \
                     is negative or overflows 32-bit floats",
                    m.name, m.emissive
                )));
            }
            if bad(&m.base_color) {
                return Err(SceneError::Invalid(format!(
                    "material '{}': base colour {:?} is negative or not finite",
                    m.name, m.base_color
                )));
            }
            if let Some(l) = &m.luminescence {
                let base = [m.base_color[0], m.base_color[1], m.base_color[2]];
                l.check(&m.name, base).map_err(SceneError::Invalid)?;
            }
            if let Some(f) = &m.emission_falloff {
                f.check().map_err(|e| {
                    SceneError::Invalid(format!("material '{}': emission falloff: {e}", m.name))
                })?;
            }
            if let Some(medium) = &m.medium {
                medium.validate(&format!("material '{}' medium", m.name))?;
                if m.transmission > 0.0 && medium.n != m.ior {
                    return Err(SceneError::Invalid(format!(
                        "material '{}': its medium's n = {} differs from its ior {}: a \
                         refracting boundary's inside has the material's index",
                        m.name, medium.n, m.ior
                    )));
                }
            }
        }
        if let Some(medium) = &self.medium {
            medium.validate("scene medium")?;
        }
        for l in &self.lights {
            if !l.position.is_finite()
                || l.intensity_w_per_sr
                    .iter()
                    .any(|v| !v.is_finite() || *v < 0.0)
            {
                return Err(SceneError::Invalid(format!(
                    "light '{}' has a non-finite position or a negative/non-finite intensity",
                    l.name
                )));
            }
            if let Some(p) = &l.projector {
                let frame_ok = p.direction.is_normalized()
                    && p.up.is_normalized()
                    && p.direction.dot(p.up).abs() < 1e-3;
                let tan_ok = |t: f32| t.is_finite() && t > 0.0;
                if !(frame_ok && tan_ok(p.tan_half_x) && tan_ok(p.tan_half_y)) || l.spot.is_some() {
                    return Err(SceneError::Invalid(format!(
                        "light '{}': a projector needs a unit axis and up across it, a \
                         field of view in (0, 180) degrees, and no spot cone",
                        l.name
                    )));
                }
                if let Some(im) = &p.image {
                    let n = im.width as usize * im.height as usize;
                    if n == 0 || im.rgb.len() != n {
                        return Err(SceneError::Invalid(format!(
                            "light '{}': its image is {} x {} texels with {} values",
                            l.name,
                            im.width,
                            im.height,
                            im.rgb.len()
                        )));
                    }
                    if let Some(i) = im
                        .rgb
                        .iter()
                        .position(|c| c.iter().any(|v| !(v.is_finite() && *v >= 0.0)))
                    {
                        return Err(SceneError::Invalid(format!(
                            "light '{}': its image's texel ({}, {}) is {:?}: irradiance must be finite and >= 0",
                            l.name,
                            i % im.width as usize,
                            i / im.width as usize,
                            im.rgb[i]
                        )));
                    }
                }
            }
        }
        self.ambient.validate()?;
        if !self.camera.is_valid() {
            return Err(SceneError::Invalid(
                "camera has a non-finite transform or near plane, or a field of view outside (0, 180) degrees"
                    .into(),
            ));
        }
        Ok(())
    }
}

/// The single spectral band the transient cube records: a colour channel, or a
/// wavelength (colours upsampled to spectra, [`spectrum`]; dispersive indices read there).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Channel {
    Red,
    Green,
    Blue,
    /// A panchromatic band: Rec. 709 luminance weights of R, G, B.
    #[default]
    Gray,
    /// A narrow band at one wavelength.
    Wavelength(spectrum::Wavelength),
}

impl Channel {
    /// Every colour band, with the name [`Channel::name`] gives it.
    pub const ALL: [Channel; 4] = [Channel::Red, Channel::Green, Channel::Blue, Channel::Gray];

    /// The band's name in files and on the command line: `red`, `550nm`.
    pub fn name(self) -> String {
        match self {
            Channel::Red => "red".into(),
            Channel::Green => "green".into(),
            Channel::Blue => "blue".into(),
            Channel::Gray => "gray".into(),
            Channel::Wavelength(w) => w.name(),
        }
    }

    /// This band's value of a linear RGB triple (at a wavelength: the value there of the
    /// smooth spectrum of that colour, [`spectrum::Wavelength::pick`]).
    #[inline]
    pub fn pick(self, rgb: [f32; 3]) -> f32 {
        match self {
            Channel::Red => rgb[0],
            Channel::Green => rgb[1],
            Channel::Blue => rgb[2],
            Channel::Gray => 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2],
            Channel::Wavelength(w) => w.pick(rgb),
        }
    }

    /// [`Channel::pick`] for colours met per hit (a texture's): at a wavelength by the
    /// coefficient table ([`spectrum::Wavelength::pick_fast`]), else the same.
    #[inline]
    pub fn pick_texel(self, rgb: [f32; 3]) -> f32 {
        match self {
            Channel::Wavelength(w) => w.pick_fast(rgb),
            c => c.pick(rgb),
        }
    }

    /// The wavelength a dispersive index is read at in this band: its own, or the
    /// d line ([`spectrum::D_LINE_NM`]) for a colour band.
    pub fn index_wavelength_um(self) -> f64 {
        match self {
            Channel::Wavelength(w) => w.um(),
            _ => spectrum::D_LINE_NM * 1e-3,
        }
    }
}

impl std::fmt::Display for Channel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.name())
    }
}

/// A band name that is neither one of [`Channel::ALL`] nor a wavelength.
#[derive(Debug, thiserror::Error)]
#[error(
    "unknown channel '{0}' (known: red, green, blue, gray, or a wavelength such as 550nm in [360, 830] nm)"
)]
pub struct UnknownChannel(pub String);

impl std::str::FromStr for Channel {
    type Err = UnknownChannel;
    fn from_str(s: &str) -> Result<Channel, UnknownChannel> {
        if let Some(c) = Channel::ALL
            .into_iter()
            .find(|c| c.name().eq_ignore_ascii_case(s.trim()))
        {
            return Ok(c);
        }
        spectrum::Wavelength::parse(s)
            .map(Channel::Wavelength)
            .map_err(|_| UnknownChannel(s.to_string()))
    }
}

impl Serialize for Channel {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&self.name())
    }
}

impl<'de> Deserialize<'de> for Channel {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Channel, D::Error> {
        let s = String::deserialize(d)?;
        s.parse().map_err(serde::de::Error::custom)
    }
}

/// Why a scene could not be loaded. Messages name the problem and where it is.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    #[error("cannot read {path}: {source}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: not a valid glTF 2.0 file: {message}")]
    Gltf { path: String, message: String },
    #[error("{path}: requires extension {extension}, which tprf does not support")]
    UnsupportedExtension { path: String, extension: String },
    /// A Mitsuba 3 XML scene that cannot be read as tprf renders it: `location` is
    /// `FILE:LINE` of the element (or the file alone).
    #[error("{location}: {message}")]
    Mitsuba { location: String, message: String },
    #[error("unknown built-in scene '{0}' (known: {known})", known = builtin::NAMES.join(", "))]
    UnknownBuiltin(String),
    #[error("invalid scene: {0}")]
    Invalid(String),
    /// Too large for the memory left, or not a regular file (a device, a FIFO).
    #[error(transparent)]
    Budget(#[from] crate::budget::BudgetError),
}

/// Render settings a scene file carries beside its scene (a Mitsuba XML file's film,
/// sampler and integrator): a front end uses each where its user gave none. glTF files
/// and built-in scenes carry none.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FileSettings {
    /// Image width and height, pixels.
    pub width: Option<FileSetting<u64>>,
    pub height: Option<FileSetting<u64>>,
    /// Number of time bins.
    pub bins: Option<FileSetting<u64>>,
    /// Start of the time window, metres of optical path counted from the camera's near
    /// plane (mitransient's `start_opl`): [`FileSettings::t0_opl_m_for`] gives it for a
    /// render's time origin.
    pub t0_opl_m: Option<FileSetting<f64>>,
    /// The camera's near clip distance, metres (where the file's optical paths start).
    pub near_clip_m: Option<FileSetting<f64>>,
    /// Where the file's arrival times start, when it says (mitransient's `camera_unwarp`:
    /// [`TimeOrigin::FirstHit`]).
    pub time_origin: Option<FileSetting<TimeOrigin>>,
    /// When the pulse starts, when the file says (mitransient's
    /// `account_first_and_last_bounces` false: [`PulseOrigin::FirstHit`]).
    pub pulse_origin: Option<FileSetting<PulseOrigin>>,
    /// Bin width, metres of optical path (dt = width / c).
    pub dt_opl_m: Option<FileSetting<f64>>,
    /// Samples per pixel.
    pub spp: Option<FileSetting<u64>>,
    /// Largest number of scattering events on a path.
    pub max_bounces: Option<FileSetting<u32>>,
    /// Fewest scattering events of a recorded path (mitransient's
    /// `discard_direct_paths`, `filter_depth`, `filter_bounces`).
    pub min_bounces: Option<FileSetting<u32>>,
    /// mitransient's `phasor_hdr_film`: its `wl_mean` and `wl_sigma`, metres of
    /// optical path (the phasors to write: `export::phasor`).
    pub phasor_wl_mean_m: Option<FileSetting<f64>>,
    pub phasor_wl_sigma_m: Option<FileSetting<f64>>,
    /// The file asks for Stokes vectors (Mitsuba's `stokes` integrator around its
    /// transient one): a polarized render.
    pub polarized: Option<FileSetting<bool>>,
    /// An NLOS capture's settings (mitransient's `transient_nlos_path` with an
    /// `nlos_capture_meter` on the relay wall), for `tprf nlos`.
    pub nlos: Option<NlosFileSettings>,
    /// The file is an NLOS integrator watched by a camera (mitransient's
    /// `transient_nlos_path` with a perspective sensor and no capture meter): a scene
    /// `tprf render` renders, not a capture.
    pub nlos_view: bool,
}

/// What a Mitsuba NLOS scene says of its capture (see `scene::mitsuba`'s NLOS part):
/// each field where the file gives it, for the `tprf nlos` flags not given.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NlosFileSettings {
    /// The relay wall's object (its shape's `id`; `relay_wall` without one).
    pub relay_wall: Option<FileSetting<String>>,
    /// Sensor points along the wall's u and v (the capture meter's film, or its
    /// `original_film_width/height` for a confocal scan).
    pub grid: Option<FileSetting<[u64; 2]>>,
    /// `single`, `confocal` or `exhaustive` (the integrator's `capture_type`).
    pub capture_type: Option<FileSetting<String>>,
    /// SPAD and laser device positions, metres.
    pub sensor_origin: Option<FileSetting<[f64; 3]>>,
    pub laser_origin: Option<FileSetting<[f64; 3]>>,
    /// A single scan's laser point on the wall, metres (an older meter's
    /// `laser_lookat_pixel`).
    pub laser_point: Option<FileSetting<[f64; 3]>>,
    /// Times include the device-to-wall legs (`account_first_and_last_bounces`).
    pub device_legs: Option<FileSetting<bool>>,
    /// Time bins, bin width and start (metres of optical path) of the capture meter's film.
    pub bins: Option<FileSetting<u64>>,
    pub dt_opl_m: Option<FileSetting<f64>>,
    pub t0_opl_m: Option<FileSetting<f64>>,
    /// Samples per sensor point.
    pub spp: Option<FileSetting<u64>>,
    /// Scattering events in the hidden scene (the two on the wall not counted):
    /// `max_depth - 3`.
    pub hidden_bounces: Option<FileSetting<u32>>,
    /// Only paths of exactly this many scattering events (`filter_depth`, or
    /// `filter_bounces + 1`): mitransient's depth at its laser-sampled next-event
    /// estimate, the wall point, each hidden vertex and the laser's spot counted.
    pub depth_filter: Option<FileSetting<u32>>,
    /// `discard_direct_paths`: the paths from the wall straight to the laser's spot
    /// (2 scattering events, mitransient's depth 2) and shorter left out.
    pub discard_direct: Option<FileSetting<bool>>,
}

/// One setting of a scene file: its value and where it was read (`scene.xml:31
/// <integer name="width">`), for messages about it.
#[derive(Clone, Debug, PartialEq)]
pub struct FileSetting<T> {
    pub value: T,
    pub from: String,
}

impl FileSettings {
    /// The window's start for a render whose clock starts at `origin`, metres of optical
    /// path: the file's `start_opl` as it is for the near plane or the first hit (where
    /// mitransient counts from), `start_opl + near_clip` from the pinhole, so a bin holds
    /// the light of mitransient's bin on the image's axis (off the axis at angle a,
    /// mitransient's arrivals are earlier by `near_clip (1 / cos a - 1)` more: render
    /// with `TimeOrigin::NearPlane` for its cube bin for bin).
    pub fn t0_opl_m_for(&self, origin: TimeOrigin) -> Option<FileSetting<f64>> {
        let t0 = self.t0_opl_m.clone()?;
        match (&self.near_clip_m, origin) {
            (Some(near), TimeOrigin::Pinhole) if near.value != 0.0 => Some(FileSetting {
                value: t0.value + near.value,
                from: format!(
                    "{} + near_clip {} ({}: mitransient counts the optical path from the near plane; --time-origin near-plane renders its cube bin for bin)",
                    t0.from, near.value, near.from
                ),
            }),
            _ => Some(t0),
        }
    }

    /// The settings in words, one per line, for notes and metadata: `width 400
    /// (scene.xml:26 <integer name="width">)`.
    pub fn describe(&self) -> Vec<String> {
        fn line<T: std::fmt::Display>(name: &str, s: &Option<FileSetting<T>>) -> Option<String> {
            s.as_ref()
                .map(|s| format!("{name} {} ({})", s.value, s.from))
        }
        [
            line("width", &self.width),
            line("height", &self.height),
            line("bins", &self.bins),
            line("t0 (m of optical path)", &self.t0_opl_m),
            line("near clip (m)", &self.near_clip_m),
            line("time origin", &self.time_origin),
            line("pulse origin", &self.pulse_origin),
            line("dt (m of optical path)", &self.dt_opl_m),
            line("spp", &self.spp),
            line("max bounces", &self.max_bounces),
            line("min bounces", &self.min_bounces),
            line("phasor wl_mean (m)", &self.phasor_wl_mean_m),
            line("phasor wl_sigma (m)", &self.phasor_wl_sigma_m),
        ]
        .into_iter()
        .flatten()
        .collect()
    }
}

/// Whether `name` is a path to a Mitsuba XML scene (its extension is `.xml`, any case).
pub fn is_mitsuba_path(name: &str) -> bool {
    std::path::Path::new(name)
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("xml"))
}

/// The render settings the scene file `name` carries, read without loading the scene
/// (only a Mitsuba XML scene has any: [`mitsuba::mitsuba_file_settings`]; built-in and
/// glTF scenes: none).
pub fn file_settings(name: &str) -> Result<FileSettings, SceneError> {
    if name.starts_with("builtin:") || !is_mitsuba_path(name) {
        return Ok(FileSettings::default());
    }
    mitsuba::mitsuba_file_settings(std::path::Path::new(name))
}

/// Load a scene by name: `builtin:NAME`, a path to a `.gltf` / `.glb` file, or a path
/// to a Mitsuba 3 `.xml` scene.
pub fn load(name: &str) -> Result<Scene, SceneError> {
    load_with_settings(name).map(|(scene, _)| scene)
}

/// [`load`], with the render settings the file carries (only a Mitsuba XML scene has
/// any: see [`mitsuba`]).
pub fn load_with_settings(name: &str) -> Result<(Scene, FileSettings), SceneError> {
    match name.strip_prefix("builtin:") {
        Some(b) => builtin::load(b).map(|s| (s, FileSettings::default())),
        None if is_mitsuba_path(name) => mitsuba::load_mitsuba(std::path::Path::new(name)),
        None => {
            gltf_load::load_gltf(std::path::Path::new(name)).map(|s| (s, FileSettings::default()))
        }
    }
}
