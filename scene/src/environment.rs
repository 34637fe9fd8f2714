//! Environment maps: distant lighting from every direction as scene data (thesis Ch. 6, issue 14).
//!
//! An [`EnvironmentMap`] is a lat-long (equirectangular) radiance map in linear RGB, loaded from
//! OpenEXR (`exr`) or Radiance `.hdr` (`image`), or generated in code (`builtin:sky`,
//! `builtin:studio`, [`EnvironmentMap::builtin`]). It gives the radiance arriving from a direction,
//! importance sampling of directions, the thesis's table of 4096 precomputed samples (Sec. 6.5.2) and
//! the map's bandwidth `B_e` (Sec. 6.7). The GPU receives the same data (`backends/src/gpu/scene.rs`,
//! `shaders/environment.wgsl`) and selects the same texel for every direction, bit for bit.
//!
//! # Convention
//!
//! - **Rows**: row 0 is the zenith (+Y up), the last row the nadir; row `j` covers polar angles
//!   `θ ∈ [πj/H, π(j+1)/H)` from +Y (`v = θ/π`).
//! - **Columns**: `u = φ/(2π)` with `φ = atan2(−x, z)` in the map's frame, so the column at **u = 0.5
//!   faces −Z** (the default camera's forward direction: the middle of the image is straight ahead),
//!   **u = 0.75 faces +X**, u = 0.25 faces −X, and u = 0 (the left and right edges) faces +Z. Seen from
//!   inside the sphere with +Y up, left-to-right in the image is turning right, so the map is not
//!   mirrored. This is Mitsuba 3's +Y-up `envmap` layout (`u = atan2(x, −z)/(2π)`, u = 0 facing −Z,
//!   u = 0.25 facing +X) turned by half a turn: a map made for Mitsuba looks the same here with
//!   `rotation_deg = 180`.
//!   Direction of `(u, v)`: `(−sin φ sin θ, cos θ, cos φ sin θ)` with `φ = 2πu`, `θ = πv`.
//! - **`rotation_deg`** rotates the environment about +Y by the right-hand rule, i.e. counter-clockwise
//!   seen from above: with 90° the map's centre column (−Z at 0°) faces −X, and a direction's `u`
//!   grows by `rotation_deg/360`. World direction = `R_y(rotation) ·` map direction.
//! - **`scale`** multiplies the radiance (finite, > 0); sampling does not depend on it.
//!
//! # Radiance and sampling
//!
//! [`EnvironmentMap::radiance`] returns the texel containing the direction, piecewise constant (no
//! bilinear filtering: that would put radiance where the sampling pdf is zero). Sampling picks texel
//! `(i, j)` with probability ∝ luminance × solid angle, then a direction uniformly in the texel's
//! solid angle, so the pdf is constant per texel and equals `lum(L_ij) / ∫ lum(L) dω` (Rec. 709
//! luminance). The texel's solid angle `(2π/W)(cos θ_j − cos θ_{j+1}) = (2π/W)·2 sin(π/2H)·sin θ_c` is
//! ∝ sin θ at the row's centre, so this is the "luminance × sin θ" distribution of pbrt and the thesis,
//! with exact row areas: a marginal CDF over rows and a conditional CDF per row, inverted by binary
//! search ([`EnvironmentMap::sample`]). A texel of zero luminance (black: RGB are non-negative) gets
//! probability zero: no direction from it is ever sampled, which is correct because it sends no
//! light. A map that is black everywhere falls back to uniform sphere sampling (pdf 1/(4π)) so every
//! estimate is a correct zero.
//!
//! # The table (thesis Sec. 6.5.2)
//!
//! [`EnvironmentMap::table`] holds [`TABLE_SIZE`] = 4096 samples `{dir, radiance, pdf}`: the first
//! 4096 points of the 2-D Sobol' sequence, Owen-scrambled with fixed seeds ([`table_point`]), pushed
//! through the inverse CDF and stored in sequence order. They are a (0,12,2)-net, stratified in every
//! elementary interval of area 1/4096 (4096 strips of rows as well as a 64 × 64 grid), and every
//! aligned run of `2^k` consecutive entries is a (0,k,2)-net too, so stratified indices give 2-D
//! stratified directions. Measured against a 64 × 64 jittered grid (Morton order) on the same maps,
//! Sobol' cut the white-furnace error from ≤ 8.4e-4 to ≤ 1.6e-4 and the sky's RMS irradiance error
//! from 1.5e-3 to 9.0e-4 of the largest irradiance (`scene/tests/environment.rs`). A renderer picks entry
//! `k = floor(u · 4096)` with uniform `u`; then `L_k f cos θ_k / pdf_k` is an unbiased estimate of the
//! *table's quadrature* `(1/4096) Σ_k L_k f cos θ_k / pdf_k`, which approximates the true integral
//! with the error measured in `scene/tests/environment.rs` (thesis: RMS 1e-5 in its images). More
//! look-ups converge to that quadrature, not to the exact integral.
//!
//! # Bandwidth `B_e` (thesis Sec. 6.7, docs/EQUATIONS.md "Environment")
//!
//! The radius, in cycles per radian, holding 99% of the energy of the 2-D power spectrum of the
//! map's luminance in lat-long coordinates, DC included ([`EnvironmentMap::bandwidth`]). A column
//! step is 2π/W rad and a row step π/H rad, so FFT bin `(k_x, k_y)` is at `(k_x/2π, k_y/π)` cycles per
//! radian. Computed once on load with `rustfft`, over the whole map up to 2048 columns; larger maps are
//! box-averaged by an integer factor first (the 99% radius of real maps is far below the 163 cycles
//! per radian such a map still resolves). The spectrum treats rows as periodic, like the columns;
//! zenith and nadir rows differ, so some energy leaks into vertical frequencies.
//!
//! # Texel selection without transcendentals
//!
//! `atan2`/`acos` round differently in Rust and in WGSL implementations, so the texel of a direction is
//! found by comparisons against boundary tables computed once on the CPU (in f64) and uploaded:
//! rows by `y·y ≤ cot²θ_k · (x·x + z·z)` (sign cases below), columns by a pseudo-angle (quadrant, then
//! `a' ≥ f_k · (a' + b')`) against the boundaries' pseudo-angles, which already include the rotation.
//! Only f32 multiplications, additions and comparisons on the direction, in the same order on both
//! sides ([`EnvironmentMap::texel_of`], WGSL `env_texel`), so CPU and GPU pick the same texel where the
//! GPU does not fuse `x·x + z·z` into one multiply-add; where it does, only directions within an ulp of
//! a row cone can differ (the GPU probe test counts them).

