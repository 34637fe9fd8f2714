//! `wedge export-scene`: a loaded scene (built-in or file, with the pipeline's camera block applied)
//! written out for other renderers, so an independent renderer can render exactly what wedge
//! renders (the thin-lens cross-check in `scripts/thin_lens_check/` reads it into Mitsuba 3).
//!
//! Files, written all-or-nothing into one directory ([`crate::staging`]):
//! - `scene.obj` + `scene.mtl`: every triangle of the scene (area lights included) with its
//!   shading normals and uvs, grouped by object and material (`o obj<object>_m<material>`,
//!   `usemtl m<material>_<name>`). Vertices are not shared: each triangle writes its own three
//!   `v`/`vt`/`vn`, so the file is the scene's triangles as wedge traces them. `vt` stores
//!   `(u, 1 − v)` because OBJ puts v = 0 at the bottom row and wedge at the top (the OBJ loader
//!   undoes it, so `wedge render --scene out/scene.obj` renders the same scene). MTL keys: `Kd`
//!   (base colour), `map_Kd` (8-bit sRGB PNG), `Ks`/`Ns` (Phong lobe), `Ke` (emission).
//! - `texture_<i>.exr` (linear RGB, exact) and `texture_<i>.png` (8-bit sRGB, for OBJ readers): the
//!   texels as stored, row 0 = v = 0.
//! - `environment.exr` (when the scene is lit by an environment map, its own or the pipeline's
//!   `Environment`/`MixedReality` node's): the lat-long texels as loaded, linear RGB, unscaled, row 0
//!   the zenith; scene.json gives its scale and rotation, wedge's convention, and the same light as
//!   a Mitsuba 3 `envmap` emitter (filename, scale, `to_world`).
//! - `scene.json`: what OBJ/MTL cannot say or says lossily — the image size, the camera (look-at
//!   frame, vertical field of view, thin-lens aperture radius and focus distance, the shutter, with
//!   their conventions) and the pipeline's camera path, every material exactly (texture index instead
//!   of an 8-bit file), the texture lookup convention, every area light (vertices in emitting order,
//!   normal, radiance, sidedness, object), every object with its rigid motion as two keyframes (the
//!   poses at shutter open and close, applied to the OBJ's vertices), the environment map, and
//!   `not_exported`: what the pipeline renders that is not a scene (a mixed-reality real layer).
//!   Conventions are spelled out in the file so a reader does not have to guess.
//!
//! [`open`] opens a pipeline for export without its mixed-reality real layer: the layer is not
//! exported, so neither its maps are read nor its `capture` rendered (minutes at full size).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use wedge_graph::{CameraKey, SceneRequest};
use wedge_scene::{Camera, EnvironmentMap, RigidTransform, Scene, Texture};

use crate::image::{write_exr, write_png_srgb, Image, ImageError};
use crate::session::{Overrides, Session, WedgeError};
use crate::staging::Staging;

/// The file name of the exported environment map.
const ENVIRONMENT_FILE: &str = "environment.exr";

/// What [`export_session`] wrote, and what of the pipeline it could not write.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Exported {
    pub files: Vec<PathBuf>,
    /// One sentence per thing the pipeline renders that the export does not hold (also in
    /// scene.json's `not_exported`).
    pub not_exported: Vec<String>,
}

/// What the exported files say beyond the scene itself: the pipeline's camera path and what of the
/// pipeline is not exported.
#[derive(Clone, Copy, Debug, Default)]
pub struct PipelineParts<'a> {
    pub camera_path: &'a [CameraKey],
    pub not_exported: &'a [String],
}

/// Open `pipeline` (or the default) for export, with `ov` (scene, size, `--allow-outside-dir`):
/// the session without a mixed-reality real layer (module doc).
pub fn open(
    registries: &crate::session::Registries,
    pipeline: Option<&Path>,
    ov: &Overrides,
) -> Result<Session, WedgeError> {
    Session::open_with(registries, pipeline, &Overrides { without_real_layer: true, ..ov.clone() })
}

/// Write the scene of `session` (opened by [`open`]), seen by its camera at its size, with the
/// pipeline's camera path, into `dir` (see the module doc).
pub fn export_session(session: &Session, dir: &Path) -> Result<Exported, WedgeError> {
    let not_exported = not_exported(session);
    let parts = PipelineParts { camera_path: &session.pipeline.pipeline.camera_path, not_exported: &not_exported };
    let files = write_files(&session.scene, &session.scene.camera, session.width, session.height, &parts, dir)?;
    Ok(Exported { files, not_exported })
}

