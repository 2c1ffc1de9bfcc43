//! Built-in scenes, by name (`builtin:NAME`).
//!
//! - `cornell`: the Cornell box (0.555 m cube, open front), a point light under the
//!   ceiling, a camera in front. The default scene: a first picture of a light pulse
//!   filling a room.
//! - `canopy`: the paper's airborne LiDAR example (its Figure 4 read as LiDAR, section 6):
//!   a partly transparent foliage layer (A) over opaque ground (B), in 3-D, seen from
//!   100 m above by a camera with a co-located point light (the laser), under a sun
//!   (an ambient directional light, [`CANOPY_SUN_W_PER_M2`], 60 degrees high: never in
//!   the TPRF, rendered as the cube's ambient image).
//! - `nlos-z`: tal's NLOS quickstart: a 2 m x 2 m relay wall (the plane z = 0, facing
//!   +z; object and material `relay_wall`) and a Z-shaped planar object, 0.8 m across,
//!   1 m in front of it (object `Z`), both white Lambertians of albedo 1 (tal's `white`).
//! - `nlos-shapes`: the same wall with three shapes at different depths: a 0.3 m box
//!   (0.8 m away), a sphere of radius 0.15 m (1.1 m) and a tilted 0.4 m square (1.3 m).
//!
//!   Both NLOS scenes have a point light at tal's device position and a camera looking at
//!   the setup from the side, so a camera render shows it.
//! - `fog`: a road in fog seen by a car's LiDAR: a pedestrian, two cars and a sign at
//!   22-78 m, a pulsed laser beside the camera, fog of visibility 50 m ([`fog`]).
//! - `flim`: fluorescence-lifetime imaging: two dye spots of the same colour and
//!   lifetimes 1 ns and 4 ns on a slide under a pulsed laser ([`flim`]).
//!
//! World space is glTF's: metres, +Y up; the scenes are deterministic (a fixed-seed
//! PRNG), so a render of them is reproducible. Triangles are stored grouped by material,
//! in material order, so a glTF export (one mesh per material) keeps their order.

use super::{
    AmbientLights, Camera, DirectionalLight, Material, PunctualLight, Scene, SceneError,
    SceneObject, Triangle, TriangleAttrs,
};
use glam::{Affine3A, Vec2, Vec3, Vec3A};

/// Names accepted after `builtin:`.
pub const NAMES: &[&str] = &["cornell", "canopy", "nlos-z", "nlos-shapes", "fog", "flim"];

pub mod flim;
pub mod fog;

/// Build a built-in scene.
pub fn load(name: &str) -> Result<Scene, SceneError> {
    let scene = match name {
        "cornell" => cornell(),
        "canopy" => canopy(),
        "nlos-z" => nlos_z(),
        "nlos-shapes" => nlos_shapes(),
        "fog" => fog::fog(),
        "flim" => flim::flim(),
        _ => return Err(SceneError::UnknownBuiltin(name.to_string())),
    };
    scene.validate()?;
    Ok(scene)
}

/// Triangles and their attributes, kept in step.
#[derive(Default)]
struct Builder {
    triangles: Vec<Triangle>,
    attrs: Vec<TriangleAttrs>,
}

impl Builder {
    fn triangle(&mut self, p: [Vec3; 3], normals: Option<[Vec3; 3]>, material: u32) {
        self.triangles.push(Triangle { p });
        self.attrs.push(TriangleAttrs {
            normals,
            uv: [Vec2::ZERO; 3],
            material,
        });
    }

    /// A planar quad `q0 q1 q2 q3` (in order around its edge) as two triangles, wound so
    /// that the front face (counter-clockwise, geometric normal) points along `facing`.
    fn quad(&mut self, q: [Vec3; 4], facing: Vec3, material: u32) {
        let n = (q[1] - q[0]).cross(q[2] - q[0]);
        let q = if n.dot(facing) < 0.0 {
            [q[0], q[3], q[2], q[1]]
        } else {
            q
        };
        self.triangle([q[0], q[1], q[2]], None, material);
        self.triangle([q[0], q[2], q[3]], None, material);
    }