use std::f64::consts::PI;
use std::path::{Path, PathBuf};
use std::sync::{Arc, OnceLock};

use glam::{Vec2, Vec3};

use crate::limits::{MAX_RADIANCE, MAX_TEXTURE_PIXELS, MAX_TEXTURE_SIDE};
use crate::SceneError;

/// Entries of the precomputed sample table (thesis Sec. 6.5.2).
pub const TABLE_SIZE: usize = 4096;
/// Names accepted by [`EnvironmentMap::builtin`] (as `builtin:NAME` in [`EnvironmentMap::open`]).
pub const BUILTIN_NAMES: &[&str] = &["sky", "studio", "sun", "overcast", "sunset"];
/// The B_e FFT runs on at most this many columns (larger maps are box-averaged first).
pub const BANDWIDTH_MAX_COLUMNS: u32 = 2048;
/// Fraction of the spectrum's energy inside `B_e`.
pub const BANDWIDTH_ENERGY: f64 = 0.99;

/// One precomputed sample: a world direction (unit), the radiance arriving from it (scaled), and the
/// sampling pdf per solid angle of that direction; `texel` is `row · width + column`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EnvSample {
    pub dir: Vec3,
    pub radiance: Vec3,
    pub pdf: f32,
    pub texel: u32,
}

/// A lat-long environment map with its sampling distribution, sample table and bandwidth (see the
/// module doc for the conventions). Cheap to clone: the texels and the distribution are shared.
#[derive(Clone)]
pub struct EnvironmentMap {
    name: String,
    scale: f32,
    rotation_deg: f32,
    data: Arc<MapData>,
    /// Column boundaries in the world frame (they depend on the rotation).
    columns: Arc<ColumnBounds>,
    /// The table in the world frame, scaled.
    table: Arc<Vec<EnvSample>>,
}

/// What does not depend on `scale` and `rotation_deg`.
struct MapData {
    width: u32,
    height: u32,
    /// Row-major, row 0 = zenith, as loaded (unscaled).
    texels: Vec<[f32; 3]>,
    /// `∫ lum(L) dω` over the sphere (unscaled); 0 for a black map (uniform sampling).
    total: f64,
    /// Marginal CDF over rows (`height + 1` values, 0 … 1).
    marginal: Vec<f64>,
    /// Conditional CDF per row (`width + 1` values each, 0 … 1; a black row is uniform).
    conditional: Vec<f64>,
    /// `cos θ_j` for j = 0..=height (row boundaries).
    cos_theta: Vec<f64>,
    /// `cot² θ_k` for the row boundaries k = 1..height (index 0 unused, 0).
    row_t: Vec<f32>,
    /// B_e, cycles per radian.
    bandwidth: f32,
    /// The table before rotation and scale: per entry (texel, φ_map, cos θ).
    table_map: Vec<TableEntry>,
}

/// Column boundaries sorted by world pseudo-angle: boundary `m` starts map column
/// `(first + m) % width`; `q[m]` is its quadrant, `f[m]` its in-quadrant fraction (see `pseudo_angle`).
struct ColumnBounds {
    q: Vec<u32>,
    f: Vec<f32>,
    first: u32,
}

impl std::fmt::Debug for EnvironmentMap {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("EnvironmentMap")
            .field("name", &self.name)
            .field("width", &self.data.width)
            .field("height", &self.data.height)
            .field("scale", &self.scale)
            .field("rotation_deg", &self.rotation_deg)
            .field("bandwidth", &self.data.bandwidth)
            .finish()
    }
}

/// A map's width, height and texels as generated or read.
type Texels = (u32, u32, Vec<[f32; 3]>);

/// Rec. 709 / sRGB-primaries luminance.
pub fn luminance(c: [f32; 3]) -> f64 {
    0.2126 * c[0] as f64 + 0.7152 * c[1] as f64 + 0.0722 * c[2] as f64
}

impl EnvironmentMap {
    /// A map from `spec`: `builtin:NAME` ([`BUILTIN_NAMES`]) or a `.exr` / `.hdr` file path.
    pub fn open(spec: &str) -> Result<EnvironmentMap, SceneError> {
        match spec.strip_prefix("builtin:") {
            Some(name) => EnvironmentMap::builtin(name),
            None => EnvironmentMap::load(Path::new(spec)),
        }
    }

    /// Load a lat-long map from an OpenEXR (`.exr`) or Radiance (`.hdr`, `.pic`) file. Refused, with
    /// the file and the fix: an unreadable file or one that is not such an image, a size that is not
    /// 2:1 or over [`crate::limits`], and NaN, infinite, negative or absurdly large (> `MAX_RADIANCE`)
    /// texels (counted by kind; never clamped or spread).
    pub fn load(path: &Path) -> Result<EnvironmentMap, SceneError> {
        let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
        let (w, h, texels) = match ext.as_deref() {
            Some("exr") => read_exr(path)?,
            Some("hdr") | Some("pic") => read_hdr(path)?,
            _ => {
                return Err(SceneError::invalid(
                    path,
                    "not an environment map format we read",
                    "give a lat-long map as .exr (OpenEXR) or .hdr (Radiance RGBE), or builtin:sky",
                ))
            }
        };
        EnvironmentMap::from_texels(&path.display().to_string(), w, h, texels)
    }

    /// A map from texels (row-major, row 0 = zenith, linear RGB), with the same checks as
    /// [`EnvironmentMap::load`]; `name` is reported in errors. `scale` 1, `rotation_deg` 0.
    pub fn from_texels(
        name: &str,
        width: u32,
        height: u32,
        texels: Vec<[f32; 3]>,
    ) -> Result<EnvironmentMap, SceneError> {
        let path = PathBuf::from(name);
        check_size(&path, width, height)?;
        if texels.len() != width as usize * height as usize {
            return Err(SceneError::invalid(
                &path,
                format!(
                    "{} texels for a {width}x{height} map (expected {})",
                    texels.len(),
                    width as u64 * height as u64
                ),
                "give width × height texels",
            ));
        }
        check_texels(&path, width, &texels)?;
        let data = Arc::new(MapData::build(width, height, texels));
        let mut map = EnvironmentMap {
            name: name.to_string(),
            scale: 1.0,
            rotation_deg: 0.0,
            columns: Arc::new(ColumnBounds::build(width, 0.0)),
            table: Arc::new(Vec::new()),
            data,
        };
        map.table = Arc::new(map.world_table());
        Ok(map)
    }

