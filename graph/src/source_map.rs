//! Source positions for a pipeline file.
//!
//! ron 0.12 deserializes into plain values and has no spanned values, so after a successful parse we
//! know *what* is wrong (node 3 names an unknown kind) but not *where* it was written. This module
//! recovers the "where" with a small tokenizer over the same source text: it records the 1-based
//! line and column of every token, walks `nodes: [ ( … ), … ]` by bracket depth, and remembers, for
//! each node tuple in file order, the tokens the validator wants to point at: the `name` string, the
//! `kind` string, every input key and its reference string, every parameter key. Because both the
//! serde parse and this walk see the nodes in file order, node `i` of [`crate::Pipeline::nodes`] is
//! entry `i` here.
//!
//! It also provides [`map_as_pairs`], the `deserialize_with` that reads a RON map into a `Vec` of
//! pairs so that a key written twice is kept (and reported by the validator) rather than silently
//! overwritten, which is what a `HashMap`/`BTreeMap` field would do.

use std::fmt;
use std::marker::PhantomData;

use serde::de::{Deserialize, Deserializer, MapAccess, Visitor};

/// Read a map into a list of pairs, preserving order and duplicate keys.
pub fn map_as_pairs<'de, D, K, V>(deserializer: D) -> Result<Vec<(K, V)>, D::Error>
where
    D: Deserializer<'de>,
    K: Deserialize<'de>,
    V: Deserialize<'de>,
{
    struct PairsVisitor<K, V>(PhantomData<(K, V)>);

    impl<'de, K: Deserialize<'de>, V: Deserialize<'de>> Visitor<'de> for PairsVisitor<K, V> {
        type Value = Vec<(K, V)>;

        fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
            f.write_str("a map such as {\"key\": value, …}")
        }

        fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Self::Value, A::Error> {
            let mut out = Vec::with_capacity(map.size_hint().unwrap_or(0));
            while let Some((k, v)) = map.next_entry()? {
                out.push((k, v));
            }
            Ok(out)
        }
    }

    deserializer.deserialize_map(PairsVisitor(PhantomData))
}

/// A 1-based line and column (columns count characters, as ron does).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Default)]
pub struct Pos {
    pub line: usize,
    pub col: usize,
}

#[derive(Clone, Debug, PartialEq)]
pub enum Tok {
    /// A string literal (normal or raw), with its decoded value.
    Str(String),
    Ident(String),
    /// A number literal, as written (`64`, `-1.5e3`, `0x1F`).
    Number(String),
    /// A character literal `'x'`.
    Char,
    Punct(char),
}

#[derive(Clone, Debug)]
pub struct Token {
    pub tok: Tok,
    pub pos: Pos,
}

