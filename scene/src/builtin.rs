//! Built-in procedural scenes (no files, fully deterministic).
//!
//! - `grids`: thesis Fig. 3.6 — a 0.6×0.6 m Rect light 3 m above (1 m behind the grids, seen from the camera) a checker-textured ground (14×12 m so it fills the frame), three rotated grids
//!   of thin bars at 0.6, 0.8 and 1.05 m casting overlapping penumbrae toward the camera; the light is out of view.
//! - `curved`: thesis Fig. 3.8 — curved occluders (sphere, torus) over a wavy, smooth-shaded receiver.
//! - `heavy`: the grids' occluders and light over a displaced terrain plus many spheres (>100k triangles),
//!   for throughput benchmarks.
//! - `cornell`: thesis Figs. 4.7, 4.8, 4.11 — a 2 m Cornell-box-like room (red and green side walls,
//!   checker-textured back wall, open front), a 0.5 m square ceiling light, a glossy tall box (Phong
//!   m = 20) and a glossy sphere (m = 12): diffuse and glossy indirect light, colour bleeding, a curved
//!   receiver.
//! - `chess`: thesis Fig. 5.1's CHESS in spirit — lathe-turned pieces, diffuse and glossy, near, at and
//!   beyond the focus distance on a fine checkerboard ground seen at a grazing angle, one rectangular
//!   light; the defocus test scene. Recommended lens: [`chess::FOCUS_DISTANCE`], [`chess::APERTURE_RADIUS`].
//! - `spheres`: issue 12's ray-tracing benchmark scene — a 20×20 field of UV spheres on a ground under one
//!   area light, 409,604 triangles, for traversal throughput against Embree (see `builtin/spheres.rs`).
//! - `motion`: thesis Fig. B.1 in spirit — a translating multi-frequency textured plate, a moving ball
//!   shadowing it, a static bridge shadowing it, a rotating textured cube, a static floor, one area
//!   light; the motion-blur test scene (see `builtin/motion.rs`).
//! - `envmap`: thesis Fig. 6.7 in spirit — a diffuse sphere and a Phong-64 torus on a large diffuse
//!   plane lit only by the procedural `builtin:sky` environment map (sun, sky, clouds, windows); the
//!   environment-lighting test scene (see `builtin/envmap.rs`). `envmap_light` adds one area light.
//! - `envmap_far`: `envmap_virtual` with the torus 1 km below the ground (mixed reality's no-influence
//!   test).
//! - `envmap_empty`: `envmap`'s camera and map with no triangles at all — mixed reality's empty
//!   virtual world (its composite is the camera image exactly); any other pipeline renders the sky.
//! - `envmap_real` / `envmap_virtual`: `envmap` split for the mixed-reality round trip (issue 15) — the
//!   ground and sphere (rendered with their AOVs, they stand in for a captured real world), and the
//!   torus alone (the virtual object inserted into it); same camera and map.
//!
//!
//! **The scene suite** ([`SUITE`], issue 16; `wedge bench --suite` runs a pipeline over it): ten small
//! scenes (a few thousand triangles each, one `Rect` area light out of view, a camera), each stressing
//! one part of the analysis, so a filter tuned on one scene is measured on the others:
//!
//! - `grids`: thin occluders at several heights — three rotated grids of bars whose penumbrae
//!   overlap; a mildly textured ground.
//! - `suite_slats`: thin occluders at several heights in an open scene — parallel slats at 0.3, 0.65
//!   and 1.1 m (crisp to washed-out penumbrae over the same pixels) and a sphere (see
//!   `builtin/slats.rs`).
//! - `suite_grate`: a small light and fine, regular occluders — a 6 cm-pitch grate 0.25 m up casts a
//!   sharp, high-frequency shadow grid, under a coarser turned grate (see `builtin/grate.rs`).
//! - `suite_contact`: contact shadows under a large light — a cube, a sphere, a lying cylinder, a
//!   leaning plank and tiny cubes on the ground, where the occluder distance goes to 0 (see
//!   `builtin/contact.rs`).
//! - `suite_near_light`: occluders close to the light — a louvre 0.2 m under the light (tiny
//!   `s_min`: the rate and width formulas at their extreme) over a table whose shadow mixes
//!   occluder depths (see `builtin/near_light.rs`).
//! - `curved`: curved receivers and occluders — a wavy, smooth-shaded ground under a sphere and a
//!   torus.
//! - `suite_textured`: textured receivers — a high-contrast 6 cm checker floor and a checkered wall
//!   under bar and torus shadows: the albedo multiplies after filtering and must stay sharp (see
//!   `builtin/textured.rs`).
//! - `suite_glossy`: glossy receivers — a Phong floor seen at a low angle, Phong sphere and box, a
//!   bright box it reflects (see `builtin/glossy.rs`).
//! - `cornell`: the thesis's indirect-light box — colour bleeding, glossy objects, open front.
//! - `suite_room`: a closed room seen from inside — table, cabinet, bench, one small ceiling light;
//!   no path escapes, so indirect light matters everywhere (see `builtin/room.rs`).
//!
//! **The defocus suite** ([`DEFOCUS_SUITE`], issue 35; `wedge bench --suite` picks it for a pipeline
//! whose node names it, `NodeKind::bench_suite`: Defocus): nine scenes named `dof_*`, each with its own
//! thin lens in its camera, described in `builtin/defocus_suite.rs`.
//!
//! **The motion suite** ([`MOTION_SUITE`], issue 35; picked for a pipeline with a Motion node): eight
//! scenes named `mo_*` moving over the shutter (0, 1), described in `builtin/motion_suite.rs`.
//!
//! **The environment suite** ([`ENVIRONMENT_SUITE`], issue 35; picked for a pipeline with an
//! Environment node): eight scenes named `env_*`, each lit by its own environment map alone
//! (`sun`, `overcast`, `sunset`, `sky`, `studio`), described in `builtin/environment_suite.rs`.
//!
//! Mesh generators (ground planes, panels, boxes, bars, cylinders, spheres, tori, lathes, rectangular
//! lights) live in `builtin/mesh.rs` so new built-ins reuse them; each scene larger than a screenful
//! lives in its own file under `builtin/`.