    /// A procedural map generated in code at first use and cached: `sky` (sun, sky gradient, clouds,
    /// bright windows, dark ground; 512 × 256) or `studio` (dark room with three soft boxes; 256 × 128).
    pub fn builtin(name: &str) -> Result<EnvironmentMap, SceneError> {
        static SKY: OnceLock<EnvironmentMap> = OnceLock::new();
        static STUDIO: OnceLock<EnvironmentMap> = OnceLock::new();
        static SUN: OnceLock<EnvironmentMap> = OnceLock::new();
        static OVERCAST: OnceLock<EnvironmentMap> = OnceLock::new();
        static SUNSET: OnceLock<EnvironmentMap> = OnceLock::new();
        let (cell, make): (&OnceLock<EnvironmentMap>, fn() -> Texels) = match name {
            "sky" => (&SKY, procedural::sky),
            "studio" => (&STUDIO, procedural::studio),
            "sun" => (&SUN, procedural::sun),
            "overcast" => (&OVERCAST, procedural::overcast),
            "sunset" => (&SUNSET, procedural::sunset),
            _ => {
                return Err(SceneError::invalid(
                    Path::new(&format!("builtin:{name}")),
                    "no such built-in environment map",
                    format!(
                        "use one of {}, or a .exr/.hdr file",
                        BUILTIN_NAMES.iter().map(|n| format!("builtin:{n}")).collect::<Vec<_>>().join(", ")
                    ),
                ))
            }
        };
        if let Some(map) = cell.get() {
            return Ok(map.clone());
        }
        let (w, h, texels) = make();
        let map = EnvironmentMap::from_texels(&format!("builtin:{name}"), w, h, texels)?;
        Ok(cell.get_or_init(|| map).clone())
    }

    /// The same map with radiance multiplied by `scale` (finite, > 0) and rotated by `rotation_deg`
    /// about +Y (see the module doc); the table is redrawn in the new frame (same texels, same pdfs).
    pub fn with_params(mut self, scale: f32, rotation_deg: f32) -> Result<EnvironmentMap, SceneError> {
        let path = PathBuf::from(&self.name);
        if !(scale.is_finite() && scale > 0.0) {
            return Err(SceneError::invalid(
                &path,
                format!("environment scale {scale} is not a finite number > 0"),
                "give a scale > 0 (1 keeps the map's radiance)",
            ));
        }
        let brightest = self.data.texels.iter().map(|c| c[0].max(c[1]).max(c[2])).fold(0.0f32, f32::max);
        if (brightest as f64) * (scale as f64) > MAX_RADIANCE as f64 {
            return Err(SceneError::invalid(
                &path,
                format!(
                    "scale {scale} makes the brightest texel {:e}, over the limit of {MAX_RADIANCE:e}",
                    brightest as f64 * scale as f64
                ),
                "use a smaller scale",
            ));
        }
        if !rotation_deg.is_finite() {
            return Err(SceneError::invalid(
                &path,
                format!("environment rotation {rotation_deg}° is not finite"),
                "give rotation_deg in degrees about +Y (e.g. 0 … 360)",
            ));
        }
        let rotation_changed = rotation_deg.to_bits() != self.rotation_deg.to_bits();
        self.scale = scale;
        self.rotation_deg = rotation_deg;
        if rotation_changed {
            self.columns = Arc::new(ColumnBounds::build(self.data.width, rotation_deg));
        }
        self.table = Arc::new(self.world_table());
        Ok(self)
    }

    /// The file path or `builtin:NAME` it came from.
    pub fn name(&self) -> &str {
        &self.name
    }
    pub fn width(&self) -> u32 {
        self.data.width
    }
    pub fn height(&self) -> u32 {
        self.data.height
    }
    pub fn scale(&self) -> f32 {
        self.scale
    }
    pub fn rotation_deg(&self) -> f32 {
        self.rotation_deg
    }
    /// The texels as loaded (unscaled), row-major, row 0 = zenith.
    pub fn texels(&self) -> &[[f32; 3]] {
        &self.data.texels
    }
    /// `B_e`: the 99%-energy radius of the luminance's 2-D power spectrum in lat-long coordinates,
    /// DC included, in cycles per radian (module doc). Independent of `scale` and `rotation_deg`.
    pub fn bandwidth(&self) -> f32 {
        self.data.bandwidth
    }
    /// `∫ lum(L) dω` over the sphere, scaled (W/m²-like luminance units); 0 for a black map.
    pub fn total_luminance(&self) -> f64 {
        self.data.total * self.scale as f64
    }

    /// The texel `(column, row)` containing `dir` (any non-zero length; world frame). The same
    /// comparisons as WGSL `env_texel` (module doc); a zero or NaN direction gives some valid texel.
    pub fn texel_of(&self, dir: Vec3) -> (u32, u32) {
        let row = self.data.row_of(dir);
        let col = self.columns.column_of(dir, self.data.width);
        (col, row)
    }

    /// Radiance arriving from `dir` (world frame): the scaled texel containing it.
    pub fn radiance(&self, dir: Vec3) -> Vec3 {
        let (c, r) = self.texel_of(dir);
        self.texel_radiance(r as usize * self.data.width as usize + c as usize)
    }

    /// Scaled radiance of texel `index` (`row · width + column`), as the GPU stores it.
    pub fn texel_radiance(&self, index: usize) -> Vec3 {
        Vec3::from(self.data.texels[index]) * self.scale
    }

    /// Sampling pdf per solid angle of texel `index`: `lum / ∫ lum dω` (1/(4π) for a black map), as f32
    /// (what `pdf`, `sample` and the GPU report).
    pub fn texel_pdf(&self, index: usize) -> f32 {
        if self.data.total > 0.0 {
            (luminance(self.data.texels[index]) / self.data.total) as f32
        } else {
            (0.25 / PI) as f32
        }
    }

    /// Solid angle of texel `index` (sr).
    pub fn texel_solid_angle(&self, index: usize) -> f64 {
        let j = index / self.data.width as usize;
        2.0 * PI / self.data.width as f64 * (self.data.cos_theta[j] - self.data.cos_theta[j + 1])
    }

    /// The pdf per solid angle with which [`EnvironmentMap::sample`] picks `dir`.
    pub fn pdf(&self, dir: Vec3) -> f32 {
        let (c, r) = self.texel_of(dir);
        self.texel_pdf(r as usize * self.data.width as usize + c as usize)
    }

    /// Importance-sample a direction from `u ∈ [0, 1)²` by inverse CDF (`u.y` picks the row, `u.x` the
    /// column; the remainders place the direction uniformly in the texel's solid angle): the world
    /// direction, the radiance from it (scaled) and the pdf per solid angle.
    pub fn sample(&self, u: Vec2) -> EnvSample {
        let (texel, phi_map, cos_theta) = self.data.sample_map(u.x as f64, u.y as f64);
        self.world_sample(texel, phi_map, cos_theta)
    }

