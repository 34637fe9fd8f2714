//! Input mutation: byte-level (bit flips, interesting bytes and integers, float bit patterns,
//! deletions, duplications, insertions, splices from other corpus entries, truncation) and, for
//! text targets, token-level (numbers replaced by interesting values such as 0, -1, 1e38, NaN,
//! 4294967295; dictionary words inserted or substituted; lines duplicated, deleted or swapped).
//! Everything draws from one seeded [`fastrand::Rng`], so a run is reproducible from its seed.

use fastrand::Rng;

/// Numbers that break readers: zero, signs, powers of two and their neighbours, type limits,
/// huge, tiny and non-finite floats, fractions where integers are wanted.
const NUMBERS: &[&str] = &[
    "0",
    "-0",
    "1",
    "-1",
    "2",
    "3",
    "4",
    "7",
    "8",
    "16",
    "255",
    "256",
    "-128",
    "65535",
    "65536",
    "2147483647",
    "-2147483648",
    "4294967295",
    "4294967296",
    "9223372036854775807",
    "18446744073709551615",
    "1e38",
    "3.4e38",
    "-3.4e38",
    "1e39",
    "1e300",
    "1e-45",
    "1e-300",
    "0.5",
    "-0.5",
    "64.5",
    "NaN",
    "nan",
    "inf",
    "-inf",
    "1e",
    ".",
    "-",
    "00",
    "0x10",
    "5120",
    "5121",
    "5122",
    "5123",
    "5125",
    "5126",
    "34962",
    "34963",
];

const BYTES: &[u8] = &[0, 1, 0x7f, 0x80, 0xff, b'\n', b'"', b'(', b')', b'[', b']', b'{', b'}', b',', b':', b'\\'];

const INTS: &[u64] = &[
    0,
    1,
    2,
    4,
    0x7f,
    0x80,
    0xff,
    0x100,
    0x7fff,
    0x8000,
    0xffff,
    0x1_0000,
    0x7fff_ffff,
    0x8000_0000,
    0xffff_ffff,
    u64::MAX,
    u64::MAX - 1,
];

const FLOATS: &[f32] = &[
    0.0,
    -0.0,
    1.0,
    -1.0,
    0.5,
    1e38,
    -1e38,
    f32::MAX,
    f32::MIN_POSITIVE,
    1e-45,
    f32::NAN,
    f32::INFINITY,
    f32::NEG_INFINITY,
];

/// A mutator for one target: its dictionary, whether token-level mutations apply, and the
/// largest input it produces.
pub struct Mutator {
    pub rng: Rng,
    dictionary: &'static [&'static str],
    text: bool,
    max_len: usize,
}

/// Words worth inserting for a target (field names, keywords, syntax fragments).
pub fn dictionary(target: &str) -> &'static [&'static str] {
    match target {
        "pipeline" => &[
            "Pipeline(",
            "scene:",
            "width:",
            "height:",
            "seed:",
            "camera:",
            "nodes:",
            "name:",
            "kind:",
            "params:",
            "inputs:",
            "Some(",
            "None",
            "position:",
            "look_at:",
            "up:",
            "vfov_deg:",
            "aperture_radius:",
            "focus_distance:",
            "\"Primary\"",
            "\"Output\"",
            "\"SoftShadows\"",
            "\"Indirect\"",
            "\"Add\"",
            "\"MonteCarlo\"",
            "\"primary.position\"",
            "\"primary.normal\"",
            "\"color\"",
            "\"builtin:grids\"",
            "\"builtin:heavy\"",
            "(",
            ")",
            "[",
            "]",
            "{",
            "}",
            ",",
            ":",
            "\"",
            "//",
            "/*",
            "*/",
            "r#\"",
            "\u{feff}",
            "true",
            "false",
            "'x'",
            "#![enable(implicit_some)]",
        ],
        "gltf" | "glb" => &[
            "\"accessors\"",
            "\"bufferView\"",
            "\"byteOffset\"",
            "\"byteStride\"",
            "\"byteLength\"",
            "\"componentType\"",
            "\"count\"",
            "\"type\"",
            "\"VEC3\"",
            "\"VEC2\"",
            "\"SCALAR\"",
            "\"MAT4\"",
            "\"indices\"",
            "\"POSITION\"",
            "\"NORMAL\"",
            "\"TEXCOORD_0\"",
            "\"material\"",
            "\"mode\"",
            "\"children\"",
            "\"mesh\"",
            "\"camera\"",
            "\"matrix\"",
            "\"scale\"",
            "\"rotation\"",
            "\"translation\"",
            "\"yfov\"",
            "\"uri\"",
            "\"buffer\"",
            "\"sparse\"",
            "\"normalized\"",
            "\"emissiveFactor\"",
            "\"emissiveStrength\"",
            "\"baseColorTexture\"",
            "\"index\"",
            "\"source\"",
            "\"images\"",
            "\"/etc/passwd\"",
            "\"../buffer.bin\"",
            "\"tex.png\"",
            "[0]",
            "[0, 0]",
            "{}",
            "[]",
            "null",
            ":",
            ",",
            "{",
            "}",
            "[",
            "]",
        ],
        "obj" => &[
            "v ",
            "vt ",
            "vn ",
            "f ",
            "o ",
            "g ",
            "s ",
            "l ",
            "p ",
            "usemtl ",
            "mtllib ",
            "newmtl ",
            "Kd ",
            "Ks ",
            "Ke ",
            "Ns ",
            "Ni ",
            "d ",
            "Tr ",
            "illum ",
            "map_Kd ",
            "map_Ke ",
            "map_Bump ",
            "scene.mtl",
            "tex.png",
            "missing",
            "/",
            "//",
            "\n",
            " ",
            "\\\n",
            "#",
            "1/1/1",
            "-1",
            "0",
            "nan",
        ],
        _ => &[
            "channels",
            "compression",
            "dataWindow",
            "displayWindow",
            "lineOrder",
            "pixelAspectRatio",
            "screenWindowCenter",
            "screenWindowWidth",
            "tiles",
            "chunkCount",
            "type",
            "name",
            "box2i",
            "chlist",
            "compression",
            "half",
            "float",
            "R",
            "G",
            "B",
            "A",
            "\0",
        ],
    }
}