pub mod chess;
mod contact;
mod defocus_suite;
mod environment_suite;
pub mod envmap;
mod glossy;
mod grate;
mod mesh;
pub mod motion;
mod motion_suite;
mod near_light;
mod room;
mod slats;
pub mod spheres;
mod textured;

use std::f32::consts::TAU;

use glam::{Mat4, Quat, Vec2, Vec3};

use crate::data::SceneData;
use crate::{Camera, Material, Scene, SceneError, Texture};
use mesh::{add_box, add_ground, add_sphere, add_square_light, add_torus, parametric, smooth_tri};

pub const NAMES: &[&str] = &[
    "grids",
    "curved",
    "heavy",
    "cornell",
    "chess",
    "spheres",
    "motion",
    "envmap",
    "envmap_light",
    "envmap_real",
    "envmap_virtual",
    "envmap_far",
    "envmap_empty",
    "suite_slats",
    "suite_grate",
    "suite_contact",
    "suite_near_light",
    "suite_textured",
    "suite_glossy",
    "suite_room",
    "dof_foreground",
    "dof_background",
    "dof_receding",
    "dof_bokeh",
    "dof_thin",
    "dof_glossy",
    "dof_wide",
    "dof_tiny",
    "dof_room",
    "mo_fast_thin",
    "mo_rotating",
    "mo_shadow_caster",
    "mo_slow",
    "mo_sliding_wall",
    "mo_approach",
    "mo_crossing",
    "mo_glossy",
    "env_sun",
    "env_overcast",
    "env_glossy",
    "env_courtyard",
    "env_sunset",
    "env_slats",
    "env_studio",
    "env_curved",
];