    /// Entry `i` of the precomputed table (`i < TABLE_SIZE`; larger indices wrap).
    pub fn table(&self, i: usize) -> EnvSample {
        self.table[i % TABLE_SIZE]
    }

    /// The whole table ([`TABLE_SIZE`] entries in Sobol' sequence order).
    pub fn table_entries(&self) -> &[EnvSample] {
        &self.table
    }

    /// The world direction of map coordinates `(u, v)` (module doc; `u` in turns, `v = θ/π`).
    pub fn direction_of(&self, u: f32, v: f32) -> Vec3 {
        let phi = 2.0 * PI * u as f64;
        let theta = PI * v as f64;
        world_dir(phi, theta.cos(), self.rotation_rad())
    }

    /// Map coordinates `(u, v)` of a world direction, with `atan2`/`acos` (for reading and tests; the
    /// texel lookup is [`EnvironmentMap::texel_of`]).
    pub fn uv_of(&self, dir: Vec3) -> Vec2 {
        let d = dir.as_dvec3().normalize_or_zero();
        let psi = (-d.x).atan2(d.z);
        let u = (psi + self.rotation_rad()).rem_euclid(2.0 * PI) / (2.0 * PI);
        let v = d.y.clamp(-1.0, 1.0).acos() / PI;
        Vec2::new(u as f32, v as f32)
    }

    fn rotation_rad(&self) -> f64 {
        (self.rotation_deg as f64).to_radians()
    }

    fn world_sample(&self, texel: u32, phi_map: f64, cos_theta: f64) -> EnvSample {
        EnvSample {
            dir: world_dir(phi_map, cos_theta, self.rotation_rad()),
            radiance: self.texel_radiance(texel as usize),
            pdf: self.texel_pdf(texel as usize),
            texel,
        }
    }

    fn world_table(&self) -> Vec<EnvSample> {
        self.data.table_map.iter().map(|&(t, phi, c)| self.world_sample(t, phi, c)).collect()
    }

    /// GPU data: row boundary values `cot² θ_k` (index 0 unused).
    pub fn gpu_rows(&self) -> &[f32] {
        &self.data.row_t
    }
    /// GPU data: column boundaries sorted by world pseudo-angle, as (quadrant, fraction) pairs, and
    /// the map column the first one starts.
    pub fn gpu_columns(&self) -> (&[u32], &[f32], u32) {
        (&self.columns.q, &self.columns.f, self.columns.first)
    }

    /// Bytes this map holds on the CPU (texels, CDFs, boundary tables, table), for memory estimates.
    pub fn bytes(&self) -> u64 {
        let d = &self.data;
        (std::mem::size_of_val(d.texels.as_slice())
            + std::mem::size_of_val(d.marginal.as_slice())
            + std::mem::size_of_val(d.conditional.as_slice())
            + std::mem::size_of_val(d.cos_theta.as_slice())
            + std::mem::size_of_val(d.row_t.as_slice())
            + std::mem::size_of_val(d.table_map.as_slice())
            + self.columns.q.len() * 8
            + std::mem::size_of_val(self.table.as_slice())) as u64
    }
}

/// World direction of map azimuth `phi_map` and `cos θ` under a rotation of `rot` rad about +Y
/// (world ψ = φ_map − rot; direction `(−sin ψ sin θ, cos θ, cos ψ sin θ)`).
fn world_dir(phi_map: f64, cos_theta: f64, rot: f64) -> Vec3 {
    let psi = phi_map - rot;
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    Vec3::new((-psi.sin() * sin_theta) as f32, cos_theta as f32, (psi.cos() * sin_theta) as f32)
}

impl MapData {
    fn build(width: u32, height: u32, texels: Vec<[f32; 3]>) -> MapData {
        let (w, h) = (width as usize, height as usize);
        let cos_theta: Vec<f64> = (0..=h)
            .map(|j| match j {
                0 => 1.0,
                j if j == h => -1.0,
                j => (PI * j as f64 / h as f64).cos(),
            })
            .collect();
        let row_t: Vec<f32> = (0..h)
            .map(|k| {
                if k == 0 || 2 * k == h {
                    0.0
                } else {
                    let t = PI * k as f64 / h as f64;
                    let cot = t.cos() / t.sin();
                    (cot * cot) as f32
                }
            })
            .collect();
        // Texel weight = luminance × solid angle; per row the conditional CDF, over rows the marginal.
        let mut conditional = vec![0.0f64; h * (w + 1)];
        let mut row_weight = vec![0.0f64; h];
        for j in 0..h {
            let omega = 2.0 * PI / w as f64 * (cos_theta[j] - cos_theta[j + 1]);
            let cdf = &mut conditional[j * (w + 1)..(j + 1) * (w + 1)];
            let mut sum = 0.0;
            for i in 0..w {
                sum += luminance(texels[j * w + i]);
                cdf[i + 1] = sum;
            }
            row_weight[j] = sum * omega;
            normalise_cdf(cdf);
        }
        let total: f64 = row_weight.iter().sum();
        let mut marginal = vec![0.0f64; h + 1];
        for j in 0..h {
            marginal[j + 1] = marginal[j] + row_weight[j];
        }
        normalise_cdf(&mut marginal);
        let lum: Vec<f32> = texels.iter().map(|&c| luminance(c) as f32).collect();
        let bandwidth = bandwidth_99(&lum, w, h);
        let mut data = MapData {
            width,
            height,
            texels,
            total: if total.is_finite() && total > 0.0 { total } else { 0.0 },
            marginal,
            conditional,
            cos_theta,
            row_t,
            bandwidth,
            table_map: Vec::new(),
        };
        data.table_map = data.draw_table();
        data
    }

    /// Inverse CDF in the map frame: (texel, φ_map, cos θ).
    fn sample_map(&self, ux: f64, uy: f64) -> (u32, f64, f64) {
        let (w, h) = (self.width as usize, self.height as usize);
        let ux = clamp_unit(ux);
        let uy = clamp_unit(uy);
        if self.total <= 0.0 {
            // Black map: uniform over the sphere.
            let c = 1.0 - 2.0 * uy;
            let phi = 2.0 * PI * ux;
            let j = (((1.0 - c) * 0.5 * h as f64) as usize).min(h - 1);
            let i = ((ux * w as f64) as usize).min(w - 1);
            return ((j * w + i) as u32, phi, c);
        }
        let (j, fy) = invert_cdf(&self.marginal, uy);
        let row = &self.conditional[j * (w + 1)..(j + 1) * (w + 1)];
        let (i, fx) = invert_cdf(row, ux);
        let (c0, c1) = (self.cos_theta[j], self.cos_theta[j + 1]);
        let c = c0 - fy * (c0 - c1);
        let phi = 2.0 * PI * (i as f64 + fx) / w as f64;
        ((j * w + i) as u32, phi, c)
    }