    /// A prism standing on the footprint `f` (4 points in order, in the XZ plane) from
    /// height `y0` to `y1` (metres): the 4 sides and the top, facing out. No bottom.
    fn prism(&mut self, f: [(f32, f32); 4], y0: f32, y1: f32, material: u32) {
        let centroid = f
            .iter()
            .fold(Vec3::ZERO, |s, &(x, z)| s + Vec3::new(x, 0.0, z))
            / 4.0;
        for i in 0..4 {
            let (ax, az) = f[i];
            let (bx, bz) = f[(i + 1) % 4];
            let out = Vec3::new(0.5 * (ax + bx), 0.0, 0.5 * (az + bz)) - centroid;
            self.quad(
                [
                    Vec3::new(ax, y0, az),
                    Vec3::new(bx, y0, bz),
                    Vec3::new(bx, y1, bz),
                    Vec3::new(ax, y1, az),
                ],
                out,
                material,
            );
        }
        self.quad(f.map(|(x, z)| Vec3::new(x, y1, z)), Vec3::Y, material);
    }

    fn append(&mut self, other: Builder) {
        self.triangles.extend(other.triangles);
        self.attrs.extend(other.attrs);
    }
}

/// Inner size of the Cornell box, metres (the classic 555 mm).
pub const CORNELL_SIZE_M: f32 = 0.555;

/// The Cornell box: a 0.555 m cube, x in [-0.2775, 0.2775] (red wall at -x, green at
/// +x), y in [0, 0.555] (floor at 0), z in [-0.2775, 0.2775] (back wall at -z, open at
/// +z). White floor, ceiling and back wall; the two classic blocks (0.165 m and 0.33 m
/// tall, footprints from the original Cornell data). All pure Lambertian, double-sided;
/// the walls face into the box.
///
/// Light: a white point light of 0.5 W/sr, 0.05 m under the centre of the ceiling. The
/// centre of the back wall then has a direct radiance of 0.75/pi x 0.5 x cos/r^2 =
/// 0.72 W/(m^2 sr), the floor centre 0.47 W/(m^2 sr).
///
/// Camera: the classic one, 0.8 m in front of the opening at mid height, looking along
/// -z, yfov = 2 atan(12.5/35) = 39.3 deg (a 35 mm lens on 25 mm film): the opening just
/// fills a square image.
fn cornell() -> Scene {
    const WHITE: u32 = 0;
    const RED: u32 = 1;
    const GREEN: u32 = 2;
    let l = CORNELL_SIZE_M;
    let h = 0.5 * l;
    let v = Vec3::new;

    let mut white = Builder::default();
    // Floor, ceiling, back wall.
    white.quad(
        [v(-h, 0.0, h), v(h, 0.0, h), v(h, 0.0, -h), v(-h, 0.0, -h)],
        Vec3::Y,
        WHITE,
    );
    white.quad(
        [v(-h, l, h), v(h, l, h), v(h, l, -h), v(-h, l, -h)],
        Vec3::NEG_Y,
        WHITE,
    );
    white.quad(
        [v(-h, 0.0, -h), v(h, 0.0, -h), v(h, l, -h), v(-h, l, -h)],
        Vec3::Z,
        WHITE,
    );
    // The blocks, from the original data (millimetres, x to the left, z into the box,
    // origin at the front-right corner): x = (278 - x_mm) / 1000, z = (279.6 - z_mm) / 1000.
    let classic = |x_mm: f32, z_mm: f32| ((278.0 - x_mm) / 1000.0, (279.6 - z_mm) / 1000.0);
    let short = [
        classic(130.0, 65.0),
        classic(82.0, 225.0),
        classic(240.0, 272.0),
        classic(290.0, 114.0),
    ];
    let tall = [
        classic(423.0, 247.0),
        classic(265.0, 296.0),
        classic(314.0, 456.0),
        classic(472.0, 406.0),
    ];
    white.prism(short, 0.0, 0.165, WHITE);
    white.prism(tall, 0.0, 0.330, WHITE);

    let mut b = white;
    b.quad(
        [v(-h, 0.0, h), v(-h, 0.0, -h), v(-h, l, -h), v(-h, l, h)],
        Vec3::X,
        RED,
    );
    b.quad(
        [v(h, 0.0, h), v(h, 0.0, -h), v(h, l, -h), v(h, l, h)],
        Vec3::NEG_X,
        GREEN,
    );

    let eye = v(0.0, h, h + 0.8);
    Scene {
        name: "builtin:cornell".into(),
        triangles: b.triangles,
        attrs: b.attrs,
        materials: vec![
            Material::lambertian("white", [0.75, 0.75, 0.75]),
            Material::lambertian("red", [0.63, 0.065, 0.05]),
            Material::lambertian("green", [0.14, 0.45, 0.09]),
        ],
        textures: Vec::new(),
        lights: vec![PunctualLight {
            name: "ceiling point light".into(),
            position: v(0.0, l - 0.05, 0.0),
            intensity_w_per_sr: [0.5; 3],
            spot: None,
            projector: None,
        }],
        camera: Camera::look_at(eye, v(0.0, h, 0.0), 2.0 * (12.5f32 / 35.0).atan()),
        ambient: Default::default(),
        objects: Vec::new(),
        medium: None,
        notes: Vec::new(),
    }
}