/// The scene suite of issue 16, in the order `wedge bench --suite` runs it: each built-in's name and
/// what it tests (one or two sentences, for reports). Every name is in [`NAMES`].
pub const SUITE: &[(&str, &str)] = &[
    (
        "grids",
        "Thin occluders at several heights: three rotated grids of 3 cm bars at 0.6-1.05 m under a 0.6 m light, \
         overlapping penumbrae over a mildly checkered ground (thesis Fig. 3.6).",
    ),
    (
        "suite_slats",
        "Thin occluders at three heights in an open scene: parallel slats at 0.3, 0.65 and 1.1 m (penumbrae 9-60 cm, \
         crisp and washed out over the same pixels) and a sphere under a 0.6 m light 2.2 m up.",
    ),
    (
        "suite_grate",
        "A small (0.15 m) light and fine occluders: a 6 cm-pitch grate 0.25 m up casts a sharp, high-frequency \
         shadow grid, overlapped by a coarser turned grate at 0.8 m.",
    ),
    (
        "suite_contact",
        "Contact shadows under a large (1.6 m) light: a cube, a sphere, a lying cylinder, a leaning plank and tiny \
         cubes on the ground, where the occluder distance (and the penumbra) goes to zero.",
    ),
    (
        "suite_near_light",
        "Occluders close to the light: a louvre 0.2 m under a 0.8 m light (s = d1/d2 - 1 ~ 0.08, the rate and width \
         formulas at their extreme) over a table whose shadow mixes occluder depths.",
    ),
    (
        "curved",
        "Curved receivers and occluders: a wavy, smooth-shaded ground under a sphere and a torus (thesis Fig. 3.8), \
         open to the sky.",
    ),
    (
        "suite_textured",
        "Textured receivers: a high-contrast 6 cm checker floor and a checkered wall under bar and torus shadows; \
         the albedo multiplies after filtering and must stay as sharp as in the reference.",
    ),
    (
        "suite_glossy",
        "Glossy receivers: a Phong (m = 40) floor seen at a low angle, a Phong sphere and box, a bright box it \
         reflects (glossy indirect light; for SoftShadows, diffuse-only, a dark receiver).",
    ),
    (
        "cornell",
        "The thesis's indirect-light box (Figs. 4.7-4.11): colour bleeding from red and green walls, a glossy box \
         and sphere, a checkered back wall, open front.",
    ),
    (
        "suite_room",
        "A closed room seen from inside: table, cabinet, bench and a small ceiling light; no path escapes, so \
         indirect light matters everywhere (the floor under the table is lit only by bounces).",
    ),
];

/// The defocus suite (issue 35, `builtin/defocus_suite.rs`): each scene's camera carries its own thin
/// lens, which `wedge bench --suite` sets on the pipeline's Defocus node.
pub const DEFOCUS_SUITE: &[(&str, &str)] = &[
    (
        "dof_foreground",
        "Foreground out of focus over sharp texture: posts and a lattice 0.7-1.1 m from the lens (circles of \
         confusion of tens of pixels) in front of a fine checker wall and floor in focus at 4.6 m.",
    ),
    (
        "dof_background",
        "Background out of focus behind a sharp subject: boxes and a sphere in focus at 1.7 m, a fine checker wall \
         6 m away blurred behind their edges.",
    ),
    (
        "dof_receding",
        "A deep receding checker floor from under the camera to 20 m at a grazing angle, focus 3 m: the circle of \
         confusion sweeps from large to zero to large along every column.",
    ),
    (
        "dof_bokeh",
        "Bright small features: 5 cm white beads 4-6 m behind a sharp textured box, on a dark wall, blurred into \
         discs a few lens samples find.",
    ),
    (
        "dof_thin",
        "Thin occluders across the focal plane: 2.5 cm rods tilted in depth from ~1 to ~5 m, in focus in the \
         middle, over a textured floor they shadow.",
    ),
    (
        "dof_glossy",
        "Glossy receivers through the lens: a Phong (m = 50) floor and Phong spheres (m 15-80) at four depths, \
         a checker wall behind.",
    ),
    (
        "dof_wide",
        "A large aperture (0.15 m): boxes and spheres from 1.4 to 7 m on a checker floor, focus 3.6 m; circles of \
         confusion of tens of pixels, the widest filters and most primary rays.",
    ),
    (
        "dof_tiny",
        "A tiny aperture (3 mm): a textured table with boxes and bars, nearly a pinhole (circles under a pixel); \
         the factored filter must not lose to plain Monte Carlo.",
    ),
    (
        "dof_room",
        "suite_room through a 4 cm lens focused on the table's sphere (2.4 m): the thesis's ROOM-like scene, \
         closed, indirect light everywhere.",
    ),
];