    /// The table's points through the inverse CDF (see [`table_point`]).
    fn draw_table(&self) -> Vec<TableEntry> {
        (0..TABLE_SIZE as u32)
            .map(|m| {
                let (ux, uy) = table_point(m);
                self.sample_map(ux, uy)
            })
            .collect()
    }

    /// Row of `dir`: the number of row boundaries k in 1..H with θ ≥ θ_k (binary search; module doc).
    fn row_of(&self, dir: Vec3) -> u32 {
        let h = self.height;
        let (x, y, z) = (dir.x, dir.y, dir.z);
        let h2 = x * x + z * z;
        let yy = y * y;
        let below = |k: u32| -> bool {
            let t = self.row_t[k as usize] * h2;
            if 2 * k <= h {
                y <= 0.0 || yy <= t
            } else {
                y < 0.0 && yy >= t
            }
        };
        let (mut lo, mut hi) = (1u32, h);
        while lo < hi {
            let mid = (lo + hi) / 2;
            if below(mid) {
                lo = mid + 1;
            } else {
                hi = mid;
            }
        }
        lo - 1
    }
}

/// A table entry before rotation and scale: (texel, φ_map, cos θ).
type TableEntry = (u32, f64, f64);

impl ColumnBounds {
    /// World boundaries ψ_i = (2πi/W − rotation) mod 2π of map column i, sorted (a cyclic shift).
    fn build(width: u32, rotation_deg: f32) -> ColumnBounds {
        let w = width as usize;
        let rot = (rotation_deg as f64).to_radians();
        let psi: Vec<f64> = (0..w).map(|i| (2.0 * PI * i as f64 / w as f64 - rot).rem_euclid(2.0 * PI)).collect();
        let mut first = 0usize;
        for i in 1..w {
            if psi[i] < psi[first] {
                first = i;
            }
        }
        let mut q = Vec::with_capacity(w);
        let mut f = Vec::with_capacity(w);
        for m in 0..w {
            let p = psi[(first + m) % w];
            let quadrant = ((p / (0.5 * PI)).floor() as i64).clamp(0, 3);
            let beta = p - quadrant as f64 * 0.5 * PI;
            let (s, c) = beta.sin_cos();
            q.push(quadrant as u32);
            f.push((s / (s + c)) as f32);
        }
        ColumnBounds { q, f, first: first as u32 }
    }

    /// Map column of `dir`: count the sorted boundaries at or before its pseudo-angle (module doc).
    fn column_of(&self, dir: Vec3, width: u32) -> u32 {
        let (q, a, b) = pseudo_angle(dir);
        let den = a + b;
        let at_or_after = |m: u32| -> bool {
            let bq = self.q[m as usize];
            q > bq || (q == bq && a >= self.f[m as usize] * den)
        };
        let (mut lo, mut hi) = (0u32, width);
        while lo < hi {
            let mid = (lo + hi) / 2;
            if at_or_after(mid) {
                lo = mid + 1;
            } else {
                hi = mid;
            }
        }
        (self.first + lo + width - 1) % width
    }
}

/// The quadrant of the world azimuth ψ = atan2(−x, z) and the direction's components turned back into
/// quadrant 0 (`a' ≥ 0`, `b' > 0`; fraction `a'/(a' + b')` grows with ψ). Exact: sign tests and
/// negations only. A direction along ±Y (or NaN) is put at ψ = 0.
fn pseudo_angle(dir: Vec3) -> (u32, f32, f32) {
    let (a, b) = (-dir.x, dir.z);
    if b > 0.0 && a >= 0.0 {
        (0, a, b)
    } else if a > 0.0 && b <= 0.0 {
        (1, -b, a)
    } else if b < 0.0 && a <= 0.0 {
        (2, -a, -b)
    } else if a < 0.0 && b >= 0.0 {
        (3, b, -a)
    } else {
        (0, 0.0, 1.0)
    }
}

fn clamp_unit(u: f64) -> f64 {
    if u.is_nan() {
        0.0
    } else {
        u.clamp(0.0, 1.0 - f64::EPSILON / 2.0)
    }
}

/// Divide a cumulative sum by its last value (0 … 1); an all-zero one becomes uniform.
fn normalise_cdf(cdf: &mut [f64]) {
    let n = cdf.len() - 1;
    let total = cdf[n];
    if total > 0.0 && total.is_finite() {
        for c in cdf.iter_mut() {
            *c /= total;
        }
    } else {
        for (k, c) in cdf.iter_mut().enumerate() {
            *c = k as f64 / n as f64;
        }
    }
    cdf[n] = 1.0;
}

/// The interval `k` with `cdf[k] ≤ u < cdf[k+1]` (never an empty one) and u's fraction within it.
fn invert_cdf(cdf: &[f64], u: f64) -> (usize, f64) {
    let n = cdf.len() - 1;
    // First index with cdf > u, minus one: the last k with cdf[k] <= u.
    let k = cdf.partition_point(|&c| c <= u).clamp(1, n) - 1;
    let width = cdf[k + 1] - cdf[k];
    let frac = if width > 0.0 { ((u - cdf[k]) / width).clamp(0.0, 1.0) } else { 0.5 };
    (k, frac)
}

/// Point `m` of the table's point set in [0, 1)²: the first two dimensions of Sobol' (a (0,2)-sequence
/// in base 2), Owen-scrambled with fixed seeds so the table is deterministic.
pub fn table_point(m: u32) -> (f64, f64) {
    let unit = |v: u32| (v as f64 + 0.5) / 4_294_967_296.0;
    (unit(owen(m.reverse_bits(), 0x8a3c_0e71)), unit(owen(sobol1(m), 0x1f2b_99d5)))
}

/// Sobol' dimension 1 (primitive polynomial x + 1) of index `i` as a 32-bit fraction.
fn sobol1(mut i: u32) -> u32 {
    let (mut x, mut v) = (0u32, 1u32 << 31);
    while i != 0 {
        if i & 1 != 0 {
            x ^= v;
        }
        i >>= 1;
        v ^= v >> 1;
    }
    x
}

/// Nested uniform (Owen) scramble of a 32-bit fraction (Burley 2020, Laine–Karras hash).
fn owen(x: u32, seed: u32) -> u32 {
    let mut v = x.reverse_bits().wrapping_add(seed);
    v ^= v.wrapping_mul(0x6c50_b47c);
    v ^= v.wrapping_mul(0xb82f_1e52);
    v ^= v.wrapping_mul(0xc7af_e638);
    v ^= v.wrapping_mul(0x8d22_f6e6);
    v.reverse_bits()
}