/// Tokenize RON source. Lenient: anything unrecognised becomes punctuation, an unterminated string
/// or comment runs to the end; ron itself has already rejected malformed input when this matters.
pub fn tokenize(src: &str) -> Vec<Token> {
    let chars: Vec<char> = src.chars().collect();
    let mut out = Vec::new();
    let (mut i, mut line, mut col) = (0usize, 1usize, 1usize);
    // Advance one character, keeping line/col up to date.
    macro_rules! bump {
        () => {{
            if chars[i] == '\n' {
                line += 1;
                col = 1;
            } else {
                col += 1;
            }
            i += 1;
        }};
    }
    let is_ident_start = |c: char| c.is_alphabetic() || c == '_';
    let is_ident_char = |c: char| c.is_alphanumeric() || c == '_';
    while i < chars.len() {
        let c = chars[i];
        let next = chars.get(i + 1).copied();
        let pos = Pos { line, col };
        if c.is_whitespace() {
            bump!();
        } else if c == '/' && next == Some('/') {
            while i < chars.len() && chars[i] != '\n' {
                bump!();
            }
        } else if c == '/' && next == Some('*') {
            // Block comments nest in RON.
            let mut depth = 0usize;
            while i < chars.len() {
                if chars[i] == '/' && chars.get(i + 1) == Some(&'*') {
                    depth += 1;
                    bump!();
                    bump!();
                } else if chars[i] == '*' && chars.get(i + 1) == Some(&'/') {
                    depth -= 1;
                    bump!();
                    bump!();
                    if depth == 0 {
                        break;
                    }
                } else {
                    bump!();
                }
            }
        } else if c == '"' {
            bump!();
            let mut value = String::new();
            while i < chars.len() && chars[i] != '"' {
                if chars[i] == '\\' && i + 1 < chars.len() {
                    bump!();
                    let e = chars[i];
                    bump!();
                    match e {
                        'n' => value.push('\n'),
                        't' => value.push('\t'),
                        'r' => value.push('\r'),
                        '0' => value.push('\0'),
                        'u' if i < chars.len() && chars[i] == '{' => {
                            let mut hex = String::new();
                            bump!();
                            while i < chars.len() && chars[i] != '}' {
                                hex.push(chars[i]);
                                bump!();
                            }
                            if i < chars.len() {
                                bump!();
                            }
                            if let Some(ch) = u32::from_str_radix(&hex, 16).ok().and_then(char::from_u32) {
                                value.push(ch);
                            }
                        }
                        'x' => {
                            let mut hex = String::new();
                            for _ in 0..2 {
                                if i < chars.len() {
                                    hex.push(chars[i]);
                                    bump!();
                                }
                            }
                            if let Some(ch) = u32::from_str_radix(&hex, 16).ok().and_then(char::from_u32) {
                                value.push(ch);
                            }
                        }
                        '\n' => {
                            // Line continuation: skip leading whitespace of the next line.
                            while i < chars.len() && chars[i].is_whitespace() {
                                bump!();
                            }
                        }
                        other => value.push(other),
                    }
                } else {
                    value.push(chars[i]);
                    bump!();
                }
            }
            if i < chars.len() {
                bump!();
            }
            out.push(Token { tok: Tok::Str(value), pos });
        } else if (c == 'r' || c == 'b')
            && raw_string_hashes(&chars, if c == 'b' && next == Some('r') { i + 2 } else { i + 1 }).is_some()
            && (c == 'r' || next == Some('r'))
        {
            // Raw string r"…", r#"…"#, br"…": no escapes, ends at `"` followed by as many `#`.
            let start = if c == 'b' { i + 2 } else { i + 1 };
            let hashes = raw_string_hashes(&chars, start).unwrap();
            while i < start + hashes + 1 {
                bump!();
            }
            let mut value = String::new();
            loop {
                if i >= chars.len() {
                    break;
                }
                if chars[i] == '"' && (0..hashes).all(|k| chars.get(i + 1 + k) == Some(&'#')) {
                    for _ in 0..=hashes {
                        bump!();
                    }
                    break;
                }
                value.push(chars[i]);
                bump!();
            }
            out.push(Token { tok: Tok::Str(value), pos });
        } else if c == 'r' && next == Some('#') && chars.get(i + 2).is_some_and(|&c| is_ident_start(c)) {
            // Raw identifier r#name.
            bump!();
            bump!();
            let mut name = String::new();
            while i < chars.len() && (is_ident_char(chars[i]) || chars[i] == '.' || chars[i] == '+' || chars[i] == '-')
            {
                name.push(chars[i]);
                bump!();
            }
            out.push(Token { tok: Tok::Ident(name), pos });
        } else if is_ident_start(c) {
            let mut name = String::new();
            while i < chars.len() && is_ident_char(chars[i]) {
                name.push(chars[i]);
                bump!();
            }
            out.push(Token { tok: Tok::Ident(name), pos });
        } else if c.is_ascii_digit() || ((c == '-' || c == '+' || c == '.') && next.is_some_and(|n| n.is_ascii_digit()))
        {
            let start = i;
            bump!();
            while i < chars.len() {
                let d = chars[i];
                let prev = chars[i - 1];
                let exp_sign = (d == '+' || d == '-') && (prev == 'e' || prev == 'E');
                if d.is_ascii_alphanumeric() || d == '_' || d == '.' || exp_sign {
                    bump!();
                } else {
                    break;
                }
            }
            out.push(Token { tok: Tok::Number(chars[start..i].iter().collect()), pos });
        } else if c == '\'' {
            bump!();
            while i < chars.len() && chars[i] != '\'' {
                if chars[i] == '\\' {
                    bump!();
                }
                if i < chars.len() {
                    bump!();
                }
            }
            if i < chars.len() {
                bump!();
            }
            out.push(Token { tok: Tok::Char, pos });
        } else {
            bump!();
            out.push(Token { tok: Tok::Punct(c), pos });
        }
    }
    out
}