/// splitmix64: a tiny deterministic PRNG, so the built-in scenes never change.
struct SplitMix64(u64);

impl SplitMix64 {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    fn unit(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }

    /// Uniform in [lo, hi).
    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.unit()
    }
}

/// Irradiance of the canopy scene's sun on a surface facing it, W/m^2 (clear-sky
/// noon order of magnitude, all wavelengths in the one band).
pub const CANOPY_SUN_W_PER_M2: f32 = 1000.0;

/// Half the side of the canopy scene's ground patch, metres (the patch is 40 m x 40 m).
pub const CANOPY_HALF_SIZE_M: f32 = 20.0;
/// Height of the canopy scene's camera and laser above the mean ground level, metres.
pub const CANOPY_SENSOR_HEIGHT_M: f32 = 100.0;

/// Ground height of the canopy scene at (x, z), metres: gentle swells of about +-1 m.
fn terrain_height(x: f32, z: f32) -> f32 {
    use std::f32::consts::TAU;
    0.6 * (TAU * x / 27.0 + 0.7).sin() * (TAU * z / 33.0 + 1.9).sin()
        + 0.35 * (TAU * (0.6 * x + 0.8 * z) / 14.0 + 0.3).sin()
}

/// Unit normal of [`terrain_height`] at (x, z) (from its analytic gradient).
fn terrain_normal(x: f32, z: f32) -> Vec3 {
    use std::f32::consts::TAU;
    let (a, b) = (TAU * x / 27.0 + 0.7, TAU * z / 33.0 + 1.9);
    let c = (TAU * (0.6 * x + 0.8 * z) / 14.0 + 0.3).cos() * 0.35 * TAU / 14.0;
    let dhdx = 0.6 * TAU / 27.0 * a.cos() * b.sin() + 0.6 * c;
    let dhdz = 0.6 * TAU / 33.0 * a.sin() * b.cos() + 0.8 * c;
    Vec3::new(-dhdx, 1.0, -dhdz).normalize()
}

/// A tree of the canopy scene: trunk at (x, z), an ellipsoidal crown.
struct Tree {
    x: f32,
    z: f32,
    /// Crown centre height above the local ground, metres.
    crown_y: f32,
    /// Crown horizontal and vertical radii, metres.
    radius_h: f32,
    radius_v: f32,
}

