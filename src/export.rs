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
//! - `scene.json`: what OBJ/MTL cannot say or says lossily — the image size, the camera (look-at
//!   frame, vertical field of view, thin-lens aperture radius and focus distance with their
//!   conventions), every material exactly (texture index instead of an 8-bit file), the texture
//!   lookup convention, and every area light (vertices in emitting order, normal, radiance,
//!   sidedness). Conventions are spelled out in the file so a reader does not have to guess.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use wedge_scene::{Camera, Scene, Texture};

use crate::image::{write_exr, write_png_srgb, Image, ImageError};
use crate::staging::Staging;

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
    let clean: String = name.chars().map(|c| if c.is_ascii_alphanumeric() || c == '-' || c == '_' { c } else { '_' }).collect();
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
    let mut s = String::from("# wedge export-scene: Kd base colour (× map_Kd), Ks/Ns Phong lobe, Ke emitted radiance\n");
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

fn json_text(scene: &Scene, camera: &Camera, width: u32, height: u32) -> String {
    let (_, _, forward) = camera.basis();
    let mut s = String::from("{\n");
    let _ = writeln!(s, "  \"generator\": \"wedge export-scene\",");
    let _ = writeln!(s, "  \"scene\": {},", string(&scene.name));
    let _ = writeln!(s, "  \"obj\": \"scene.obj\",\n  \"mtl\": \"scene.mtl\",\n  \"triangles\": {},", scene.triangles.len());
    let _ = writeln!(
        s,
        "  \"image\": {{\"width\": {width}, \"height\": {height}, \"pixel_origin\": \"top-left, y down; pixel (x, y) spans \
         [x, x+1] x [y, y+1]\", \"linear\": true}},"
    );
    let _ = writeln!(
        s,
        "  \"camera\": {{\"position\": {}, \"look_at\": {}, \"up\": {}, \"forward\": {}, \"vfov_deg\": {}, \"fov_axis\": \"y\", \
         \"aperture_radius\": {}, \"focus_distance\": {}, \"conventions\": \"thin lens (scene/src/camera.rs Camera::ray): \
         the lens is a uniform disk of radius aperture_radius (world units) centred on position, in the plane spanned by \
         right and up; focus_distance is measured along the view direction (forward): the focal plane is perpendicular to \
         it, and every ray of an image point passes through the point of the focal plane the pinhole ray of that image \
         point meets; aperture_radius 0 is a pinhole\"}},",
        vec3(camera.position),
        vec3(camera.look_at),
        vec3(camera.up),
        vec3(forward),
        num(camera.vfov_deg),
        num(camera.aperture_radius),
        num(camera.effective_focus_distance()),
    );
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
        let _ = write!(
            s,
            "    {{\"index\": {i}, \"vertices\": [{}], \"normal\": {}, \"area\": {}, \"radiance\": {}, \"two_sided\": {}}}",
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
         (vertices counter-clockwise around it, the triangles' winding normal); one-sided unless two_sided\""
    );
    s.push_str("}\n");
    s
}

/// Write `scene` seen by `camera` at `width`×`height` into `dir` (see the module doc); returns the
/// files written.
pub fn export_scene(scene: &Scene, camera: &Camera, width: u32, height: u32, dir: &Path) -> Result<Vec<PathBuf>, ImageError> {
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
    text(&mut set, "scene.json", json_text(scene, camera, width, height))?;
    set.commit()
}