/// B_e: the 99%-energy radius (cycles per radian) of the 2-D power spectrum of `lum` (W × H,
/// row-major), DC included; maps wider than [`BANDWIDTH_MAX_COLUMNS`] are box-averaged first.
pub fn bandwidth_99(lum: &[f32], width: usize, height: usize) -> f32 {
    use rustfft::num_complex::Complex;
    let factor = width.div_ceil(BANDWIDTH_MAX_COLUMNS as usize).max(1);
    let (w, h) = (width / factor, height / factor);
    if w == 0 || h == 0 {
        return 0.0;
    }
    let mut grid = vec![Complex::new(0.0f64, 0.0); w * h];
    for y in 0..h {
        for x in 0..w {
            let mut s = 0.0f64;
            for dy in 0..factor {
                for dx in 0..factor {
                    s += lum[(y * factor + dy) * width + x * factor + dx] as f64;
                }
            }
            grid[y * w + x].re = s / (factor * factor) as f64;
        }
    }
    let mut planner = rustfft::FftPlanner::<f64>::new();
    let row_fft = planner.plan_fft_forward(w);
    for row in grid.chunks_exact_mut(w) {
        row_fft.process(row);
    }
    let col_fft = planner.plan_fft_forward(h);
    let mut column = vec![Complex::new(0.0f64, 0.0); h];
    for x in 0..w {
        for y in 0..h {
            column[y] = grid[y * w + x];
        }
        col_fft.process(&mut column);
        for y in 0..h {
            grid[y * w + x] = column[y];
        }
    }
    // Signed frequency of bin k of n: k for k ≤ n/2, k − n above.
    let signed = |k: usize, n: usize| {
        if k <= n / 2 {
            k as f64
        } else {
            k as f64 - n as f64
        }
    };
    let mut bins: Vec<(f64, f64)> = Vec::with_capacity(w * h);
    let mut total = 0.0;
    for y in 0..h {
        let fy = signed(y, h) / PI;
        for x in 0..w {
            let fx = signed(x, w) / (2.0 * PI);
            let p = grid[y * w + x].norm_sqr();
            total += p;
            bins.push(((fx * fx + fy * fy).sqrt(), p));
        }
    }
    if !(total > 0.0 && total.is_finite()) {
        return 0.0;
    }
    bins.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut sum = 0.0;
    for (r, p) in bins {
        sum += p;
        if sum >= BANDWIDTH_ENERGY * total {
            return r as f32;
        }
    }
    0.0
}

fn check_size(path: &Path, width: u32, height: u32) -> Result<(), SceneError> {
    if width == 0 || height == 0 {
        return Err(SceneError::invalid(
            path,
            format!("the environment map is empty ({width}x{height})"),
            "give a lat-long map with width = 2 × height",
        ));
    }
    if width > MAX_TEXTURE_SIDE || height > MAX_TEXTURE_SIDE || width as u64 * height as u64 > MAX_TEXTURE_PIXELS {
        return Err(SceneError::invalid(
            path,
            format!(
                "the environment map is {width}x{height} texels, more than the limit \
                 ({MAX_TEXTURE_SIDE} per side, {MAX_TEXTURE_PIXELS} texels in all)"
            ),
            "downscale the map (8192x4096 at most)",
        ));
    }
    if width != 2 * height {
        return Err(SceneError::invalid(
            path,
            format!("the environment map is {width}x{height} texels, not 2:1"),
            "give a lat-long (equirectangular) map whose width is twice its height, e.g. 2048x1024 \
             (cube maps and mirror-ball images must be converted first)",
        ));
    }
    Ok(())
}

/// Count NaN, infinite, negative and over-`MAX_RADIANCE` texels (a texel counts once per kind, if
/// any channel is of that kind) and refuse the map if any, naming the first of each kind.
fn check_texels(path: &Path, width: u32, texels: &[[f32; 3]]) -> Result<(), SceneError> {
    let mut counts = [0u64; 4];
    let mut first: [Option<usize>; 4] = [None; 4];
    for (k, c) in texels.iter().enumerate() {
        let kinds = [
            c.iter().any(|v| v.is_nan()),
            c.iter().any(|v| v.is_infinite()),
            c.iter().any(|&v| v < 0.0),
            c.iter().any(|&v| v.is_finite() && v > MAX_RADIANCE),
        ];
        for (n, &is) in kinds.iter().enumerate() {
            if is {
                counts[n] += 1;
                first[n].get_or_insert(k);
            }
        }
    }
    if counts.iter().all(|&c| c == 0) {
        return Ok(());
    }
    let names = ["NaN", "infinite", "negative", "over 1e12"];
    let at: Vec<String> = first
        .iter()
        .zip(names)
        .filter_map(|(f, n)| {
            f.map(|k| format!("first {n} at column {}, row {}", k % width as usize, k / width as usize))
        })
        .collect();
    let mut what =
        format!("the environment map has {} NaN, {} infinite, {} negative texels", counts[0], counts[1], counts[2]);
    if counts[3] > 0 {
        what += &format!(" and {} over the radiance limit of {MAX_RADIANCE:e}", counts[3]);
    }
    what += &format!(" ({})", at.join("; "));
    Err(SceneError::invalid(
        path,
        what,
        "fix the map in an image editor or re-export it (radiance must be finite and >= 0); the map \
         is refused rather than clamped, so no texel is silently changed",
    ))
}