/// The airborne LiDAR scene (the paper's Figure 4 in 3-D: foliage layer A, ground B).
///
/// - Ground: 40 m x 40 m (x, z in [-20, 20]), gently undulating (+-1 m), a grid of
///   0.5 m cells (12 800 triangles) with smooth analytic vertex normals; grey Lambertian,
///   albedo 0.3 (soil in a single, e.g. near-infrared, band).
/// - Foliage: 20 tree crowns (ellipsoids 3.2-4.8 m in horizontal radius, centred ~16 m
///   above the ground with 3-3.5 m vertical half-axes: leaves between 12 m and 20 m)
///   filled with ~11 000 leaf quads 0.3-0.6 m across, mostly horizontal; grey
///   Lambertian, albedo 0.5. Seen from above they cover about half of the view (0.49),
///   with gaps through each crown, between crowns, and a clearing of open ground at +x
///   (x > 4 m, z > -9 m).
/// - Trunks: 0.3 m square prisms from just below the ground into each crown, albedo 0.4.
/// - Sensor: a camera 100 m above the patch centre looking straight down (image top =
///   -z, image right = +x), yfov 20 deg (it sees ~35 m x 35 m of ground), and the laser:
///   a white point light of 30 000 W/sr at the camera position. Ground radiance at nadir:
///   0.3/pi x 30 000 / 100^2 = 0.29 W/(m^2 sr); a horizontal leaf at 84 m: 0.68.
///
/// The round trip to the ground is ~200 m (667 ns), to the canopy top ~160 m: a pixel
/// over the canopy records two returns ~50-130 ns apart (the paper's A-B separation).
fn canopy() -> Scene {
    const GROUND: u32 = 0;
    const BARK: u32 = 1;
    const LEAF: u32 = 2;
    const CELLS: usize = 80;
    let half = CANOPY_HALF_SIZE_M;
    let cell = 2.0 * half / CELLS as f32;

    // Ground grid.
    let mut ground = Builder::default();
    let grid = |i: usize, j: usize| {
        let (x, z) = (-half + i as f32 * cell, -half + j as f32 * cell);
        (Vec3::new(x, terrain_height(x, z), z), terrain_normal(x, z))
    };
    for j in 0..CELLS {
        for i in 0..CELLS {
            let (p00, n00) = grid(i, j);
            let (p10, n10) = grid(i + 1, j);
            let (p01, n01) = grid(i, j + 1);
            let (p11, n11) = grid(i + 1, j + 1);
            // Counter-clockwise seen from above (+Y): x right, z towards the viewer.
            ground.triangle([p00, p01, p11], Some([n00, n01, n11]), GROUND);
            ground.triangle([p00, p11, p10], Some([n00, n11, n10]), GROUND);
        }
    }

    // Trees: random positions with a minimum spacing (as many as fit, up to 22: 20 do),
    // none in the clearing.
    let mut rng = SplitMix64(0x7470_7266_6361_6e6f);
    let in_clearing = |x: f32, z: f32| x > 4.0 && z > -9.0;
    let mut trees: Vec<Tree> = Vec::new();
    for _ in 0..20_000 {
        if trees.len() == 22 {
            break;
        }
        let x = rng.range(-17.0, 17.0);
        let z = rng.range(-17.0, 17.0);
        let radius_h = rng.range(3.2, 4.8);
        let radius_v = rng.range(3.0, 3.5);
        let crown_y = rng.range(16.0 - (4.0 - radius_v), 16.0 + (4.0 - radius_v));
        let crowded = trees
            .iter()
            .any(|t| (t.x - x).hypot(t.z - z) < 0.85 * (t.radius_h + radius_h));
        if in_clearing(x, z) || crowded {
            continue;
        }
        trees.push(Tree {
            x,
            z,
            crown_y,
            radius_h,
            radius_v,
        });
    }

    // Trunks.
    let mut bark = Builder::default();
    for t in &trees {
        let g = terrain_height(t.x, t.z);
        let w = 0.15;
        bark.prism(
            [
                (t.x - w, t.z - w),
                (t.x + w, t.z - w),
                (t.x + w, t.z + w),
                (t.x - w, t.z + w),
            ],
            g - 0.3,
            g + t.crown_y,
            BARK,
        );
    }

    // Leaves: uniform in each crown's volume, as many as give a mean leaf area index
    // (projected leaf area per crown disk area) of ~2. A leaf's mean area is
    // E[len^2] E[wid/len] = 0.21 x 0.8 = 0.168 m^2, times E[cos tilt] ~ 0.95.
    const LEAF_AREA_INDEX: f32 = 2.0;
    const MEAN_PROJECTED_LEAF_AREA_M2: f32 = 0.16;
    let mut leaves = Builder::default();
    for t in &trees {
        let g = terrain_height(t.x, t.z);
        let disk = std::f32::consts::PI * t.radius_h * t.radius_h;
        let count = (LEAF_AREA_INDEX * disk / MEAN_PROJECTED_LEAF_AREA_M2).round() as usize;
        for _ in 0..count {
            let (u, v, w) = loop {
                let (u, v, w) = (
                    rng.range(-1.0, 1.0),
                    rng.range(-1.0, 1.0),
                    rng.range(-1.0, 1.0),
                );
                if u * u + v * v + w * w <= 1.0 {
                    break (u, v, w);
                }
            };
            let centre = Vec3::new(
                t.x + t.radius_h * u,
                g + t.crown_y + t.radius_v * v,
                t.z + t.radius_h * w,
            );
            // Mostly horizontal: tilt up to 70 deg, weighted towards 0 (mean 17.5 deg).
            let tilt = 70f32.to_radians() * rng.unit() * rng.unit();
            let azimuth = rng.range(0.0, std::f32::consts::TAU);
            let n = Vec3::new(
                tilt.sin() * azimuth.cos(),
                tilt.cos(),
                tilt.sin() * azimuth.sin(),
            );
            let (t1, t2) = n.any_orthonormal_pair();
            let spin = rng.range(0.0, std::f32::consts::TAU);
            let a = t1 * spin.cos() + t2 * spin.sin();
            let b = n.cross(a);
            let len = rng.range(0.3, 0.6);
            let wid = len * rng.range(0.6, 1.0);
            let (a, b) = (0.5 * len * a, 0.5 * wid * b);
            leaves.quad(
                [
                    centre - a - b,
                    centre + a - b,
                    centre + a + b,
                    centre - a + b,
                ],
                n,
                LEAF,
            );
        }
    }

    let mut all = ground;
    all.append(bark);
    all.append(leaves);

    let sensor = Vec3::new(0.0, CANOPY_SENSOR_HEIGHT_M, 0.0);
    // Looking down -Y; camera +Y (image up) = world -Z, camera +X = world +X.
    let camera = Camera {
        world_from_camera: Affine3A::from_cols(
            Vec3A::X,
            Vec3A::NEG_Z,
            Vec3A::Y,
            Vec3A::from(sensor),
        ),
        fov_rad: 20f32.to_radians(),
        fov_axis: crate::scene::FovAxis::Y,
        near_m: crate::scene::camera::DEFAULT_NEAR_M,
    };
    Scene {
        name: "builtin:canopy".into(),
        triangles: all.triangles,
        attrs: all.attrs,
        materials: vec![
            Material::lambertian("ground", [0.3; 3]),
            Material::lambertian("bark", [0.4; 3]),
            Material::lambertian("leaves", [0.5; 3]),
        ],
        textures: Vec::new(),
        lights: vec![PunctualLight {
            name: "laser".into(),
            position: sensor,
            intensity_w_per_sr: [30_000.0; 3],
            spot: None,
            projector: None,
        }],
        camera,
        ambient: AmbientLights {
            directional: vec![DirectionalLight {
                name: "sun".into(),
                // 60 degrees above the horizon, from +X: travelling down and toward -X.
                direction: Vec3::new(-0.5, -0.75f32.sqrt(), 0.0),
                irradiance_w_per_m2: [CANOPY_SUN_W_PER_M2; 3],
            }],
            ..Default::default()
        },
        objects: Vec::new(),
        medium: None,
        notes: Vec::new(),
    }
}