/// If `chars[start..]` is `#…#"` (zero or more `#`), the number of `#`.
fn raw_string_hashes(chars: &[char], start: usize) -> Option<usize> {
    let mut k = start;
    while chars.get(k) == Some(&'#') {
        k += 1;
    }
    (chars.get(k) == Some(&'"')).then_some(k - start)
}

/// Where the parts of one node tuple were written.
#[derive(Clone, Debug, Default)]
pub struct NodeSource {
    /// The opening `(` of the tuple (or its struct name, if written `NodeSpec(…)`).
    pub tuple: Pos,
    /// The `name` string literal.
    pub name: Option<Pos>,
    /// The `kind` string literal.
    pub kind: Option<Pos>,
    /// Each input entry in order: (key position, value position); parallel to `NodeSpec::inputs`.
    pub inputs: Vec<(Pos, Pos)>,
    /// Each parameter key position in order; parallel to `NodeSpec::params`.
    pub params: Vec<Pos>,
}

/// Positions of the top-level fields that validation points at.
#[derive(Clone, Debug, Default)]
pub struct SourceMap {
    /// The value of `scene`.
    pub scene: Option<Pos>,
    /// The `nodes` key.
    pub nodes_key: Option<Pos>,
    /// The values of `width` and `height`.
    pub width: Option<Pos>,
    pub height: Option<Pos>,
    /// The value of `camera` (`Some(…)`), and each field of the camera struct: (name, value position).
    pub camera: Option<Pos>,
    pub camera_fields: Vec<(String, Pos)>,
    /// The value of `motion` (its `[`), and each entry's fields: (name, value position) per entry.
    pub motion: Option<Pos>,
    pub motion_entries: Vec<(Pos, Vec<(String, Pos)>)>,
    /// The same for `camera_path`.
    pub camera_path: Option<Pos>,
    pub camera_path_entries: Vec<(Pos, Vec<(String, Pos)>)>,
    pub nodes: Vec<NodeSource>,
}

impl SourceMap {
    /// Build the map from source text that ron has already parsed successfully.
    pub fn build(src: &str) -> SourceMap {
        let toks = tokenize(src);
        let mut map = SourceMap::default();
        // Depth of the top-level struct's contents: the first opening `(`.
        let Some(open) = toks.iter().position(|t| t.tok == Tok::Punct('(')) else {
            return map;
        };
        let mut depth = 0usize;
        let mut i = open;
        while i < toks.len() {
            match &toks[i].tok {
                Tok::Punct('(' | '[' | '{') => depth += 1,
                Tok::Punct(')' | ']' | '}') => depth = depth.saturating_sub(1),
                Tok::Ident(field) if depth == 1 && is_punct(&toks, i + 1, ':') => {
                    let value = toks.get(i + 2).map(|t| t.pos);
                    match field.as_str() {
                        "scene" => map.scene = value,
                        "width" => map.width = value,
                        "height" => map.height = value,
                        "camera" => {
                            map.camera = value;
                            map.camera_fields = camera_fields(&toks, i + 2);
                        }
                        "motion" => {
                            map.motion = value;
                            map.motion_entries = array_of_structs(&toks, i + 2);
                        }
                        "camera_path" => {
                            map.camera_path = value;
                            map.camera_path_entries = array_of_structs(&toks, i + 2);
                        }
                        "nodes" => {
                            map.nodes_key = Some(toks[i].pos);
                            if is_punct(&toks, i + 2, '[') {
                                let (nodes, end) = walk_nodes(&toks, i + 3);
                                map.nodes = nodes;
                                i = end;
                                continue;
                            }
                        }
                        _ => {}
                    }
                }
                _ => {}
            }
            i += 1;
        }
        map
    }

    /// Position of the value written for field `name` of motion entry `k`, else of the entry, else of
    /// the `motion` array.
    pub fn motion_field(&self, k: usize, name: &str) -> Option<Pos> {
        entry_field(&self.motion_entries, self.motion, k, name)
    }

    /// The same for entry `k` of `camera_path`.
    pub fn camera_path_field(&self, k: usize, name: &str) -> Option<Pos> {
        entry_field(&self.camera_path_entries, self.camera_path, k, name)
    }

    /// Position of the value written for camera field `name`, else of the camera block.
    pub fn camera_field(&self, name: &str) -> Option<Pos> {
        self.camera_fields.iter().find(|(n, _)| n == name).map(|(_, p)| *p).or(self.camera)
    }
}