/// What `session`'s pipeline renders that is not part of its scene: a real layer (the nodes that ask
/// for one, by [`SceneRequest`], whatever their kind).
fn not_exported(session: &Session) -> Vec<String> {
    let mut lost = Vec::new();
    for node in &session.pipeline.nodes {
        for request in node.kind.scene_requests(&node.params) {
            if let SceneRequest::RealLayer { camera_image, capture, .. } = request {
                let source = if capture.is_empty() {
                    format!("camera_image {camera_image:?} and its maps")
                } else {
                    format!("capture {capture:?}")
                };
                lost.push(format!(
                    "the mixed-reality real layer of node `{}` ({source}): it is an image the virtual objects are composited \
                     into, not a scene; the export holds the virtual objects and their lighting only",
                    node.name
                ));
            }
        }
    }
    lost
}

/// A number as JSON/OBJ text: Rust's shortest representation that reads back to the same `f32`.
fn num(x: f32) -> String {
    if x.is_finite() {
        format!("{x}")
    } else {
        // Scenes are checked on load, so this is not reached; JSON has no NaN, 0 keeps it parseable.
        "0".into()
    }
}

fn vec3(v: glam::Vec3) -> String {
    format!("[{}, {}, {}]", num(v.x), num(v.y), num(v.z))
}

