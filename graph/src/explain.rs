//! Parse errors in words.
//!
//! ron reports *where* it stopped and what token it expected there, which is often not what the
//! user got wrong: `width: 64.5` stops at the `.` with "Expected comma", `width: -1` with "Integer is
//! out of bounds", a missing `)` at the end with "Expected comma" at the end of the file. This module
//! looks at the tokens around ron's position (with the [`crate::source_map`] tokenizer) and, for the
//! common mistakes, says which field is wrong, what it wants and how to write it. Anything it does
//! not recognise keeps ron's own message with a general help line.

use ron::Error as E;

use crate::source_map::{tokenize, unclosed_bracket, Pos, Tok, Token};

/// A parse error as shown to the user: where, what, and the fix.
pub(crate) struct Explained {
    pub pos: Pos,
    pub message: String,
    pub help: String,
}

/// Explain ron's error `err` at `at` in `src`.
pub(crate) fn explain(src: &str, err: &E, at: Pos) -> Explained {
    let toks = tokenize(src);
    let plain = || Explained { pos: at, message: err.to_string(), help: generic_help(err) };

    // A number literal that contains ron's position: a fraction or exponent where a whole number
    // is wanted, or an integer out of range (negative, or too large).
    if let Some(k) = toks.iter().rposition(|t| t.pos <= at) {
        if let Tok::Number(text) = &toks[k].tok {
            let t = &toks[k];
            let inside = t.pos.line == at.line && at.col < t.pos.col + text.chars().count();
            let field = field_of(&toks, k).unwrap_or("this value");
            let fractional = !text.starts_with("0x")
                && !text.starts_with("0b")
                && !text.starts_with("0o")
                && text.contains(['.', 'e', 'E']);
            let int_error = matches!(
                err,
                E::ExpectedComma
                    | E::InvalidIntegerDigit { .. }
                    | E::ExpectedInteger
                    | E::TrailingCharacters
                    | E::ExpectedStructLikeEnd
            );
            if inside && fractional && int_error {
                let suggestion = text
                    .replace('_', "")
                    .parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite() && *v >= 0.0 && *v <= f64::from(u32::MAX))
                    .map(|v| format!(", e.g. `{field}: {}`", v.trunc()))
                    .unwrap_or_default();
                return Explained {
                    pos: t.pos,
                    message: format!("`{field}` must be a whole number, but `{text}` is not"),
                    help: format!("write `{field}` without a decimal point or exponent{suggestion}"),
                };
            }
            if inside && matches!(err, E::IntegerOutOfBounds) {
                let message = if text.starts_with('-') {
                    format!("`{field}` cannot be negative, but it is `{text}`")
                } else {
                    format!("`{text}` is too large for `{field}`")
                };
                return Explained {
                    pos: t.pos,
                    message,
                    help: format!(
                        "write `{field}` as a whole number from 0 to {}{}",
                        u32::MAX,
                        field_example(field).map(|e| format!(", e.g. {e}")).unwrap_or_default()
                    ),
                };
            }
        }
    }

    // The file ends while a bracket is open: name the bracket.
    // ron reports this at (or just after) the last token, whatever it expected there.
    let at_end = toks.last().is_none_or(|last| at >= last.pos);
    if at_end || matches!(err, E::Eof) {
        if let Some(open) = unclosed_bracket(&toks) {
            let Tok::Punct(c) = open.tok else {
                return plain();
            };
            let close = match c {
                '(' => ')',
                '[' => ']',
                _ => '}',
            };
            return Explained {
                pos: at,
                message: format!(
                    "the file ends before the `{c}` opened at {}:{} is closed",
                    open.pos.line, open.pos.col
                ),
                help: format!(
                    "add the missing `{close}` (every `(`, `[` and `{{` needs its closing partner; \
                     check the lines after {}:{})",
                    open.pos.line, open.pos.col
                ),
            };
        }
        return plain();
    }

    // A value of the wrong type: say what the field wants, with an example.
    let wanted = match err {
        E::ExpectedInteger => "a whole number",
        E::ExpectedFloat => "a number",
        E::ExpectedString | E::ExpectedStringEnd => "a double-quoted string",
        E::ExpectedBoolean => "`true` or `false`",
        E::ExpectedOption => "`Some(…)` or `None`",
        E::ExpectedArray => "a list `[…]`",
        E::ExpectedMap => "a map `{…}`",
        E::ExpectedStructLike => "a parenthesised group `(…)`",
        _ => return plain(),
    };
    let Some(k) = toks.iter().position(|t| t.pos >= at) else {
        return plain();
    };
    let found = &toks[k];
    let field = field_of(&toks, k);
    let what = field.map_or("this value".to_string(), |f| format!("`{f}`"));
    let example = field.and_then(field_example);
    let quoted_number = match &found.tok {
        Tok::Str(s) => s.trim().parse::<f64>().is_ok(),
        _ => false,
    };
    let help = if quoted_number && matches!(err, E::ExpectedInteger | E::ExpectedFloat) {
        format!(
            "remove the quotes: numbers are written bare{}",
            example.map(|e| format!(", e.g. {e}")).unwrap_or_default()
        )
    } else if let Some(e) = example {
        format!("write it like {e}")
    } else {
        format!("write {wanted} here")
    };
    Explained { pos: found.pos, message: format!("{what} expects {wanted}, but found `{}`", token_text(found)), help }
}