/// Half the side of the NLOS scenes' relay wall, metres (the wall is 2 m x 2 m).
pub const NLOS_WALL_HALF_M: f32 = 1.0;
/// Distance of `nlos-z`'s Z from the relay wall, metres.
pub const NLOS_Z_DEPTH_M: f32 = 1.0;

/// The outline of tal's Z (`examples/render/meshes/Z.obj`), metres, in the plane
/// z = const: 0.8 m square, bars 0.103 m thick, as its six triangles.
const Z_TRIANGLES: [[(f32, f32); 3]; 6] = [
    [(0.364_878, 0.296_774), (-0.4, 0.4), (0.364_878, 0.4)],
    [(0.364_878, 0.296_774), (-0.164_553, 0.296_774), (-0.4, 0.4)],
    [
        (-0.164_553, 0.296_774),
        (0.164_553, -0.296_774),
        (-0.4, 0.4),
    ],
    [
        (0.4, -0.4),
        (0.164_553, -0.296_774),
        (-0.164_553, 0.296_774),
    ],
    [(0.4, -0.4), (-0.4, -0.296_774), (0.164_553, -0.296_774)],
    [(0.4, -0.4), (-0.4, -0.4), (-0.4, -0.296_774)],
];

/// The relay wall, the NLOS scenes' light and camera; `hidden` adds the hidden geometry
/// (material 1, `white`) and returns its named parts.
fn nlos_scene(name: &str, hidden: impl FnOnce(&mut Builder) -> Vec<(String, usize)>) -> Scene {
    let h = NLOS_WALL_HALF_M;
    let v = Vec3::new;
    let mut b = Builder::default();
    b.quad(
        [v(-h, -h, 0.0), v(h, -h, 0.0), v(h, h, 0.0), v(-h, h, 0.0)],
        Vec3::Z,
        0,
    );
    let mut objects = vec![SceneObject {
        name: "relay_wall".into(),
        triangles: 0..b.triangles.len(),
    }];
    let mut start = b.triangles.len();
    for (name, end) in hidden(&mut b) {
        objects.push(SceneObject {
            name,
            triangles: start..end,
        });
        start = end;
    }
    // tal's default device position.
    let device = v(-0.5, 0.0, 0.25);
    Scene {
        name: format!("builtin:{name}"),
        triangles: b.triangles,
        attrs: b.attrs,
        materials: vec![
            Material::lambertian("relay_wall", [1.0; 3]),
            Material::lambertian("white", [1.0; 3]),
        ],
        textures: Vec::new(),
        lights: vec![PunctualLight {
            name: "laser".into(),
            position: device,
            intensity_w_per_sr: [1.0; 3],
            spot: None,
            projector: None,
        }],
        camera: Camera::look_at(v(2.6, 1.4, 2.4), v(0.0, 0.0, 0.6), 40f32.to_radians()),
        ambient: AmbientLights::default(),
        objects,
        medium: None,
        notes: Vec::new(),
    }
}