/// The motion suite (issue 35, `builtin/motion_suite.rs`): each scene moves over the camera's
/// shutter (0, 1); lights and camera at rest.
pub const MOTION_SUITE: &[(&str, &str)] = &[
    ("mo_fast_thin", "Fast thin movers: 6 cm posts sweeping 0.4 m over the shutter across a fine checker floor (blur many times wider than the mover)."),
    ("mo_rotating", "A rotating textured object: a spinning checkered sphere and a spinning box (velocity varies across the object and flips across its axis)."),
    ("mo_shadow_caster", "A moving shadow caster over static texture: a ball sweeping 0.6 m over a fine checker; the shadow blurs, the texture must stay sharp."),
    ("mo_slow", "Slow motion: a box, a ball and bars moving 1-2 cm over the shutter (blur under two pixels); the filters must not lose to plain Monte Carlo."),
    ("mo_sliding_wall", "A textured wall (6 cm checks) sliding 6 cm sideways behind a static fence that shadows it: the texture moves, the shadow stays."),
    ("mo_approach", "Objects moving toward the camera (0.3-0.7 m over the shutter): radial image velocities and blur growing with speed."),
    ("mo_crossing", "Twelve small cubes at different speeds and directions crossing one another over a checker floor."),
    ("mo_glossy", "Glossy movers: a Phong ball sliding and a Phong box turning on a glossy floor before a checker wall (glossy indirect light over the shutter)."),
];

/// The environment suite (issue 35, `builtin/environment_suite.rs`): each scene lit by one
/// environment map alone.
pub const ENVIRONMENT_SUITE: &[(&str, &str)] = &[
    ("env_sun", "A sphere, a box and a post under builtin:sun (a 0.5 degree sun at 30000): high-frequency shadows, B_e far above sky's."),
    ("env_overcast", "The same objects under builtin:overcast (CIE overcast, no sun): the smoothest light; contact shadows must stay."),
    ("env_glossy", "Glossy receivers under builtin:sky: a Phong-32 floor and spheres of exponent 8, 64 and 256 reflecting the sun and windows."),
    ("env_courtyard", "An enclosed courtyard (3 m walls, open top) under builtin:sun seen from inside: most of the sky occluded, one sunlit wall."),
    ("env_sunset", "Posts on a fine checker under builtin:sunset (sun 6 degrees up): long thin shadows across texture."),
    ("env_slats", "A pergola of thin slats under builtin:sun: stripes of sun and shade 2 m below the occluders."),
    ("env_studio", "A product shot under builtin:studio: a glossy torus (m 96) and sphere on a sweep lit by soft boxes."),
    ("env_curved", "Twenty small spheres (6-12 cm) on a plain ground under builtin:overcast: the curvature term where occlusion is small."),
];

/// A family of scene suites: which scenes `wedge bench --suite` runs a pipeline over, picked from the
/// pipeline's nodes (`wedge_graph::NodeKind::bench_suite`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SuiteFamily {
    /// Soft shadows, indirect light, AO: [`SUITE`] (issue 16).
    Shadows,
    /// Depth of field: [`DEFOCUS_SUITE`], each scene with its own lens.
    Defocus,
    /// Motion blur: [`MOTION_SUITE`], each scene moving over its camera's shutter.
    Motion,
    /// Environment lighting: [`ENVIRONMENT_SUITE`], each scene with its own map.
    Environment,
}

impl SuiteFamily {
    pub const ALL: [SuiteFamily; 4] =
        [SuiteFamily::Shadows, SuiteFamily::Defocus, SuiteFamily::Motion, SuiteFamily::Environment];

    pub fn name(self) -> &'static str {
        match self {
            SuiteFamily::Shadows => "shadows",
            SuiteFamily::Defocus => "defocus",
            SuiteFamily::Motion => "motion",
            SuiteFamily::Environment => "environment",
        }
    }
    pub fn parse(s: &str) -> Option<SuiteFamily> {
        SuiteFamily::ALL.into_iter().find(|f| f.name() == s)
    }
    /// The scenes and what each tests, in run order.
    pub fn scenes(self) -> &'static [(&'static str, &'static str)] {
        match self {
            SuiteFamily::Shadows => SUITE,
            SuiteFamily::Defocus => DEFOCUS_SUITE,
            SuiteFamily::Motion => MOTION_SUITE,
            SuiteFamily::Environment => ENVIRONMENT_SUITE,
        }
    }
}