/// The field whose value contains token `k`: the nearest `name:` before it that is not inside a
/// group closed before `k` (so `width` for `width: 64.5`, `position` for `position: (0, x, 2)`).
fn field_of(toks: &[Token], k: usize) -> Option<&str> {
    let mut depth = 0usize;
    for j in (0..k.min(toks.len())).rev() {
        match &toks[j].tok {
            Tok::Punct(')' | ']' | '}') => depth += 1,
            Tok::Punct('(' | '[' | '{') => depth = depth.saturating_sub(1),
            Tok::Punct(':') if depth == 0 && j > 0 => {
                if let Tok::Ident(name) = &toks[j - 1].tok {
                    return Some(name);
                }
            }
            _ => {}
        }
    }
    None
}

/// How a field of the pipeline schema is written, for help lines.
fn field_example(field: &str) -> Option<&'static str> {
    Some(match field {
        "width" => "`width: 640`",
        "height" => "`height: 480`",
        "seed" => "`seed: 1`",
        "vfov_deg" => "`vfov_deg: 45.0`",
        "aperture_radius" => "`aperture_radius: 0.0`",
        "focus_distance" => "`focus_distance: Some(4.0)` or `focus_distance: None`",
        "position" => "`position: (0.0, 1.0, 4.0)`",
        "look_at" => "`look_at: (0.0, 0.0, 0.0)`",
        "up" => "`up: (0.0, 1.0, 0.0)`",
        "scene" => "`scene: \"builtin:grids\"`",
        "name" => "`name: \"primary\"`",
        "kind" => "`kind: \"Primary\"`",
        "camera" => "`camera: Some((position: (0, 1, 4), look_at: (0, 0, 0), vfov_deg: 45))` or `camera: None`",
        "nodes" => "`nodes: [(name: \"primary\", kind: \"Primary\"), …]`",
        "params" => "`params: {\"mu\": 2.0}`",
        "inputs" => "`inputs: {\"color\": \"shadows.radiance\"}`",
        _ => return None,
    })
}

/// The token as written, shortened to 40 characters (an unterminated string runs to the end of
/// the file, and the message must stay one readable line).
fn token_text(t: &Token) -> String {
    let full = match &t.tok {
        Tok::Str(s) => format!("{s:?}"),
        Tok::Ident(s) | Tok::Number(s) => s.clone(),
        Tok::Char => "a character literal".into(),
        Tok::Punct(c) => c.to_string(),
    };
    if full.chars().count() > 40 {
        format!("{}…", full.chars().take(40).collect::<String>())
    } else {
        full
    }
}

/// What to do about a ron error that [`explain`] has no specific words for.
fn generic_help(code: &E) -> String {
    match code {
        E::NoSuchStructField { expected, found, outer } => {
            let what = outer.as_deref().unwrap_or("this struct");
            format!("`{found}` is not a field of {what}; remove it or use one of: {}", expected.join(", "))
        }
        E::MissingStructField { field, outer } => {
            let what = outer.as_deref().unwrap_or("this struct");
            format!("add `{field}: …` to {what}")
        }
        E::DuplicateStructField { field, .. } => format!("remove one of the `{field}` fields"),
        E::ExpectedComma => "separate entries with `,`".into(),
        E::ExpectedMap | E::ExpectedMapColon | E::ExpectedMapEnd => {
            "write maps as {\"key\": value, …} (string keys, `:` between key and value)".into()
        }
        E::ExpectedString | E::ExpectedStringEnd => "write this value as a double-quoted string".into(),
        E::ExpectedArray | E::ExpectedArrayEnd => "write `nodes` as a list `[ (…), (…) ]`".into(),
        E::Eof => "the file ends early; close every open `(`, `[` and `{`".into(),
        E::InvalidValueForType { expected, .. } => format!("write {expected} here"),
        E::IntegerOutOfBounds => "use a smaller, non-negative integer".into(),
        E::TrailingCharacters => "remove everything after the closing `)` of the pipeline".into(),
        E::UnclosedBlockComment => "close the comment with `*/`".into(),
        E::ExceededRecursionLimit => {
            "the value is nested too deeply; a pipeline needs only a few levels of brackets".into()
        }
        _ => {
            "see the pipeline format in the wedge documentation (docs/GUIDE.md, \"A pipeline\") and fix the syntax here"
                .into()
        }
    }
}
