//! Where scene errors come from and how they read: byte spans turned into lines, the dotted
//! field of a toml error, range checks of values, and "did you mean" for misspelt names.

use std::collections::HashMap;
use std::ops::Range;

use glam::Vec3;
use serde_path_to_error::Segment;

use super::schema::{Triple, S};
use crate::Error;
use crate::Result;

/// The file being loaded, for turning byte spans into line numbers.
#[derive(Clone, Copy)]
pub(super) struct Ctx<'a> {
    /// The file name as messages show it.
    pub(super) name: &'a str,
    /// The whole document, for turning byte offsets into lines.
    pub(super) text: &'a str,
}

impl Ctx<'_> {
    pub(super) fn line_of(&self, offset: usize) -> usize {
        let end = offset.min(self.text.len());
        self.text.as_bytes()[..end]
            .iter()
            .filter(|&&b| b == b'\n')
            .count()
            + 1
    }

    pub(super) fn err(
        &self,
        span: Range<usize>,
        field: impl Into<String>,
        message: impl Into<String>,
    ) -> Error {
        Error::scene(self.name, self.line_of(span.start), field, message)
    }

    /// A parse/type error from toml, with the line from its span, the field from serde's
    /// path to it, and a "did you mean" hint for unknown keys and values.
    ///
    /// Errors the TOML parser raises before serde sees a single key (malformed syntax, a
    /// duplicate key) come with an empty path, and so do errors about the document root (a
    /// missing `camera`); only for those is the field found by re-lexing the text around
    /// the error's span ([`field_at`]).
    pub(super) fn toml_error(&self, e: &serde_path_to_error::Error<toml::de::Error>) -> Error {
        let inner = e.inner();
        let span = inner.span();
        let line = span.as_ref().map_or(0, |s| self.line_of(s.start));
        let path = path_field(e.path());
        // A required top-level table that is absent has no line of its own; toml points at
        // the whole document, whose first key would be blamed. Name the missing table.
        if path.is_none() {
            if let Some(name) = inner
                .message()
                .strip_prefix("missing field `")
                .and_then(|r| r.split_once('`'))
                .map(|(n, _)| n)
            {
                return Error::scene(
                    self.name,
                    1,
                    name,
                    format!(
                        "the scene has no `[{name}]` table, which is required{}",
                        if name == "camera" {
                            " (e.g. `[camera]` with `eye`, `look_at` and `fov`)"
                        } else {
                            ""
                        }
                    ),
                );
            }
        }
        let field = match (path, &span) {
            (Some(f), _) => f,
            (None, Some(s)) => field_at(self.text, s.start),
            (None, None) => String::new(),
        };
        // Garbage before any key leaves no field to name: show the text the parser stopped
        // at instead of an empty field.
        let field = if field.is_empty() {
            at_text(self.text, span.as_ref().map_or(0, |s| s.start))
        } else {
            field
        };
        // `fov =` with nothing after it: toml says "invalid string: expected `"`, `'`".
        if let Some(key) = span.and_then(|s| key_without_value(self.text, s.start)) {
            return Error::scene(
                self.name,
                line,
                field,
                format!("`{key} =` has no value after it (e.g. `{key} = 40`, `{key} = [0, 1, 0]`)"),
            );
        }
        Error::scene(self.name, line, field, improve_message(inner.message()))
    }

    pub(super) fn finite(&self, v: &S<f64>, field: &str) -> Result<f32> {
        let x = *v.get_ref();
        let y = x as f32;
        if !y.is_finite() {
            return Err(self.err(v.span(), field, format!("must be a finite number, got {x}")));
        }
        Ok(y)
    }

    /// A finite scalar satisfying `ok`, else an error saying `expect`.
    pub(super) fn scalar(
        &self,
        v: &S<f64>,
        field: &str,
        ok: impl Fn(f64) -> bool,
        expect: &str,
    ) -> Result<f32> {
        let y = self.finite(v, field)?;
        if !ok(*v.get_ref()) {
            return Err(self.err(v.span(), field, format!("{expect}, got {}", v.get_ref())));
        }
        Ok(y)
    }

    pub(super) fn vec3(&self, v: &S<Triple>, field: &str) -> Result<Vec3> {
        let a = v.get_ref();
        let f = Vec3::new(a[0] as f32, a[1] as f32, a[2] as f32);
        if !f.is_finite() {
            return Err(self.err(v.span(), field, format!("must be finite, got {a:?}")));
        }
        Ok(f)
    }

    pub(super) fn color(&self, v: &S<Triple>, field: &str) -> Result<Vec3> {
        let c = self.vec3(v, field)?;
        if c.min_element() < 0.0 {
            return Err(self.err(
                v.span(),
                field,
                format!("colour components must be >= 0, got {:?}", v.get_ref()),
            ));
        }
        Ok(c)
    }

    pub(super) fn opt_color(
        &self,
        v: &Option<S<Triple>>,
        field: &str,
        default: Vec3,
    ) -> Result<Vec3> {
        v.as_ref().map_or(Ok(default), |v| self.color(v, field))
    }

    pub(super) fn integer(
        &self,
        v: &S<i64>,
        field: &str,
        range: std::ops::RangeInclusive<i64>,
        why: &str,
    ) -> Result<u32> {
        let x = *v.get_ref();
        if !range.contains(&x) {
            return Err(self.err(
                v.span(),
                field,
                format!("{x} is outside {}..={}{why}", range.start(), range.end()),
            ));
        }
        Ok(x as u32)
    }
}