/// What the suite scene `name` tests (any family's suite); `None` for a built-in outside every
/// suite or an unknown name.
pub fn describe(name: &str) -> Option<&'static str> {
    SuiteFamily::ALL.iter().flat_map(|f| f.scenes()).find(|(n, _)| *n == name).map(|(_, d)| *d)
}

/// The names of the soft-shadow suite's scenes, in order.
pub fn suite_names() -> impl Iterator<Item = &'static str> {
    SUITE.iter().map(|(n, _)| *n)
}

pub(crate) fn builtin_data(name: &str) -> Result<SceneData, SceneError> {
    match name {
        "grids" => Ok(grids()),
        "curved" => Ok(curved()),
        "heavy" => Ok(heavy()),
        "cornell" => Ok(cornell()),
        "chess" => Ok(chess::chess()),
        "spheres" => Ok(spheres::spheres()),
        "motion" => Ok(motion::motion()),
        "envmap" => Ok(envmap::envmap(false)),
        "envmap_light" => Ok(envmap::envmap(true)),
        "envmap_real" => {
            Ok(envmap::envmap_parts(envmap::Parts { real: true, virtual_objects: false, light: false, far: false }))
        }
        "envmap_virtual" => {
            Ok(envmap::envmap_parts(envmap::Parts { real: false, virtual_objects: true, light: false, far: false }))
        }
        "envmap_far" => {
            Ok(envmap::envmap_parts(envmap::Parts { real: false, virtual_objects: true, light: false, far: true }))
        }
        "envmap_empty" => {
            Ok(envmap::envmap_parts(envmap::Parts { real: false, virtual_objects: false, light: false, far: false }))
        }
        "suite_slats" => Ok(slats::slats()),
        "suite_grate" => Ok(grate::grate()),
        "suite_contact" => Ok(contact::contact()),
        "suite_near_light" => Ok(near_light::near_light()),
        "suite_textured" => Ok(textured::textured()),
        "suite_glossy" => Ok(glossy::glossy()),
        "suite_room" => Ok(room::room()),
        "dof_foreground" => Ok(defocus_suite::dof_foreground()),
        "dof_background" => Ok(defocus_suite::dof_background()),
        "dof_receding" => Ok(defocus_suite::dof_receding()),
        "dof_bokeh" => Ok(defocus_suite::dof_bokeh()),
        "dof_thin" => Ok(defocus_suite::dof_thin()),
        "dof_glossy" => Ok(defocus_suite::dof_glossy()),
        "dof_wide" => Ok(defocus_suite::dof_wide()),
        "dof_tiny" => Ok(defocus_suite::dof_tiny()),
        "dof_room" => Ok(defocus_suite::dof_room()),
        "mo_fast_thin" => Ok(motion_suite::mo_fast_thin()),
        "mo_rotating" => Ok(motion_suite::mo_rotating()),
        "mo_shadow_caster" => Ok(motion_suite::mo_shadow_caster()),
        "mo_slow" => Ok(motion_suite::mo_slow()),
        "mo_sliding_wall" => Ok(motion_suite::mo_sliding_wall()),
        "mo_approach" => Ok(motion_suite::mo_approach()),
        "mo_crossing" => Ok(motion_suite::mo_crossing()),
        "mo_glossy" => Ok(motion_suite::mo_glossy()),
        "env_sun" => Ok(environment_suite::env_sun()),
        "env_overcast" => Ok(environment_suite::env_overcast()),
        "env_glossy" => Ok(environment_suite::env_glossy()),
        "env_courtyard" => Ok(environment_suite::env_courtyard()),
        "env_sunset" => Ok(environment_suite::env_sunset()),
        "env_slats" => Ok(environment_suite::env_slats()),
        "env_studio" => Ok(environment_suite::env_studio()),
        "env_curved" => Ok(environment_suite::env_curved()),
        _ => Err(SceneError::UnknownBuiltin { name: name.to_string(), known: NAMES.join(", ") }),
    }
}

pub(crate) fn builtin(name: &str) -> Result<Scene, SceneError> {
    let mut scene = builtin_data(name)?.into_scene(name)?;
    // The scenes that carry a map: the `envmap` family its `sky`, the environment suite its own.
    let map = if name.starts_with("envmap") { Some(envmap::MAP) } else { environment_suite::map_of(name) };
    if let Some(map) = map {
        scene.set_environment(Some(crate::EnvironmentMap::open(map)?));
    }
    Ok(scene)
}