impl Mutator {
    pub fn new(seed: u64, target: &str, text: bool, max_len: usize) -> Self {
        Mutator { rng: Rng::with_seed(seed), dictionary: dictionary(target), text, max_len }
    }

    /// A mutated copy of `input`: 1, 2, 4 or 8 stacked mutations; `other` is a donor for splices.
    pub fn mutate(&mut self, input: &[u8], other: &[u8]) -> Vec<u8> {
        let mut data = input.to_vec();
        let count = 1usize << self.rng.u32(0..4);
        for _ in 0..count {
            self.mutate_once(&mut data, other);
        }
        data.truncate(self.max_len);
        data
    }

    fn mutate_once(&mut self, data: &mut Vec<u8>, other: &[u8]) {
        // Token-level mutations are more productive on text formats, so they get more weight there.
        let choice = if self.text && self.rng.bool() { self.rng.u32(100..106) } else { self.rng.u32(0..11) };
        let len = data.len();
        match choice {
            0 if len > 0 => {
                let i = self.rng.usize(..len);
                data[i] ^= 1 << self.rng.u32(0..8);
            }
            1 if len > 0 => {
                let i = self.rng.usize(..len);
                data[i] = if self.rng.bool() { BYTES[self.rng.usize(..BYTES.len())] } else { self.rng.u8(..) };
            }
            2 if len > 0 => {
                // An interesting integer, 1/2/4/8 bytes, either endianness.
                let width = 1usize << self.rng.u32(0..4);
                let v = INTS[self.rng.usize(..INTS.len())];
                let bytes = if self.rng.bool() { v.to_le_bytes() } else { v.to_be_bytes() };
                let at = self.rng.usize(..len);
                let end = (at + width).min(len);
                let src = if self.rng.bool() { &bytes[..width] } else { &bytes[8 - width..] };
                data[at..end].copy_from_slice(&src[..end - at]);
            }
            3 if len >= 4 => {
                let v = FLOATS[self.rng.usize(..FLOATS.len())].to_le_bytes();
                let at = self.rng.usize(..=len - 4);
                data[at..at + 4].copy_from_slice(&v);
            }
            4 if len > 0 => {
                // Delete a range, usually short.
                let n = self.small_len(len);
                let at = self.rng.usize(..=len - n);
                data.drain(at..at + n);
            }
            5 if len > 0 => {
                // Duplicate a range somewhere (possibly many times: long repeats).
                let n = self.small_len(len);
                let from = self.rng.usize(..=len - n);
                let chunk = data[from..from + n].to_vec();
                let at = self.rng.usize(..=len);
                let times = if self.rng.u32(0..16) == 0 { self.rng.usize(2..64) } else { 1 };
                for _ in 0..times {
                    data.splice(at..at, chunk.iter().copied());
                }
            }
            6 => {
                // Insert random or repeated bytes.
                let n = self.rng.usize(1..32);
                let at = self.rng.usize(..=len);
                let byte = self.rng.u8(..);
                let repeat = self.rng.bool();
                let bytes: Vec<u8> = (0..n).map(|_| if repeat { byte } else { self.rng.u8(..) }).collect();
                data.splice(at..at, bytes);
            }
            7 if !other.is_empty() => {
                // Splice: a chunk of another corpus entry, inserted or overwriting.
                let n = self.small_len(other.len());
                let from = self.rng.usize(..=other.len() - n);
                let at = self.rng.usize(..=len);
                if self.rng.bool() {
                    data.splice(at..at, other[from..from + n].iter().copied());
                } else {
                    let end = (at + n).min(len);
                    data.splice(at..end, other[from..from + n].iter().copied());
                }
            }
            8 if len > 0 => {
                data.truncate(self.rng.usize(..len));
            }
            9 | 10 => {
                let word = self.dictionary[self.rng.usize(..self.dictionary.len())];
                let at = self.rng.usize(..=len);
                data.splice(at..at, word.bytes());
            }
            100 | 101 => self.replace_number(data),
            102 => {
                // Replace a word (identifier, quoted string or number) with a dictionary word.
                let words = spans(data, |c| c.is_ascii_alphanumeric() || c == b'_' || c == b'"');
                if let Some(&(a, b)) = self.pick(&words) {
                    let word = self.dictionary[self.rng.usize(..self.dictionary.len())];
                    data.splice(a..b, word.bytes());
                }
            }
            103..=105 => self.mutate_lines(data),
            _ => {
                // The chosen mutation did not apply (e.g. empty input): insert a word instead.
                let word = self.dictionary[self.rng.usize(..self.dictionary.len())];
                let at = self.rng.usize(..=len);
                data.splice(at..at, word.bytes());
            }
        }
    }