/// `at `TEXT`` for the (escaped, shortened) text from byte `offset` to the end of its line,
/// or `at end of file`: where the parser stopped, when no field can be named.
pub(super) fn at_text(text: &str, offset: usize) -> String {
    let start = (0..=offset.min(text.len()))
        .rev()
        .find(|&i| text.is_char_boundary(i))
        .unwrap_or(0);
    let rest = text[start..].lines().next().unwrap_or("").trim_end();
    if rest.is_empty() {
        return "at end of file".into();
    }
    let mut shown: String = rest
        .chars()
        .take(24)
        .collect::<String>()
        .escape_debug()
        .to_string();
    if rest.chars().count() > 24 {
        shown.push_str("...");
    }
    format!("at `{shown}`")
}

/// The dotted field (`objects[2].material.ior`, `objects[0].size[1]`) of a serde path, or
/// `None` when the path is empty or has a segment serde could not name.
fn path_field(path: &serde_path_to_error::Path) -> Option<String> {
    // toml::Spanned deserializes through a private map whose keys all start with this; they
    // are serde plumbing, not keys of the file.
    const SPANNED_KEY: &str = "$__serde_spanned_private_";
    let mut out = String::new();
    for segment in path {
        match segment {
            Segment::Seq { index } => out.push_str(&format!("[{index}]")),
            Segment::Map { key } if key.starts_with(SPANNED_KEY) => {}
            Segment::Map { key } | Segment::Enum { variant: key } => {
                if !out.is_empty() {
                    out.push('.');
                }
                // A key that is not bare TOML (`"my mat"`) is written quoted, as in the file,
                // so that the field is one line and unambiguous.
                let bare = !key.is_empty()
                    && key
                        .chars()
                        .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
                if bare {
                    out.push_str(key);
                } else {
                    out.push_str(&format!("{key:?}"));
                }
            }
            Segment::Unknown => return None,
        }
    }
    (!out.is_empty()).then_some(out)
}

/// Rewrites serde's "unknown field/variant" messages into "unknown key ...; did you mean".
/// The key of the line holding `offset` when that line is `key =` with no value after
/// it (only blanks or a comment).
fn key_without_value(text: &str, offset: usize) -> Option<&str> {
    let offset = offset.min(text.len());
    let start = text[..offset].rfind('\n').map_or(0, |i| i + 1);
    let end = text[start..].find('\n').map_or(text.len(), |i| start + i);
    let (key, rest) = text[start..end].split_once('=')?;
    let rest = rest.trim_start();
    let key = key.trim();
    (!key.is_empty() && (rest.is_empty() || rest.starts_with('#'))).then_some(key)
}

fn improve_message(msg: &str) -> String {
    // toml's messages can span lines ("invalid array\nexpected `]`"); errors are one line.
    let joined = msg
        .trim()
        .lines()
        .map(str::trim)
        .collect::<Vec<_>>()
        .join(": ");
    let msg = joined.as_str();
    for (prefix, what) in [("unknown field `", "key"), ("unknown variant `", "value")] {
        let Some(rest) = msg.strip_prefix(prefix) else {
            continue;
        };
        let Some((bad, tail)) = rest.split_once('`') else {
            continue;
        };
        let known: Vec<&str> = tail.split('`').skip(1).step_by(2).collect();
        let hint = closest(bad, &known)
            .map(|k| format!("; did you mean `{k}`?"))
            .unwrap_or_default();
        let list = if known.is_empty() {
            " (no keys are allowed here)".to_owned()
        } else {
            format!(
                " (expected one of {})",
                known
                    .iter()
                    .map(|k| format!("`{k}`"))
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        };
        return format!("unknown {what} `{bad}`{hint}{list}");
    }
    msg.to_owned()
}

/// The candidate nearest to `word` by edit distance (with transpositions), if it is near
/// enough to be a plausible typo.
pub(super) fn closest<'a>(word: &str, candidates: &[&'a str]) -> Option<&'a str> {
    let limit = (word.chars().count() / 3).max(1);
    candidates
        .iter()
        .map(|c| (edit_distance(&word.to_lowercase(), &c.to_lowercase()), *c))
        .filter(|&(d, _)| d <= limit)
        .min_by_key(|&(d, _)| d)
        .map(|(_, c)| c)
}

