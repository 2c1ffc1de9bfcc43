//! Mitsuba 3 (and mitransient) XML scenes: the subset that mitransient's examples and
//! typical transient scenes use, read into the same [`Scene`] as a glTF file, plus the
//! render settings the file carries ([`FileSettings`]: the film's size and time window,
//! the sampler's samples, the integrator's depth).
//!
//! Units: a Mitsuba scene unit is read as a metre (mitransient's optical path lengths
//! are in scene units, so a film's `start_opl` and `bin_width_opl` are metres of optical
//! path, and tprf's times are those over c). Emitters keep Mitsuba's radiometric units,
//! which are tprf's: a `point` or `spot` light's `intensity` is W/sr, an `area`
//! emitter's and `constant` emitter's `radiance` W m^-2 sr^-1, a `directional` emitter's
//! `irradiance` W/m^2. Colours stay RGB (linear): the cube's band picks from them as it
//! does for a glTF file; tprf's default band (gray: Rec. 709 luminance) is what
//! Mitsuba's monochrome variants (`llvm_ad_mono`, which mitransient's users render
//! with) compute from an RGB value.
//!
//! Read (in files: `xml` the format, `transform` the `<transform>` operations,
//! `meshes` the mesh files, `shapes`, `bsdf`, `emitters`, `sensor`):
//!
//! - the format: `<scene version>`, `<default>` and `$name`, `<include>`, `<ref>`,
//!   `<alias>`, `<path>`, `<transform>` (`translate`, `rotate`, `scale`, `lookat`,
//!   `matrix`), files of version < 2 upgraded as Mitsuba upgrades them;
//! - shapes `obj`, `ply`, `serialized`, `rectangle`, `cube`, `sphere`, `disk`,
//!   `cylinder` (the last three tessellated, their area kept), with `to_world`,
//!   `flip_normals`, `face_normals`, a `bsdf` and an `area` emitter;
//! - BSDFs `diffuse`, `twosided`, `dielectric`, `thindielectric`, `roughdielectric`,
//!   `conductor`, `roughconductor`, `plastic`, `roughplastic`, `principled`, `mask`,
//!   `null`, `bumpmap` and `normalmap` (their maps ignored), onto tprf's
//!   metallic-roughness material (`bsdf` says which are exact and which approximate;
//!   an approximation is noted in [`Scene::notes`]); textures `bitmap` (PNG, JPEG),
//!   `checkerboard`, and constant spectra;
//! - emitters `point`, `spot`, `area` (pulsed at t = 0), `directional` and `constant`
//!   (tprf's ambient group: steady light, never pulsed);
//! - the sensor `perspective` (`thinlens` as a pinhole), its film (`hdrfilm`,
//!   `transient_hdr_film`), sampler and the integrator (`path`, `transient_path`, and
//!   the volumetric path tracers, `transient_prbvolpath` among them: tprf renders a
//!   scene with media by its media path loop whatever the integrator);
//! - homogeneous media (`media`): a sensor's medium as the scene's, a shape's interior
//!   filling it, with an `isotropic` or `hg` phase.
//!
//! - mitransient's NLOS scenes (`transient_nlos_path`, an `nlos_capture_meter` on the
//!   relay wall, a `projector` laser): their capture settings for `tprf nlos` (`nlos`).
//!
//! **The rule for what is not read.** An element whose plugin tprf has no counterpart
//! for (`<bsdf type="hair">`, `<emitter type="envmap">`,
//! a heterogeneous `<medium>`) refuses the scene, with
//! the file, line and type: rendering it without would change what light exists or what
//! is measured. A property tprf does not use (a `<string name="filter_type">`, a
//! sensor's `near_clip`) or one whose meaning tprf approximates is loaded with a note
//! naming it and where it is (one note per kind of property, with a count).

mod bitmap;
mod bsdf;
mod emitters;
mod media;
mod meshes;
mod nlos;
mod prefetch;
mod sensor;
mod shapes;
mod transform;
mod xml;

use super::{
    AmbientLights, Camera, FileSettings, Material, PunctualLight, Scene, SceneError, SceneObject,
    Texture, Triangle, TriangleAttrs,
};
use glam::Vec3;
use std::collections::{BTreeMap, HashMap};
use std::path::Path;
use xml::{Loc, Parsed, err};