    /// A length in 1..=max, biased towards short.
    fn small_len(&mut self, max: usize) -> usize {
        let cap = if self.rng.u32(0..8) == 0 { max } else { max.min(16) };
        self.rng.usize(1..=cap.max(1))
    }

    fn pick<'a, T>(&mut self, v: &'a [T]) -> Option<&'a T> {
        (!v.is_empty()).then(|| &v[self.rng.usize(..v.len())])
    }

    fn replace_number(&mut self, data: &mut Vec<u8>) {
        let numbers = spans(data, |c| c.is_ascii_digit() || matches!(c, b'.' | b'-' | b'e' | b'E' | b'+'))
            .into_iter()
            .filter(|&(a, b)| data[a..b].iter().any(u8::is_ascii_digit))
            .collect::<Vec<_>>();
        if let Some(&(a, b)) = self.pick(&numbers) {
            let n = NUMBERS[self.rng.usize(..NUMBERS.len())];
            data.splice(a..b, n.bytes());
        }
    }

    fn mutate_lines(&mut self, data: &mut Vec<u8>) {
        let mut lines: Vec<Vec<u8>> = data.split(|&c| c == b'\n').map(<[u8]>::to_vec).collect();
        let n = lines.len();
        match self.rng.u32(0..3) {
            0 => {
                let i = self.rng.usize(..n);
                let line = lines[i].clone();
                lines.insert(self.rng.usize(..=n), line);
            }
            1 if n > 1 => {
                lines.remove(self.rng.usize(..n));
            }
            _ => {
                let (i, j) = (self.rng.usize(..n), self.rng.usize(..n));
                lines.swap(i, j);
            }
        }
        *data = lines.join(&b'\n');
    }
}

/// Maximal runs of bytes satisfying `f`, as (start, end).
fn spans(data: &[u8], f: impl Fn(u8) -> bool) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut start = None;
    for (i, &c) in data.iter().enumerate() {
        match (f(c), start) {
            (true, None) => start = Some(i),
            (false, Some(s)) => {
                out.push((s, i));
                start = None;
            }
            _ => {}
        }
    }
    if let Some(s) = start {
        out.push((s, data.len()));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_seed_same_mutations() {
        let input = b"Pipeline(width: 64, height: 48, nodes: [])\nsecond line 12\n";
        let run = |seed| {
            let mut m = Mutator::new(seed, "pipeline", true, 1 << 16);
            (0..200).map(|_| m.mutate(input, b"other 1.5")).collect::<Vec<_>>()
        };
        assert_eq!(run(7), run(7));
        assert_ne!(run(7), run(8));
        // Mutations do change inputs and respect the length cap.
        let outs = run(7);
        assert!(outs.iter().filter(|o| o.as_slice() != input).count() > 150);
        let mut m = Mutator::new(1, "exr", false, 64);
        assert!((0..500).all(|_| m.mutate(&[0u8; 60], &[1u8; 60]).len() <= 64));
    }

    #[test]
    fn number_replacement_hits_numbers() {
        let mut m = Mutator::new(3, "pipeline", true, 1 << 16);
        let mut seen_interesting = false;
        for _ in 0..100 {
            let mut d = b"width: 64".to_vec();
            m.replace_number(&mut d);
            assert!(d.starts_with(b"width: "));
            seen_interesting |= d != b"width: 64";
        }
        assert!(seen_interesting);
    }
}