/// A Phong material: diffuse `kd`, grey specular `ks`, exponent `m` (the suites' glossy surfaces).
fn phong(name: &str, kd: Vec3, ks: f32, m: f32) -> Material {
    Material { specular: Vec3::splat(ks), phong_exponent: m, ..Material::diffuse(name, kd) }
}

/// A pinhole camera at `position` looking at `look_at` (+y up) with a `vfov_deg` vertical field of view.
fn pinhole(position: Vec3, look_at: Vec3, vfov_deg: f32) -> Camera {
    Camera {
        position,
        look_at,
        up: Vec3::Y,
        vfov_deg,
        aperture_radius: 0.0,
        focus_distance: 0.0,
        shutter_open: 0.0,
        shutter_close: 0.0,
    }
}

/// Three layered, mutually rotated grids of 4 cm bars (x bars below z bars, so no coplanar faces).
fn add_grids(d: &mut SceneData) {
    const SEGMENT: f32 = 0.1;
    let m = d.add_material(Material::diffuse("bars", Vec3::splat(0.5)), false);
    let t = 0.03;
    // Under a 0.6 m light 3 m up, penumbrae are 0.6·h/(3 − h) = 0.14–0.26 m wide, comparable to the
    // bar spacing, so the three grids' shadows overlap into intricate patterns; heights within a factor
    // 1.8 keep the spread of occluder depths per pixel (s_max/s_min, eq. 3.21) in the thesis's range.
    for (height, angle_deg, spacing, count) in
        [(0.6f32, 0.0f32, 0.22f32, 7i32), (0.8, 30.0, 0.26, 6), (1.05, 60.0, 0.30, 5)]
    {
        let o = d.new_object();
        let rot = Quat::from_rotation_y(angle_deg.to_radians());
        let half_len = spacing * count as f32 * 0.5 + 0.1;
        for k in 0..count {
            let off = (k as f32 - (count - 1) as f32 * 0.5) * spacing;
            // Each bar is built from short boxes: a long, rotated bar has a huge axis-aligned box,
            // and 36 of them overlapping made every shadow ray test most of the scene (measured
            // 1 Mray/s on one core); segments keep BVH boxes tight.
            let segments = (2.0 * half_len / SEGMENT).ceil() as i32;
            let seg_half = half_len / segments as f32;
            for k in 0..segments {
                let along = -half_len + (2 * k + 1) as f32 * seg_half;
                let xbar = Mat4::from_rotation_translation(
                    rot,
                    rot * Vec3::new(along, 0.0, off) + Vec3::new(0.0, height + 0.5 * t, 0.0),
                );
                add_box(d, xbar, Vec3::new(seg_half, 0.5 * t, 0.5 * t), m, o);
                let zbar = Mat4::from_rotation_translation(
                    rot,
                    rot * Vec3::new(off, 0.0, along) + Vec3::new(0.0, height + 1.5 * t, 0.0),
                );
                add_box(d, zbar, Vec3::new(0.5 * t, 0.5 * t, seg_half), m, o);
            }
        }
    }
}

fn grids() -> SceneData {
    let mut d = SceneData::default();
    // Mild checker (0.55/0.75 in linear units) so texture-after-filter is exercised without dominating.
    d.textures.push(Texture::checker(64, 8, 0.55, 0.75));
    let ground =
        d.add_material(Material { base_color_texture: Some(0), ..Material::diffuse("ground", Vec3::ONE) }, false);
    let o = d.new_object();
    // 14 m × 12 m so the ground fills the whole frame from the default camera (a 6 m square would leave
    // the top ~17% of the image empty); uv = position/2 m with 8 checks per uv unit → 25 cm squares.
    add_ground(&mut d, (-7.0, 7.0, -7.0, 5.0), 0.5, ground, o);
    add_grids(&mut d);
    // The light sits 1 m behind the grids (seen from the camera) so their shadows fall toward the
    // camera, in front of the grids rather than hidden under them.
    add_square_light(&mut d, 60.0, Vec3::new(0.0, 3.0, -1.0), 0.6);
    d.camera = Some(Camera {
        position: Vec3::new(0.0, 2.3, 3.4),
        look_at: Vec3::new(0.0, 0.0, 0.5),
        up: Vec3::Y,
        vfov_deg: 45.0,
        aperture_radius: 0.0,
        focus_distance: 0.0,
        shutter_open: 0.0,
        shutter_close: 0.0,
    });
    d
}