/// Vertical field of view of a camera framed from the scene bounds (no sensor).
const FRAMED_YFOV_RAD: f32 = std::f32::consts::FRAC_PI_4;

/// Load a Mitsuba 3 XML scene and the render settings it carries.
///
/// What the loader decided on its own (approximated materials, ignored properties, a
/// framed camera) is listed in [`Scene::notes`].
pub fn load_mitsuba(path: &Path) -> Result<(Scene, FileSettings), SceneError> {
    let parsed = xml::parse(path)?;
    let mut b = Builder::new(&parsed, path.display().to_string());
    b.add_scene()?;
    b.finish()
}

/// The render settings a Mitsuba 3 XML scene carries (its first sensor's film and
/// sampler, its integrator), read without loading its meshes or textures: what a front
/// end shows before the scene itself is loaded (the window's Open). The same values, and
/// the same errors for them, as [`load_mitsuba`]'s.
pub fn mitsuba_file_settings(path: &Path) -> Result<FileSettings, SceneError> {
    let parsed = xml::parse(path)?;
    let mut b = Builder::new(&parsed, path.display().to_string());
    let root = b.object(0);
    let (mut sensor, mut integrator) = (None, None);
    for (_, k) in root.children() {
        match b.object(k).tag {
            "sensor" if sensor.is_none() => sensor = Some(k),
            "integrator" => integrator = Some(k),
            _ => {}
        }
    }
    if let Some(k) = sensor {
        b.read_sensor(k)?;
    }
    if let Some(k) = integrator {
        b.read_integrator(k)?;
    }
    // A capture meter on a relay wall makes the file an NLOS capture scene (its fields
    // are read with the wall's shape, by the load).
    if parsed
        .objects
        .iter()
        .any(|o| o.tag == "sensor" && o.plugin == "nlos_capture_meter")
    {
        b.nlos();
    }
    b.settle_camera_nlos();
    Ok(b.settings)
}

/// A converted material and the `to_uv` of its texture (applied to the texture
/// coordinates of the triangles that use it).
#[derive(Clone, Copy, Debug)]
pub(super) struct MaterialSlot {
    index: u32,
    to_uv: Option<glam::DAffine2>,
}

/// What a shape's surface is: its BSDF object (or the default diffuse) and, for an area
/// light, its radiance.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
struct MaterialKey {
    bsdf: Option<usize>,
    radiance_bits: Option<[u64; 3]>,
    /// An angular emitter's beam width and cutoff.
    falloff_bits: Option<[u32; 2]>,
    /// The `<medium>` object filling the shape.
    medium: Option<usize>,
}

/// Accumulates the scene while the parsed objects are converted.
pub(super) struct Builder<'a> {
    parsed: &'a Parsed,
    file: String,
    triangles: Vec<Triangle>,
    attrs: Vec<TriangleAttrs>,
    /// Shapes with an `id`, by their triangles.
    objects: Vec<SceneObject>,
    materials: Vec<Material>,
    material_of: HashMap<MaterialKey, MaterialSlot>,
    textures: Vec<Texture>,
    /// Scene texture of each texture object converted so far.
    texture_of: HashMap<usize, u32>,
    lights: Vec<PunctualLight>,
    /// The projector's position (an NLOS capture's laser device).
    projector_origin: Option<crate::scene::FileSetting<[f64; 3]>>,
    ambient: AmbientLights,
    camera: Option<Camera>,
    /// The medium the sensor sits in: the scene's.
    medium: Option<crate::scene::Medium>,
    settings: FileSettings,
    notes: Vec<String>,
    /// Approximations and ignored properties, grouped: (what, first place, count).
    grouped: BTreeMap<String, (Loc, usize)>,
    degenerate: usize,
    /// Bytes of triangles the budget was last found to allow, plus the growth let in
    /// before it is asked again (see `shapes::Builder::place`).
    budget_unchecked_to: u64,
    /// Objects being converted, outermost first (nesting bound).
    depth: usize,
    /// Mesh and bitmap files decoded ahead, in parallel.
    prefetched: prefetch::Prefetched,
}