/// Optimal-string-alignment distance: Levenshtein plus adjacent transpositions, so that
/// `fvo` is one edit from `fov` (plain Levenshtein would count two).
pub(super) fn edit_distance(a: &str, b: &str) -> usize {
    strsim::osa_distance(a, b)
}

/// The dotted field path (`objects[2].material.ior`) at byte `offset` of a TOML document.
///
/// For the errors that have no serde path (see [`Ctx::toml_error`]): toml's syntax errors
/// carry a span but no key path, and serde_path_to_error cannot help because they happen
/// while parsing, before any key is deserialized. So this re-lexes the document up to the
/// offset: table headers (counting `[[array]]` entries), keys, inline tables and strings.
/// It only has to be right for the documents the scene schema accepts.
pub(super) fn field_at(text: &str, offset: usize) -> String {
    let bytes = text.as_bytes();
    let offset = offset.min(bytes.len());
    let mut header = String::new();
    let mut aot_count: HashMap<String, usize> = HashMap::new();
    // Keys of the enclosing inline tables, and the key whose value is being read.
    let mut stack: Vec<String> = Vec::new();
    let mut key: Option<String> = None;
    let mut brackets = 0usize;
    let mut expect_key = true;
    let mut line_start = true;
    let is_key_char = |c: u8| c.is_ascii_alphanumeric() || c == b'_' || c == b'-' || c == b'.';
    let mut i = 0;
    let read_key = |i: usize| -> (String, usize) {
        let mut j = i;
        while j < bytes.len() && (is_key_char(bytes[j]) || bytes[j] == b'"') {
            j += 1;
        }
        (text[i..j].replace('"', ""), j)
    };
    let parse_header =
        |i: usize, aot_count: &mut HashMap<String, usize>, count: bool| -> (String, usize) {
            let double = bytes.get(i + 1) == Some(&b'[');
            let start = if double { i + 2 } else { i + 1 };
            let end = text[start..].find(']').map_or(bytes.len(), |e| start + e);
            let name: String = text[start..end].trim().replace(['"', ' '], "");
            let next = text[end..].find('\n').map_or(bytes.len(), |e| end + e);
            if double {
                let n = aot_count.entry(name.clone()).or_insert(0);
                if count {
                    *n += 1;
                }
                (format!("{name}[{}]", n.saturating_sub(1)), next)
            } else {
                (name, next)
            }
        };
    let join = |header: &str, stack: &[String], last: Option<&str>| -> String {
        let mut parts: Vec<&str> = Vec::new();
        if !header.is_empty() {
            parts.push(header);
        }
        parts.extend(stack.iter().map(String::as_str));
        parts.extend(last);
        parts.join(".")
    };
    while i < bytes.len() {
        let c = bytes[i];
        if i >= offset {
            if line_start && brackets == 0 && stack.is_empty() && c == b'[' {
                return parse_header(i, &mut aot_count, true).0;
            }
            if expect_key && is_key_char(c) {
                return join(&header, &stack, Some(&read_key(i).0));
            }
            return join(&header, &stack, key.as_deref());
        }
        match c {
            b'\n' => {
                if brackets == 0 && stack.is_empty() {
                    expect_key = true;
                    key = None;
                }
                line_start = true;
                i += 1;
                continue;
            }
            b' ' | b'\t' | b'\r' => {
                i += 1;
                continue;
            }
            b'#' => {
                i = text[i..].find('\n').map_or(bytes.len(), |e| i + e);
                continue;
            }
            b'"' | b'\'' if !expect_key => {
                // Skip a string value, honouring escapes in basic strings.
                let mut j = i + 1;
                while j < bytes.len() && bytes[j] != c && bytes[j] != b'\n' {
                    j += if c == b'"' && bytes[j] == b'\\' { 2 } else { 1 };
                }
                i = j + 1;
            }
            b'[' if line_start && brackets == 0 && stack.is_empty() => {
                let (h, next) = parse_header(i, &mut aot_count, true);
                header = h;
                key = None;
                i = next;
                line_start = false;
                continue;
            }
            b'[' => {
                brackets += 1;
                i += 1;
            }
            b']' => {
                brackets = brackets.saturating_sub(1);
                i += 1;
            }
            b'{' => {
                stack.extend(key.take());
                expect_key = true;
                i += 1;
            }
            b'}' => {
                key = stack.pop();
                expect_key = false;
                i += 1;
            }
            b',' if !stack.is_empty() && brackets == 0 => {
                expect_key = true;
                i += 1;
            }
            b'=' => {
                expect_key = false;
                i += 1;
            }
            _ if expect_key && (is_key_char(c) || c == b'"') => {
                let (k, next) = read_key(i);
                key = Some(k);
                i = next;
            }
            _ => i += 1,
        }
        line_start = false;
    }
    join(&header, &stack, key.as_deref())
}