fn wavy(x: f32, z: f32) -> (f32, Vec3) {
    let y = 0.1 * (2.0 * x).sin() * (2.0 * z).cos();
    let dx = 0.2 * (2.0 * x).cos() * (2.0 * z).cos();
    let dz = -0.2 * (2.0 * x).sin() * (2.0 * z).sin();
    (y, Vec3::new(-dx, 1.0, -dz).normalize())
}

fn curved() -> SceneData {
    let mut d = SceneData::default();
    let ground = d.add_material(Material::diffuse("ground", Vec3::splat(0.7)), false);
    let o = d.new_object();
    // 10 m × 9.5 m (fills the frame from the camera below), 160×152 cells ≈ 6 cm: smooth enough that
    // the interpolated normals, not the facets, shape the shading.
    parametric(&mut d, 160, 152, ground, o, |u, v| {
        let (x, z) = (-5.0 + 10.0 * u, -5.5 + 9.5 * v);
        let (y, n) = wavy(x, z);
        (Vec3::new(x, y, z), n)
    });
    let red = d.add_material(Material::diffuse("sphere", Vec3::new(0.7, 0.35, 0.3)), false);
    let o = d.new_object();
    add_sphere(&mut d, Vec3::new(-0.6, 0.9, 0.2), 0.35, 32, 64, red, o);
    let blue = d.add_material(Material::diffuse("torus", Vec3::new(0.3, 0.4, 0.7)), false);
    let o = d.new_object();
    let xf = Mat4::from_rotation_translation(Quat::from_rotation_x(0.5), Vec3::new(0.7, 0.7, -0.1));
    add_torus(&mut d, xf, 0.4, 0.1, blue, o);
    add_square_light(&mut d, 10.0, Vec3::new(0.0, 3.0, 0.0), 1.0);
    d.camera = Some(Camera {
        position: Vec3::new(0.0, 3.4, 3.2),
        look_at: Vec3::new(0.0, 0.2, 0.0),
        up: Vec3::Y,
        vfov_deg: 45.0,
        aperture_radius: 0.0,
        focus_distance: 0.0,
        shutter_open: 0.0,
        shutter_close: 0.0,
    });
    d
}

fn heavy() -> SceneData {
    let mut d = SceneData::default();
    let ground = d.add_material(Material::diffuse("terrain", Vec3::splat(0.65)), false);
    let o = d.new_object();
    // 200×200 cells = 80k triangles of gently displaced terrain (kept below the grids' lowest bar).
    parametric(&mut d, 200, 200, ground, o, |u, v| {
        let (x, z) = (-4.0 + 8.0 * u, -4.0 + 8.0 * v);
        let h = |x: f32, z: f32| 0.06 * (3.0 * x).sin() * (2.5 * z).cos() + 0.03 * (7.0 * x + 5.0 * z).sin();
        let e = 1e-3;
        let n = Vec3::new(-(h(x + e, z) - h(x - e, z)) / (2.0 * e), 1.0, -(h(x, z + e) - h(x, z - e)) / (2.0 * e));
        (Vec3::new(x, h(x, z), z), n.normalize())
    });
    add_grids(&mut d);
    add_square_light(&mut d, 10.0, Vec3::new(0.0, 3.0, 0.0), 1.0);
    // 12 spheres × ~7.7k triangles, on a ring outside the light's footprint.
    for k in 0..12 {
        let m =
            d.add_material(Material::diffuse(&format!("sphere{k}"), Vec3::new(0.4 + 0.04 * k as f32, 0.5, 0.6)), false);
        let o = d.new_object();
        let a = k as f32 / 12.0 * TAU;
        add_sphere(&mut d, Vec3::new(2.6 * a.cos(), 0.45, 2.6 * a.sin()), 0.3, 40, 96, m, o);
    }
    d.camera = Some(Camera {
        position: Vec3::new(0.0, 3.6, 5.5),
        look_at: Vec3::new(0.0, 0.0, 0.3),
        up: Vec3::Y,
        vfov_deg: 50.0,
        aperture_radius: 0.0,
        focus_distance: 0.0,
        shutter_open: 0.0,
        shutter_close: 0.0,
    });
    d
}