impl<'a> Builder<'a> {
    fn new(parsed: &'a Parsed, file: String) -> Self {
        Builder {
            parsed,
            file,
            triangles: Vec::new(),
            attrs: Vec::new(),
            objects: Vec::new(),
            materials: Vec::new(),
            material_of: HashMap::new(),
            textures: Vec::new(),
            texture_of: HashMap::new(),
            lights: Vec::new(),
            projector_origin: None,
            ambient: AmbientLights::default(),
            camera: None,
            medium: None,
            settings: FileSettings::default(),
            notes: Vec::new(),
            grouped: BTreeMap::new(),
            degenerate: 0,
            budget_unchecked_to: 0,
            depth: 0,
            prefetched: prefetch::Prefetched::default(),
        }
    }

    /// Object `k`, marked as visited (its unread properties will be noted).
    fn object(&self, k: usize) -> &'a xml::Object {
        let parsed: &'a Parsed = self.parsed;
        let o = &parsed.objects[k];
        o.visited.set(true);
        o
    }

    /// A note about `what` at `loc`, grouped with the same notes elsewhere.
    fn note_at(&mut self, loc: &Loc, what: String) {
        self.grouped
            .entry(what)
            .and_modify(|(_, n)| *n += 1)
            .or_insert((loc.clone(), 1));
    }

    /// Refuse `o`: tprf has no counterpart for its plugin.
    fn unsupported(o: &xml::Object, why: &str) -> SceneError {
        let why = if why.is_empty() {
            String::new()
        } else {
            format!(": {why}")
        };
        err(&o.loc, format!("{} is not supported{why}", o.describe()))
    }

    /// The scene's top-level objects, in file order.
    fn add_scene(&mut self) -> Result<(), SceneError> {
        let root = self.object(0);
        let mut sensor_seen = false;
        let mut integrator_seen = false;
        // The top-level shapes, whose files are decoded ahead in batches, and the bitmap
        // textures, decoded with the first batch.
        let parsed: &'a Parsed = self.parsed;
        let shapes: Vec<usize> = root
            .children()
            .map(|(_, k)| k)
            .filter(|&k| parsed.objects[k].tag == "shape")
            .collect();
        let mut ahead: Vec<usize> = (0..parsed.objects.len())
            .filter(|&k| parsed.objects[k].tag == "texture")
            .collect();
        let mut shapes_done = 0;
        for (p, k) in root.children() {
            p.used.set(true);
            let o = self.object(k);
            match o.tag {
                "shape" => {
                    if shapes_done % prefetch::SHAPES_AHEAD == 0 {
                        let end = (shapes_done + prefetch::SHAPES_AHEAD).min(shapes.len());
                        ahead.extend_from_slice(&shapes[shapes_done..end]);
                        self.prefetched.decode(parsed, &self.file, &ahead);
                        ahead.clear();
                    }
                    shapes_done += 1;
                    self.add_shape(k)?
                }
                "emitter" => self.add_emitter(k)?,
                "sensor" if sensor_seen => {
                    self.note_at(
                        &o.loc,
                        format!(
                            "{} after the first sensor ignored: tprf renders one camera",
                            o.describe()
                        ),
                    );
                }
                "sensor" => {
                    sensor_seen = true;
                    self.read_sensor(k)?;
                }
                "integrator" => {
                    integrator_seen = true;
                    self.read_integrator(k)?;
                }
                // Used where they are referenced.
                "bsdf" | "texture" => o.visited.set(false),
                // Used where they are referenced (a sensor, a shape, a medium).
                "medium" | "phase" | "volume" if o.id.is_some() => o.visited.set(false),
                "medium" | "phase" | "volume" => {
                    self.note_at(
                        &o.loc,
                        format!(
                            "{} at the scene's top level without an id ignored (a medium is used from a sensor or a shape)",
                            o.describe()
                        ),
                    );
                }
                _ => {
                    self.note_at(
                        &o.loc,
                        format!("{} at the scene's top level ignored", o.describe()),
                    );
                }
            }
        }
        if !integrator_seen {
            self.notes.push(format!(
                "no <integrator> in {}: Mitsuba's default path tracer (max_depth -1, every bounce)",
                self.file
            ));
        }
        Ok(())
    }

    /// The notes of properties nobody read, grouped by kind.
    fn note_unread(&mut self) {
        let parsed: &'a Parsed = self.parsed;
        for o in parsed.objects.iter().filter(|o| o.visited.get()) {
            for p in o.props.iter().filter(|p| !p.used.get()) {
                let what = match p.value {
                    xml::Value::Object(k) => {
                        let c = &parsed.objects[k];
                        format!(
                            "<{} type=\"{}\"> in <{} type=\"{}\"> ignored",
                            c.tag, c.plugin, o.tag, o.plugin
                        )
                    }
                    _ => format!(
                        "<{} name=\"{}\"> of <{} type=\"{}\"> ignored (tprf does not use it)",
                        p.value.tag(),
                        p.name,
                        o.tag,
                        o.plugin
                    ),
                };
                self.note_at(&p.loc, what);
            }
        }
    }

    /// The scene, with a camera and a light added where the file has none, and the notes
    /// gathered.
    fn finish(mut self) -> Result<(Scene, FileSettings), SceneError> {
        let camera_nlos = self.settle_camera_nlos();
        if let (Some(n), Some(p)) = (&mut self.settings.nlos, self.projector_origin.take()) {
            n.laser_origin.get_or_insert(p);
        }
        self.note_unread();
        let file = self.file.clone();
        let mut notes = std::mem::take(&mut self.notes);
        for (what, (loc, n)) in std::mem::take(&mut self.grouped) {
            notes.push(match n {
                1 => format!("{loc}: {what}"),
                n => format!("{loc} (and {} more): {what}", n - 1),
            });
        }
        let mut scene = Scene {
            name: file.clone(),
            triangles: self.triangles,
            attrs: self.attrs,
            materials: self.materials,
            textures: self.textures,
            lights: self.lights,
            camera: Camera::look_at(Vec3::Z, Vec3::ZERO, FRAMED_YFOV_RAD),
            ambient: self.ambient,
            medium: self.medium,
            objects: self.objects,
            notes,
        };
        if scene.triangles.is_empty() {
            scene.notes.push(format!("no triangles in {file}"));
        }
        if camera_nlos {
            for l in &scene.lights {
                if let Some(a) = nlos::spot_area_m2(&scene, l) {
                    scene.notes.push(format!(
                        "projector '{}' lights a spot of {a:.4e} m^2: mitransient's transient_nlos_path joins paths to the spot as to a point of unit area, so its cube is this cube x {:.4e} (1 / the spot's area)",
                        l.name,
                        1.0 / a
                    ));
                }
            }
        }
        // An NLOS capture scene has its capture meter and laser instead (tprf nlos):
        // the framed camera and the light below are not said to its user.
        let nlos = self.settings.nlos.is_some();
        match self.camera {
            Some(c) => scene.camera = c,
            None => {
                if !nlos {
                    scene.notes.push(format!(
                        "no sensor in {file}: framed a camera from the scene bounds"
                    ));
                }
                scene.camera = scene.framed_camera(FRAMED_YFOV_RAD);
            }
        }
        let emits = scene.attrs.iter().any(|a| {
            scene
                .materials
                .get(a.material as usize)
                .is_some_and(Material::is_emissive)
        });
        if scene.lights.is_empty() && !emits && !nlos {
            let light = emitters::colocated_light(&scene);
            scene.notes.push(format!(
                "no pulsed emitter in {file}: added a point light at the camera ({:.3} W/sr: a white Lambertian at the scene centre has radiance ~1)",
                light.intensity_w_per_sr[0]
            ));
            scene.lights.push(light);
        }
        if self.degenerate > 0 {
            scene.notes.push(format!(
                "dropped {} degenerate triangles (zero area)",
                self.degenerate
            ));
        }
        scene.validate().map_err(|e| match e {
            SceneError::Invalid(m) => SceneError::Invalid(format!("{file}: {m}")),
            e => e,
        })?;
        Ok((scene, self.settings))
    }
}