fn read_exr(path: &Path) -> Result<Texels, SceneError> {
    use exr::prelude::{ReadChannels, ReadLayers};
    use std::io::Read;
    let bytes = crate::resource::read_capped(path, None)?;
    let not_exr = |why: String| {
        SceneError::invalid(
            path,
            format!("not a readable OpenEXR image ({why})"),
            "re-export the map as an RGB OpenEXR (half or float), or use .hdr",
        )
    };
    let mut magic = [0u8; 4];
    if (&bytes[..]).read_exact(&mut magic).is_err() || magic != [0x76, 0x2f, 0x31, 0x01] {
        return Err(not_exr("it does not start with the OpenEXR magic number".into()));
    }
    let meta = exr::meta::MetaData::read_from_buffered(std::io::Cursor::new(&bytes[..]), false)
        .map_err(|e| not_exr(e.to_string()))?;
    let Some(header) = meta.headers.first() else {
        return Err(not_exr("it has no layer".into()));
    };
    // Every layer's size first: the reader may allocate per layer.
    for h in meta.headers.iter() {
        check_size_only(path, h.layer_size.0, h.layer_size.1)?;
    }
    let has = |c: &str| header.channels.list.iter().any(|ch| ch.name.eq(c));
    if !(has("R") && has("G") && has("B")) {
        let found: Vec<String> = header.channels.list.iter().map(|ch| ch.name.to_string()).collect();
        return Err(SceneError::invalid(
            path,
            format!(
                "the first layer has no R, G and B channels (it has {})",
                if found.is_empty() { "none".to_string() } else { found.join(", ") }
            ),
            "export the map with R, G, B channels",
        ));
    }
    let (w, h) = (header.layer_size.0, header.layer_size.1);
    check_size(path, w as u32, h as u32)?;
    struct Pixels {
        w: usize,
        texels: Vec<[f32; 3]>,
    }
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .rgba_channels(
            |res, _| Pixels { w: res.width(), texels: vec![[0.0; 3]; res.width() * res.height()] },
            |p: &mut Pixels, pos, (r, g, b, _a): (f32, f32, f32, f32)| {
                let i = pos.y() * p.w + pos.x();
                if let Some(t) = p.texels.get_mut(i) {
                    *t = [r, g, b];
                }
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_buffered(std::io::Cursor::new(&bytes[..]))
        .map_err(|e| not_exr(e.to_string()))?;
    let layer = image.layer_data;
    let (lw, lh) = (layer.size.0 as u32, layer.size.1 as u32);
    check_size(path, lw, lh)?;
    Ok((lw, lh, layer.channel_data.pixels.texels))
}

/// The size caps alone (before the 2:1 check, for layers we will not read).
fn check_size_only(path: &Path, w: usize, h: usize) -> Result<(), SceneError> {
    if w as u64 > MAX_TEXTURE_SIDE as u64
        || h as u64 > MAX_TEXTURE_SIDE as u64
        || (w as u64).saturating_mul(h as u64) > MAX_TEXTURE_PIXELS
    {
        return Err(SceneError::invalid(
            path,
            format!(
                "a layer is {w}x{h} texels, more than the limit ({MAX_TEXTURE_SIDE} per side, \
                 {MAX_TEXTURE_PIXELS} texels in all)"
            ),
            "downscale the map (8192x4096 at most)",
        ));
    }
    Ok(())
}

fn read_hdr(path: &Path) -> Result<Texels, SceneError> {
    let bytes = crate::resource::read_capped(path, None)?;
    let unreadable = |e: &dyn std::fmt::Display| {
        SceneError::invalid(
            path,
            format!("not a readable Radiance HDR image ({e})"),
            "re-export the map as Radiance RGBE (.hdr) or OpenEXR (.exr)",
        )
    };
    let reader = || {
        let mut r = image::ImageReader::new(std::io::Cursor::new(&bytes[..]));
        r.set_format(image::ImageFormat::Hdr);
        r
    };
    let (w, h) = reader().into_dimensions().map_err(|e| unreadable(&e))?;
    check_size(path, w, h)?;
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(MAX_TEXTURE_SIDE);
    limits.max_image_height = Some(MAX_TEXTURE_SIDE);
    limits.max_alloc = Some(MAX_TEXTURE_PIXELS * 16 + (64 << 20));
    let mut decoder = reader();
    decoder.limits(limits);
    let img = decoder.decode().map_err(|e| unreadable(&e))?.into_rgb32f();
    let (w, h) = (img.width(), img.height());
    check_size(path, w, h)?;
    let texels = img.pixels().map(|p| p.0).collect();
    Ok((w, h, texels))
}

/// The built-in maps, generated in code (no file in git).
mod procedural {
    use super::*;

    /// Map direction (convention of the module doc, no rotation) of texel-space point (x, y) of a
    /// W × H map.
    fn dir(x: f64, y: f64, w: usize, h: usize) -> [f64; 3] {
        let phi = 2.0 * PI * x / w as f64;
        let theta = PI * y / h as f64;
        let s = theta.sin();
        [-phi.sin() * s, theta.cos(), phi.cos() * s]
    }

    fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
        a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
    }

    /// Unit direction at azimuth `u` (turns, map convention) and elevation `el` (degrees).
    fn at(u: f64, el: f64) -> [f64; 3] {
        let phi = 2.0 * PI * u;
        let e = el.to_radians();
        [-phi.sin() * e.cos(), e.sin(), phi.cos() * e.cos()]
    }

    /// Average of `f` over 4 × 4 points of each texel (so small bright shapes keep their energy and
    /// get soft one-texel edges), rows in parallel-free plain loops (the maps are small).
    fn render(w: usize, h: usize, f: impl Fn([f64; 3]) -> [f64; 3]) -> Vec<[f32; 3]> {
        let mut out = Vec::with_capacity(w * h);
        for y in 0..h {
            for x in 0..w {
                let mut acc = [0.0f64; 3];
                for sy in 0..4 {
                    for sx in 0..4 {
                        let d = dir(x as f64 + (sx as f64 + 0.5) / 4.0, y as f64 + (sy as f64 + 0.5) / 4.0, w, h);
                        let c = f(d);
                        for k in 0..3 {
                            acc[k] += c[k] / 16.0;
                        }
                    }
                }
                out.push([acc[0] as f32, acc[1] as f32, acc[2] as f32]);
            }
        }
        out
    }

    /// Where the sky's sun is: azimuth u = 0.42 (a little left of −Z, which is u = 0.5), 35° up —
    /// behind the `envmap` scene's objects seen from its camera, so their shadows fall toward it.
    pub const SUN_U: f64 = 0.42;
    pub const SUN_ELEVATION_DEG: f64 = 35.0;
    /// The sun's angular radius (degrees) and radiance (thousands × the sky's ~0.3–1.2).
    pub const SUN_RADIUS_DEG: f64 = 1.5;
    pub const SUN_RADIANCE: [f64; 3] = [4000.0, 3700.0, 3300.0];

    /// `builtin:sky`, 512 × 256: a sun disk 1.5° in radius at 4000 (sharp shadows), a blue-to-white
    /// sky gradient with a glow around the sun, three soft clouds, two bright rectangular "windows"
    /// (radiance 30–40, 20–30° wide: mid-frequency light from the sides), and a darker brown ground.
    pub fn sky() -> Texels {
        let (w, h) = (512usize, 256usize);
        let sun = at(SUN_U, SUN_ELEVATION_DEG);
        let sun_cos = SUN_RADIUS_DEG.to_radians().cos();
        // Clouds: (centre, angular radius in rad, brightness added).
        let clouds = [(at(0.62, 25.0), 0.22, 0.9), (at(0.30, 50.0), 0.18, 0.7), (at(0.85, 15.0), 0.25, 0.8)];
        // Windows: (u range, elevation range in degrees, radiance).
        let windows =
            [((0.70, 0.76), (5.0, 25.0), [40.0, 36.0, 30.0]), ((0.10, 0.16), (10.0, 30.0), [24.0, 28.0, 34.0])];
        let texels = render(w, h, |d| {
            let y = d[1];
            if y < 0.0 {
                // Ground: dark brown, a little lighter toward the horizon.
                let t = (-y).sqrt();
                let g = 0.12 * (1.0 - t) + 0.05 * t;
                return [g * 1.1, g, g * 0.8];
            }
            let t = y.sqrt();
            let horizon = [1.0, 0.95, 0.9];
            let zenith = [0.25, 0.4, 0.85];
            let mut c = [0.0; 3];
            for k in 0..3 {
                c[k] = horizon[k] * (1.0 - t) + zenith[k] * t;
            }
            // Glow around the sun (soft, a few degrees).
            let cos_sun = dot(d, sun);
            let glow = 3.0 * ((cos_sun - 1.0) / 0.02).exp();
            for k in 0..3 {
                c[k] += glow * [1.0, 0.9, 0.7][k];
            }
            for (centre, radius, bright) in clouds {
                let ang = dot(d, centre).clamp(-1.0, 1.0).acos();
                let s = (1.0 - ang / radius).clamp(0.0, 1.0);
                let s = s * s * (3.0 - 2.0 * s);
                for v in c.iter_mut() {
                    *v = *v * (1.0 - 0.5 * s) + bright * s;
                }
            }
            let u = (-d[0]).atan2(d[2]).rem_euclid(2.0 * PI) / (2.0 * PI);
            let el = y.clamp(-1.0, 1.0).asin().to_degrees();
            for ((u0, u1), (e0, e1), rad) in windows {
                if u >= u0 && u < u1 && el >= e0 && el < e1 {
                    c = rad;
                }
            }
            if cos_sun >= sun_cos {
                c = SUN_RADIANCE;
            }
            c
        });
        (w as u32, h as u32, texels)
    }

    /// `builtin:studio`, 256 × 128: a dark grey room (0.03) with a large warm key box (radiance 30),
    /// a cool fill box (10) on the other side, and a bright thin strip overhead (60).
    pub fn studio() -> Texels {
        let (w, h) = (256usize, 128usize);
        let boxes = [
            ((0.36, 0.46), (20.0, 50.0), [30.0, 27.0, 22.0]),
            ((0.62, 0.70), (5.0, 35.0), [8.0, 9.0, 11.0]),
            ((0.45, 0.55), (70.0, 80.0), [60.0, 60.0, 60.0]),
        ];
        let texels = render(w, h, |d| {
            let u = (-d[0]).atan2(d[2]).rem_euclid(2.0 * PI) / (2.0 * PI);
            let el = d[1].clamp(-1.0, 1.0).asin().to_degrees();
            for ((u0, u1), (e0, e1), rad) in boxes {
                if u >= u0 && u < u1 && el >= e0 && el < e1 {
                    return rad;
                }
            }
            if d[1] < 0.0 {
                [0.02; 3]
            } else {
                [0.03 + 0.02 * d[1]; 3]
            }
        });
        (w as u32, h as u32, texels)
    }

    /// A clear sky under a small, intense sun (the environment suite's high-frequency light):
    /// horizon-to-zenith blue gradient, a dark ground, the sun `radius_deg` in angular radius at
    /// `radiance` at azimuth `u`, `elevation` degrees up, with a faint glow of a few degrees.
    fn clear_sky(w: usize, h: usize, (u, elevation): (f64, f64), radius_deg: f64, radiance: [f64; 3]) -> Vec<[f32; 3]> {
        let sun = at(u, elevation);
        let sun_cos = radius_deg.to_radians().cos();
        render(w, h, |d| {
            if d[1] < 0.0 {
                return [0.08, 0.07, 0.06];
            }
            let t = d[1].sqrt();
            let cos_sun = dot(d, sun);
            if cos_sun >= sun_cos {
                return radiance;
            }
            let glow = 2.0 * ((cos_sun - 1.0) / 0.01).exp();
            let sky = [0.9 * (1.0 - t) + 0.2 * t, 0.9 * (1.0 - t) + 0.35 * t, 0.95 * (1.0 - t) + 0.8 * t];
            std::array::from_fn(|k| sky[k] + glow * [1.0, 0.85, 0.6][k])
        })
    }

    /// `builtin:sun`, 1024 × 512: a clear sky and a sun 0.5° in radius at 30 000 (about the
    /// irradiance of `sky`'s sun from a ninth of its solid angle: shadows three times sharper and a
    /// far higher `B_e`), 50° up behind the suite's scenes; nothing else in the sky.
    pub fn sun() -> Texels {
        let (w, h) = (1024usize, 512usize);
        (w as u32, h as u32, clear_sky(w, h, (0.44, 50.0), 0.5, [30000.0, 28500.0, 26000.0]))
    }

    /// `builtin:sunset`, 1024 × 512: the sun 1° in radius at 6 000, 6° above the horizon (long
    /// shadows, light grazing the ground), over the same clear sky.
    pub fn sunset() -> Texels {
        let (w, h) = (1024usize, 512usize);
        (w as u32, h as u32, clear_sky(w, h, (0.40, 6.0), 1.0, [6000.0, 4200.0, 2400.0]))
    }

    /// `builtin:overcast`, 256 × 128: the CIE standard overcast sky, radiance (1 + 2 sin θ)/3 of a
    /// zenith 1.5 (no sun, no features: the smoothest light there is, `B_e` near its floor), over a
    /// uniform ground of 0.15.
    pub fn overcast() -> Texels {
        let (w, h) = (256usize, 128usize);
        let texels = render(w, h, |d| if d[1] < 0.0 { [0.15; 3] } else { [1.5 * (1.0 + 2.0 * d[1]) / 3.0; 3] });
        (w as u32, h as u32, texels)
    }
}

pub use procedural::{SUN_ELEVATION_DEG, SUN_RADIANCE, SUN_RADIUS_DEG, SUN_U};

/// The direction of `builtin:sky`'s sun at `rotation_deg` 0 (unit, world = map frame).
pub fn sky_sun_direction() -> Vec3 {
    let phi = 2.0 * PI * SUN_U;
    let e = SUN_ELEVATION_DEG.to_radians();
    Vec3::new((-phi.sin() * e.cos()) as f32, e.sin() as f32, (phi.cos() * e.cos()) as f32)
}