fn cornell() -> SceneData {
    let mut d = SceneData::default();
    d.textures.push(Texture::checker(64, 8, 0.45, 0.85));
    // Walls: (corners counter-clockwise seen from inside, inward normal, material).
    let white = d.add_material(Material::diffuse("white", Vec3::splat(0.75)), false);
    let red = d.add_material(Material::diffuse("red", Vec3::new(0.7, 0.12, 0.1)), false);
    let green = d.add_material(Material::diffuse("green", Vec3::new(0.12, 0.55, 0.12)), false);
    let back = d.add_material(
        Material { base_color_texture: Some(0), ..Material::diffuse("back", Vec3::new(0.85, 0.8, 0.7)) },
        false,
    );
    let (lo, hi, top) = (-1.0f32, 1.0f32, 2.0f32);
    let walls = [
        // floor, ceiling, back, left, right
        (
            [Vec3::new(lo, 0.0, lo), Vec3::new(hi, 0.0, lo), Vec3::new(hi, 0.0, hi), Vec3::new(lo, 0.0, hi)],
            Vec3::Y,
            white,
        ),
        (
            [Vec3::new(lo, top, lo), Vec3::new(hi, top, lo), Vec3::new(hi, top, hi), Vec3::new(lo, top, hi)],
            -Vec3::Y,
            white,
        ),
        (
            [Vec3::new(lo, 0.0, lo), Vec3::new(hi, 0.0, lo), Vec3::new(hi, top, lo), Vec3::new(lo, top, lo)],
            Vec3::Z,
            back,
        ),
        (
            [Vec3::new(lo, 0.0, lo), Vec3::new(lo, 0.0, hi), Vec3::new(lo, top, hi), Vec3::new(lo, top, lo)],
            Vec3::X,
            red,
        ),
        (
            [Vec3::new(hi, 0.0, lo), Vec3::new(hi, 0.0, hi), Vec3::new(hi, top, hi), Vec3::new(hi, top, lo)],
            -Vec3::X,
            green,
        ),
    ];
    for (p, n, m) in walls {
        let o = d.new_object();
        // uv = 1 per metre of the wall's first two axes (8 checks per uv unit → 25 cm squares on the back wall).
        let uv = p.map(|q| {
            let r = q - p[0];
            Vec2::new((r.x + r.z).abs(), r.y.abs().max((r.z * n.y).abs())) * 0.5
        });
        for idx in [[0, 1, 2], [0, 2, 3]] {
            smooth_tri(&mut d, idx.map(|k| p[k]), [n; 3], idx.map(|k| uv[k]), m, o);
        }
    }
    // Glossy tall box (Phong m = 20) and glossy sphere (m = 12), thesis Fig. 4.8.
    let box_mat = d.add_material(
        Material {
            specular: Vec3::splat(0.35),
            phong_exponent: 20.0,
            ..Material::diffuse("glossy box", Vec3::new(0.5, 0.45, 0.35))
        },
        false,
    );
    let o = d.new_object();
    let xf = Mat4::from_rotation_translation(Quat::from_rotation_y(0.35), Vec3::new(-0.4, 0.6, -0.35));
    add_box(&mut d, xf, Vec3::new(0.28, 0.6, 0.28), box_mat, o);
    let sphere_mat = d.add_material(
        Material {
            specular: Vec3::splat(0.4),
            phong_exponent: 12.0,
            ..Material::diffuse("glossy sphere", Vec3::new(0.15, 0.25, 0.5))
        },
        false,
    );
    let o = d.new_object();
    add_sphere(&mut d, Vec3::new(0.45, 0.35, 0.25), 0.35, 24, 48, sphere_mat, o);
    add_square_light(&mut d, 25.0, Vec3::new(0.0, 1.98, 0.0), 0.5);
    d.camera = Some(Camera {
        position: Vec3::new(0.0, 1.0, 3.9),
        look_at: Vec3::new(0.0, 1.0, 0.0),
        up: Vec3::Y,
        vfov_deg: 38.0,
        aperture_radius: 0.0,
        focus_distance: 0.0,
        shutter_open: 0.0,
        shutter_close: 0.0,
    });
    d
}