/// tal's quickstart scene (see the module doc).
fn nlos_z() -> Scene {
    nlos_scene("nlos-z", |b| {
        let z = NLOS_Z_DEPTH_M;
        for t in Z_TRIANGLES {
            let p = t.map(|(x, y)| Vec3::new(x, y, z));
            // Wound to face the wall (-z).
            let n = (p[1] - p[0]).cross(p[2] - p[0]);
            let p = if n.z > 0.0 { [p[0], p[2], p[1]] } else { p };
            b.triangle(p, None, 1);
        }
        vec![("Z".into(), b.triangles.len())]
    })
}

/// Three shapes at different depths (see the module doc).
fn nlos_shapes() -> Scene {
    nlos_scene("nlos-shapes", |b| {
        let v = Vec3::new;
        let mut parts = Vec::new();
        // A 0.3 m box centred at (-0.35, -0.25, 0.8 + 0.15).
        let (c, r) = (v(-0.35, -0.25, 0.95), 0.15);
        for axis in 0..3 {
            for sign in [-1.0f32, 1.0] {
                let unit = |k: usize| {
                    let mut e = Vec3::ZERO;
                    e[k % 3] = 1.0;
                    e
                };
                let n = unit(axis) * sign;
                let (e1, e2) = (unit(axis + 1) * r, unit(axis + 2) * r);
                let f = c + n * r;
                b.quad([f - e1 - e2, f + e1 - e2, f + e1 + e2, f - e1 + e2], n, 1);
            }
        }
        parts.push(("box".to_string(), b.triangles.len()));
        // A sphere of radius 0.15 m at (0.35, 0.3, 1.1): 12 x 24 latitude-longitude cells.
        let (c, r) = (v(0.35, 0.3, 1.1), 0.15f32);
        let (rows, cols) = (12, 24);
        let at = |i: usize, j: usize| {
            let th = std::f32::consts::PI * i as f32 / rows as f32;
            let ph = std::f32::consts::TAU * j as f32 / cols as f32;
            c + r * v(th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin())
        };
        for i in 0..rows {
            for j in 0..cols {
                let (p00, p01, p10, p11) = (at(i, j), at(i, j + 1), at(i + 1, j), at(i + 1, j + 1));
                let out = (p00 + p11) * 0.5 - c;
                if i > 0 {
                    let n = (p01 - p00).cross(p10 - p00);
                    let t = if n.dot(out) < 0.0 {
                        [p00, p10, p01]
                    } else {
                        [p00, p01, p10]
                    };
                    b.triangle(t, None, 1);
                }
                if i + 1 < rows {
                    let n = (p11 - p01).cross(p10 - p01);
                    let t = if n.dot(out) < 0.0 {
                        [p01, p10, p11]
                    } else {
                        [p01, p11, p10]
                    };
                    b.triangle(t, None, 1);
                }
            }
        }
        parts.push(("sphere".to_string(), b.triangles.len()));
        // A 0.4 m square tilted 30 degrees about x, centred at (0.3, -0.4, 1.3).
        let (c, hs) = (v(0.3, -0.4, 1.3), 0.2f32);
        let (s30, c30) = (0.5f32, 0.75f32.sqrt());
        let (e1, e2) = (v(hs, 0.0, 0.0), v(0.0, hs * c30, hs * s30));
        b.quad(
            [c - e1 - e2, c + e1 - e2, c + e1 + e2, c - e1 + e2],
            Vec3::NEG_Z,
            1,
        );
        parts.push(("plate".to_string(), b.triangles.len()));
        parts
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_builtin_is_valid_and_clean() {
        for name in NAMES {
            let s = load(name).unwrap();
            assert_eq!(s.triangles.len(), s.attrs.len());
            assert!(!s.triangles.is_empty());
            for (i, t) in s.triangles.iter().enumerate() {
                assert!(t.area_m2() > 1e-6, "{name}: triangle {i} is degenerate");
            }
            // Grouped by material, in material order.
            assert!(
                s.attrs.windows(2).all(|w| w[0].material <= w[1].material),
                "{name}: triangles not grouped by material"
            );
            if let Some(n) = s.attrs.iter().find_map(|a| a.normals) {
                assert!(n.iter().all(|n| (n.length() - 1.0).abs() < 1e-5));
            }
        }
        assert!(matches!(load("nope"), Err(SceneError::UnknownBuiltin(_))));
    }

    #[test]
    fn builtins_are_deterministic() {
        for name in NAMES {
            let (a, b) = (load(name).unwrap(), load(name).unwrap());
            assert_eq!(a.triangles, b.triangles);
            assert_eq!(a.attrs, b.attrs);
        }
    }

    #[test]
    fn terrain_normal_matches_finite_differences() {
        for &(x, z) in &[(0.0, 0.0), (3.3, -7.1), (-15.0, 12.5)] {
            let e = 1e-2;
            let dx = (terrain_height(x + e, z) - terrain_height(x - e, z)) / (2.0 * e);
            let dz = (terrain_height(x, z + e) - terrain_height(x, z - e)) / (2.0 * e);
            let fd = Vec3::new(-dx, 1.0, -dz).normalize();
            assert!((fd - terrain_normal(x, z)).length() < 1e-3);
        }
    }
}