/// The innermost bracket still open at the end of `toks` (for "the file ends early" messages).
pub fn unclosed_bracket(toks: &[Token]) -> Option<&Token> {
    let mut open: Vec<&Token> = Vec::new();
    for t in toks {
        match t.tok {
            Tok::Punct('(' | '[' | '{') => open.push(t),
            Tok::Punct(')' | ']' | '}') => {
                open.pop();
            }
            _ => {}
        }
    }
    open.pop()
}

/// The fields of the camera value starting at `toks[i]`: `Some((…))`, `Some(CameraSpec(…))` or
/// `(…)`; (field name, value position) in order. Empty for `None` or anything else.
fn camera_fields(toks: &[Token], mut i: usize) -> Vec<(String, Pos)> {
    let mut fields = Vec::new();
    if matches!(&toks.get(i).map(|t| &t.tok), Some(Tok::Ident(s)) if s == "Some") {
        i += 1;
        if !is_punct(toks, i, '(') {
            return fields;
        }
        i += 1;
    }
    if matches!(toks.get(i).map(|t| &t.tok), Some(Tok::Ident(_))) {
        i += 1;
    }
    if !is_punct(toks, i, '(') {
        return fields;
    }
    i += 1;
    while i < toks.len() {
        match &toks[i].tok {
            Tok::Punct(')') => break,
            Tok::Ident(field) if is_punct(toks, i + 1, ':') => {
                if let Some(v) = toks.get(i + 2) {
                    fields.push((field.clone(), v.pos));
                }
                i = skip_value(toks, i + 2);
            }
            _ => i += 1,
        }
    }
    fields
}

/// Position of field `name` of entry `k` of an array of structs, else of the entry, else of the array.
fn entry_field(entries: &[(Pos, Vec<(String, Pos)>)], array: Option<Pos>, k: usize, name: &str) -> Option<Pos> {
    match entries.get(k) {
        Some((entry, fields)) => Some(fields.iter().find(|(n, _)| n == name).map_or(*entry, |(_, p)| *p)),
        None => array,
    }
}

/// The elements of the array starting at `toks[i]` (`[ (…), (…) ]`), each a struct: its position and
/// its fields (name, value position) as [`camera_fields`] reads them.
fn array_of_structs(toks: &[Token], mut i: usize) -> Vec<(Pos, Vec<(String, Pos)>)> {
    let mut out = Vec::new();
    if !is_punct(toks, i, '[') {
        return out;
    }
    i += 1;
    while i < toks.len() {
        match &toks[i].tok {
            Tok::Punct(']') => break,
            Tok::Punct(',') => i += 1,
            _ => {
                out.push((toks[i].pos, camera_fields(toks, i)));
                i = skip_value(toks, i);
            }
        }
    }
    out
}

fn is_punct(toks: &[Token], i: usize, c: char) -> bool {
    toks.get(i).is_some_and(|t| t.tok == Tok::Punct(c))
}

/// Walk the elements of the `nodes` array starting just after its `[`; returns the node sources and
/// the index just after the closing `]`.
fn walk_nodes(toks: &[Token], mut i: usize) -> (Vec<NodeSource>, usize) {
    let mut nodes = Vec::new();
    while i < toks.len() {
        match &toks[i].tok {
            Tok::Punct(']') => return (nodes, i + 1),
            Tok::Punct(',') => i += 1,
            Tok::Ident(_) if is_punct(toks, i + 1, '(') => {
                // `NodeSpec( … )`: named struct form.
                let (node, end) = walk_node(toks, i + 2, toks[i].pos);
                nodes.push(node);
                i = end;
            }
            Tok::Punct('(') => {
                let (node, end) = walk_node(toks, i + 1, toks[i].pos);
                nodes.push(node);
                i = end;
            }
            _ => i = skip_value(toks, i),
        }
    }
    (nodes, i)
}