/// A JSON string literal.
fn string(s: &str) -> String {
    let mut out = String::from("\"");
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            c if (c as u32) < 0x20 => {
                let _ = write!(out, "\\u{:04x}", c as u32);
            }
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

/// The MTL name of material `i`: index first (unique), then the name with anything but
/// letters, digits, `-` and `_` replaced (MTL readers split names at whitespace).
fn mtl_name(i: usize, name: &str) -> String {
    let clean: String =
        name.chars().map(|c| if c.is_ascii_alphanumeric() || c == '-' || c == '_' { c } else { '_' }).collect();
    format!("m{i}_{clean}")
}

fn texture_image(t: &Texture) -> Image {
    Image::from_fn(t.width, t.height, |x, y| t.texels[(y * t.width + x) as usize])
}

/// The OBJ text: see the module doc.
fn obj_text(scene: &Scene) -> String {
    let mut order: Vec<usize> = (0..scene.triangles.len()).collect();
    order.sort_by_key(|&i| (scene.shading[i].object, scene.shading[i].material, i));
    let mut s = String::with_capacity(scene.triangles.len() * 300);
    let _ = writeln!(s, "# wedge export-scene: scene `{}`, {} triangles", scene.name, scene.triangles.len());
    let _ = writeln!(s, "mtllib scene.mtl");
    let mut group = None;
    for (k, &i) in order.iter().enumerate() {
        let (t, sh) = (&scene.triangles[i], &scene.shading[i]);
        if group != Some((sh.object, sh.material)) {
            group = Some((sh.object, sh.material));
            let m = sh.material as usize;
            let _ = writeln!(s, "o obj{}_m{m}", sh.object);
            let _ = writeln!(s, "usemtl {}", mtl_name(m, &scene.materials[m].name));
        }
        for p in t.vertices() {
            let _ = writeln!(s, "v {} {} {}", num(p.x), num(p.y), num(p.z));
        }
        for uv in sh.uv {
            let _ = writeln!(s, "vt {} {}", num(uv.x), num(1.0 - uv.y));
        }
        for n in sh.n {
            let _ = writeln!(s, "vn {} {} {}", num(n.x), num(n.y), num(n.z));
        }
        let b = 3 * k + 1;
        let _ = writeln!(s, "f {b}/{b}/{b} {}/{}/{} {}/{}/{}", b + 1, b + 1, b + 1, b + 2, b + 2, b + 2);
    }
    s
}

fn mtl_text(scene: &Scene) -> String {
    let mut s =
        String::from("# wedge export-scene: Kd base colour (× map_Kd), Ks/Ns Phong lobe, Ke emitted radiance\n");
    for (i, m) in scene.materials.iter().enumerate() {
        let c = |v: glam::Vec3| format!("{} {} {}", num(v.x), num(v.y), num(v.z));
        let _ = writeln!(s, "\nnewmtl {}", mtl_name(i, &m.name));
        let _ = writeln!(s, "Kd {}", c(m.base_color));
        if let Some(t) = m.base_color_texture {
            let _ = writeln!(s, "map_Kd texture_{t}.png");
        }
        if m.phong_exponent > 0.0 && m.specular.max_element() > 0.0 {
            let _ = writeln!(s, "Ks {}\nNs {}", c(m.specular), num(m.phong_exponent));
        }
        if m.is_emissive() {
            let _ = writeln!(s, "Ke {}", c(m.emission));
        }
    }
    s
}

/// A row-major 4×4 matrix as JSON: the rigid transform `x ↦ p + T + R·(x − p)` as `R·x + (p + T − R·p)`.
fn matrix(tr: &RigidTransform) -> String {
    let offset = (tr.pivot + tr.translation) - tr.vector(tr.pivot);
    let rows: Vec<String> = (0..3)
        .map(|r| format!("[{}, {}, {}, {}]", num(tr.m[r][0]), num(tr.m[r][1]), num(tr.m[r][2]), num(offset[r])))
        .chain(["[0, 0, 0, 1]".to_string()])
        .collect();
    format!("[{}]", rows.join(", "))
}

/// The `objects` entries: name, the OBJ groups holding its triangles, and its motion as keyframes at
/// shutter open (`t = −1`) and close (`t = +1`), or `null` at rest.
fn objects_json(scene: &Scene, camera: &Camera) -> String {
    let mut s = String::from("  \"objects\": [\n");
    for (i, o) in scene.objects.iter().enumerate() {
        let motion = match o.motion {
            None => "null".to_string(),
            Some(m) => {
                let prepared = m.prepare();
                let keys: Vec<String> = [(-1.0f32, camera.shutter_open), (1.0, camera.shutter_close)]
                    .iter()
                    .map(|&(t, time)| {
                        let tr = prepared.at(t);
                        let q = tr.rotation;
                        format!(
                            "{{\"time\": {}, \"t\": {}, \"translation\": {}, \"rotation_xyzw\": [{}, {}, {}, {}], \"to_world\": {}}}",
                            num(time),
                            num(t),
                            vec3(tr.translation),
                            num(q.x),
                            num(q.y),
                            num(q.z),
                            num(q.w),
                            matrix(&tr)
                        )
                    })
                    .collect();
                format!("{{\"pivot\": {}, \"keyframes\": [{}]}}", vec3(m.pivot), keys.join(", "))
            }
        };
        let _ = write!(
            s,
            "    {{\"index\": {i}, \"name\": {}, \"obj_groups\": \"obj{i}_m*\", \"motion\": {motion}}}",
            string(&o.name)
        );
        s.push_str(if i + 1 < scene.objects.len() { ",\n" } else { "\n" });
    }
    s.push_str("  ],\n");
    let _ = writeln!(
        s,
        "  \"motion_conventions\": \"an object's triangles are the OBJ groups obj<index>_m<material>, in their rest pose; a \
         moving object is at x_world(t) = pivot + T(t) + R(t) (x_obj - pivot) at shutter time t in [-1, 1] (-1 = camera \
         shutter_open, +1 = shutter_close), T linear and R spherical-linear (short arc) between the two keyframes over \
         s = (t + 1)/2 (scene/src/motion.rs); each keyframe's to_world is that map at its time as a row-major 4x4 matrix \
         (rotation_xyzw the unit quaternion of R); motion null: at rest where the OBJ puts it; a light moves with its object\","
    );
    s
}

/// The `environment` entry: the exported map with wedge's parameters and convention, and the same
/// light as a Mitsuba 3 `envmap` (`null` without a map).
fn environment_json(env: Option<&EnvironmentMap>) -> String {
    let Some(env) = env else {
        return "  \"environment\": null,\n".to_string();
    };
    // Mitsuba's envmap puts u = 0 at -Z and u = 0.25 at +X (u = atan2(x, -z)/2pi in its local frame),
    // wedge u = 0.5 at -Z and 0.75 at +X: the same image is wedge's map turned by half a turn about
    // +Y (scene/src/environment.rs, "Convention"), so Mitsuba's to_world turns by rotation_deg + 180.
    let mitsuba_angle = (env.rotation_deg() + 180.0).rem_euclid(360.0);
    format!(
        "  \"environment\": {{\"exr\": {}, \"source\": {}, \"width\": {}, \"height\": {}, \"scale\": {}, \"rotation_deg\": {}, \
         \"conventions\": \"lat-long, linear RGB, texels as loaded (radiance = texel x scale), piecewise constant per texel; \
         row 0 is the zenith (+Y), v = theta/pi; column u = phi/(2 pi) with phi = atan2(-x, z) in the map's frame, so u = 0.5 \
         faces -Z and u = 0.75 faces +X; world direction = R_y(rotation_deg) (right-handed about +Y) x map direction \
         (scene/src/environment.rs)\", \"mitsuba\": {{\"type\": \"envmap\", \"filename\": {}, \"scale\": {}, \
         \"to_world\": {{\"rotate\": {{\"axis\": [0, 1, 0], \"angle\": {}}}}}}}}},\n",
        string(ENVIRONMENT_FILE),
        string(env.name()),
        env.width(),
        env.height(),
        num(env.scale()),
        num(env.rotation_deg()),
        string(ENVIRONMENT_FILE),
        num(env.scale()),
        num(mitsuba_angle),
    )
}

/// The `camera_path` entry: the pipeline's keys (empty without a path).
fn camera_path_json(keys: &[CameraKey]) -> String {
    let v = |t: (f32, f32, f32)| vec3(glam::Vec3::new(t.0, t.1, t.2));
    let entries: Vec<String> = keys
        .iter()
        .map(|k| format!("{{\"frame\": {}, \"position\": {}, \"look_at\": {}}}", k.frame, v(k.position), v(k.look_at)))
        .collect();
    format!(
        "  \"camera_path\": [{}],\n  \"camera_path_conventions\": \"wedge render --frames: frame f's camera is camera with position \
         and look_at interpolated linearly between the keys around f (held before the first and after the last); empty: one \
         camera\",\n",
        entries.join(", ")
    )
}

fn json_text(scene: &Scene, camera: &Camera, width: u32, height: u32, parts: &PipelineParts<'_>) -> String {
    let (_, _, forward) = camera.basis();
    let mut s = String::from("{\n");
    let _ = writeln!(s, "  \"generator\": \"wedge export-scene\",");
    let _ = writeln!(s, "  \"scene\": {},", string(&scene.name));
    let _ = writeln!(
        s,
        "  \"obj\": \"scene.obj\",\n  \"mtl\": \"scene.mtl\",\n  \"triangles\": {},",
        scene.triangles.len()
    );
    let _ = writeln!(
        s,
        "  \"image\": {{\"width\": {width}, \"height\": {height}, \"pixel_origin\": \"top-left, y down; pixel (x, y) spans \
         [x, x+1] x [y, y+1]\", \"linear\": true}},"
    );
    let _ = writeln!(
        s,
        "  \"camera\": {{\"position\": {}, \"look_at\": {}, \"up\": {}, \"forward\": {}, \"vfov_deg\": {}, \"fov_axis\": \"y\", \
         \"aperture_radius\": {}, \"focus_distance\": {}, \"shutter_open\": {}, \"shutter_close\": {}, \"conventions\": \"thin \
         lens (scene/src/camera.rs Camera::ray): the lens is a uniform disk of radius aperture_radius (world units) centred \
         on position, in the plane spanned by right and up; focus_distance is measured along the view direction (forward): \
         the focal plane is perpendicular to it, and every ray of an image point passes through the point of the focal \
         plane the pinhole ray of that image point meets; aperture_radius 0 is a pinhole; the shutter is open from \
         shutter_open to shutter_close (scene time, times uniform over it; equal: an instant), the times of the objects' \
         motion keyframes\"}},",
        vec3(camera.position),
        vec3(camera.look_at),
        vec3(camera.up),
        vec3(forward),
        num(camera.vfov_deg),
        num(camera.aperture_radius),
        num(camera.effective_focus_distance()),
        num(camera.shutter_open),
        num(camera.shutter_close),
    );
    s.push_str(&camera_path_json(parts.camera_path));
    s.push_str("  \"materials\": [\n");
    for (i, m) in scene.materials.iter().enumerate() {
        let tex = m.base_color_texture.map_or("null".into(), |t| t.to_string());
        let _ = write!(
            s,
            "    {{\"index\": {i}, \"name\": {}, \"mtl\": {}, \"base_color\": {}, \"texture\": {tex}, \"specular\": {}, \
             \"phong_exponent\": {}, \"emission\": {}}}",
            string(&m.name),
            string(&mtl_name(i, &m.name)),
            vec3(m.base_color),
            vec3(m.specular),
            num(m.phong_exponent),
            vec3(m.emission),
        );
        s.push_str(if i + 1 < scene.materials.len() { ",\n" } else { "\n" });
    }
    s.push_str("  ],\n");
    let _ = writeln!(
        s,
        "  \"material_conventions\": \"diffuse albedo k_d = base_color x texture (Lambertian, k_d/pi); specular/phong_exponent: \
         a Phong lobe (0 = none); emission: radiance L_e (area lights are listed under lights)\","
    );
    s.push_str("  \"textures\": [\n");
    for (i, t) in scene.textures.iter().enumerate() {
        let _ = write!(
            s,
            "    {{\"index\": {i}, \"exr\": \"texture_{i}.exr\", \"png\": \"texture_{i}.png\", \"width\": {}, \"height\": {}}}",
            t.width, t.height
        );
        s.push_str(if i + 1 < scene.textures.len() { ",\n" } else { "\n" });
    }
    s.push_str("  ],\n");
    let _ = writeln!(
        s,
        "  \"texture_conventions\": \"linear RGB; bilinear lookup with repeat wrapping; texel (i, j) (column, row; row 0 the \
         top row of the image) is centred at uv ((i + 0.5)/width, (j + 0.5)/height), so v = 0 is the top row (scene.json \
         and wedge); the OBJ stores vt = (u, 1 - v)\","
    );
    s.push_str("  \"lights\": [\n");
    for (i, l) in scene.lights.iter().enumerate() {
        let verts: Vec<String> = l.vertices().into_iter().map(vec3).collect();
        let object = scene.light_object.get(i).map_or("null".into(), |o| o.to_string());
        let _ = write!(
            s,
            "    {{\"index\": {i}, \"vertices\": [{}], \"normal\": {}, \"area\": {}, \"radiance\": {}, \"two_sided\": {}, \"object\": {object}}}",
            verts.join(", "),
            vec3(l.normal()),
            num(l.area()),
            vec3(l.radiance),
            l.two_sided
        );
        s.push_str(if i + 1 < scene.lights.len() { ",\n" } else { "\n" });
    }
    s.push_str("  ],\n");
    let _ = writeln!(
        s,
        "  \"light_conventions\": \"uniform emitted radiance L_e (W sr^-1 m^-2, the same unit as pixel values) toward normal \
         (vertices counter-clockwise around it, the triangles' winding normal); one-sided unless two_sided; vertices in the \
         rest pose of the light's object (objects[object].motion moves them)\","
    );
    s.push_str(&objects_json(scene, camera));
    s.push_str(&environment_json(scene.environment.as_ref()));
    let lost: Vec<String> = parts.not_exported.iter().map(|l| string(l)).collect();
    let _ = writeln!(s, "  \"not_exported\": [{}]", lost.join(", "));
    s.push_str("}\n");
    s
}

/// Write `scene` seen by `camera` at `width`×`height` into `dir` (see the module doc), without a
/// pipeline's parts ([`export_session`] adds them); returns the files written.
pub fn export_scene(
    scene: &Scene,
    camera: &Camera,
    width: u32,
    height: u32,
    dir: &Path,
) -> Result<Vec<PathBuf>, ImageError> {
    write_files(scene, camera, width, height, &PipelineParts::default(), dir)
}

fn write_files(
    scene: &Scene,
    camera: &Camera,
    width: u32,
    height: u32,
    parts: &PipelineParts<'_>,
    dir: &Path,
) -> Result<Vec<PathBuf>, ImageError> {
    let mut set = Staging::new(dir)?;
    let text = |set: &mut Staging, name: &str, body: String| -> Result<(), ImageError> {
        let path = set.file(name)?;
        std::fs::write(&path, body).map_err(|source| ImageError::Write { path: dir.join(name), source })
    };
    text(&mut set, "scene.obj", obj_text(scene))?;
    text(&mut set, "scene.mtl", mtl_text(scene))?;
    for (i, t) in scene.textures.iter().enumerate() {
        let img = texture_image(t);
        write_exr(&set.file(format!("texture_{i}.exr"))?, &img)?;
        write_png_srgb(&set.file(format!("texture_{i}.png"))?, &img, 1.0)?;
    }
    if let Some(env) = &scene.environment {
        let texels = env.texels();
        let img = Image::from_fn(env.width(), env.height(), |x, y| texels[(y * env.width() + x) as usize]);
        write_exr(&set.file(ENVIRONMENT_FILE)?, &img)?;
    }
    text(&mut set, "scene.json", json_text(scene, camera, width, height, parts))?;
    set.commit()
}