/// Walk one node tuple starting just after its `(`; returns the index just after its `)`.
fn walk_node(toks: &[Token], mut i: usize, tuple: Pos) -> (NodeSource, usize) {
    let mut node = NodeSource { tuple, ..NodeSource::default() };
    while i < toks.len() {
        match &toks[i].tok {
            Tok::Punct(')') => return (node, i + 1),
            Tok::Ident(field) if is_punct(toks, i + 1, ':') => {
                let v = i + 2;
                match field.as_str() {
                    "name" => node.name = toks.get(v).map(|t| t.pos),
                    "kind" => node.kind = toks.get(v).map(|t| t.pos),
                    "inputs" | "params" if is_punct(toks, v, '{') => {
                        let (entries, end) = walk_map(toks, v + 1);
                        if field == "inputs" {
                            node.inputs = entries;
                        } else {
                            node.params = entries.into_iter().map(|(k, _)| k).collect();
                        }
                        i = end;
                        continue;
                    }
                    _ => {}
                }
                i = skip_value(toks, v);
            }
            _ => i += 1,
        }
    }
    (node, i)
}

/// Walk a map starting just after its `{`: (key position, value position) per entry, and the index
/// just after the closing `}`.
fn walk_map(toks: &[Token], mut i: usize) -> (Vec<(Pos, Pos)>, usize) {
    let mut entries = Vec::new();
    while i < toks.len() {
        match &toks[i].tok {
            Tok::Punct('}') => return (entries, i + 1),
            Tok::Punct(',') => i += 1,
            _ => {
                let key = toks[i].pos;
                let after_key = skip_value(toks, i);
                if is_punct(toks, after_key, ':') {
                    let value = toks.get(after_key + 1).map_or(key, |t| t.pos);
                    entries.push((key, value));
                    i = skip_value(toks, after_key + 1);
                } else {
                    i = after_key.max(i + 1);
                }
            }
        }
    }
    (entries, i)
}

/// Skip one value (a token, or a bracketed group possibly preceded by a name such as `Some(` or
/// `Camera(`); returns the index of the next token after it.
fn skip_value(toks: &[Token], mut i: usize) -> usize {
    if i >= toks.len() {
        return i;
    }
    if matches!(toks[i].tok, Tok::Ident(_)) && is_punct(toks, i + 1, '(') {
        i += 1;
    }
    match toks[i].tok {
        Tok::Punct('(' | '[' | '{') => {
            let mut depth = 0usize;
            while i < toks.len() {
                match toks[i].tok {
                    Tok::Punct('(' | '[' | '{') => depth += 1,
                    Tok::Punct(')' | ']' | '}') => {
                        depth -= 1;
                        if depth == 0 {
                            return i + 1;
                        }
                    }
                    _ => {}
                }
                i += 1;
            }
            i
        }
        _ => i + 1,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tokens_have_positions() {
        let src = "( // c\n  a: \"x\\\"y\", /* b /* nested */ */ r#\"raw\"# -1.5e-3 )";
        let t = tokenize(src);
        assert_eq!(t[0].pos, Pos { line: 1, col: 1 });
        assert_eq!(t[1].tok, Tok::Ident("a".into()));
        assert_eq!(t[1].pos, Pos { line: 2, col: 3 });
        assert_eq!(t[3].tok, Tok::Str("x\"y".into()));
        assert_eq!(t[3].pos, Pos { line: 2, col: 6 });
        assert_eq!(t[5].tok, Tok::Str("raw".into()));
        assert_eq!(t[6].tok, Tok::Number("-1.5e-3".into()));
        assert_eq!(t[7].tok, Tok::Punct(')'));
    }

    #[test]
    fn node_positions() {
        let src = "Pipeline(scene: \"s\", width: 4, height: 2,\n nodes: [\n  (name: \"a\", kind: \"K\", params: {\"mu\": (1, 2)},\n   inputs: {\"x\": \"b.y\"}),\n  NodeSpec(kind: \"L\", name: \"b\"),\n ],\n)";
        let m = SourceMap::build(src);
        assert_eq!(m.nodes.len(), 2);
        assert_eq!(m.width, Some(Pos { line: 1, col: 29 }));
        assert_eq!(m.nodes[0].name, Some(Pos { line: 3, col: 10 }));
        assert_eq!(m.nodes[0].params, vec![Pos { line: 3, col: 35 }]);
        assert_eq!(m.nodes[0].inputs, vec![(Pos { line: 4, col: 13 }, Pos { line: 4, col: 18 })]);
        assert_eq!(m.nodes[1].kind, Some(Pos { line: 5, col: 18 }));
        assert_eq!(m.nodes[1].name, Some(Pos { line: 5, col: 29 }));
    }
}
