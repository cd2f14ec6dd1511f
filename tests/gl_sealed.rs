//! GL is sealed in `src/gpu/gl/`: no other file of `src/`, of the tests or of the web
//! page's crate (`web/src`) makes a GL call, and `GlContext::gl()` is crate-private, so
//! code outside the crate cannot reach the raw context at all. Every GL call
//! goes through glow's `HasContext` trait (or, for the few entry points glow gets wrong on
//! GL 2.1 drivers, through pointers loaded in `gpu/gl/probe.rs`), so a file outside
//! `gpu/gl` that names the trait, globs glow in, or opens an `unsafe` block that reaches a
//! GL context is a raw GL call outside the seal. The rest of the crate draws, binds, reads
//! and waits through the safe functions and owning types of `gpu::gl`, where each unsafe
//! call states the invariant it relies on. The crate denies
//! `clippy::undocumented_unsafe_blocks`, so that every unsafe block, GL or not, says why it
//! is sound.

use std::path::Path;

/// The code of a file without `//` comments (test modules included: a test's GL call is a
/// GL call too).
fn code(text: &str) -> String {
    text.lines()
        .map(|l| match l.find("//") {
            Some(k) => &l[..k],
            None => l,
        })
        .collect::<Vec<_>>()
        .join("\n")
}

fn ident(c: u8) -> bool {
    c.is_ascii_alphanumeric() || c == b'_'
}

/// Whether `body` reaches a GL context: glow named, a `gl` binding used (`gl.`), or a
/// `GlContext`'s context taken (`.gl()`).
fn mentions_gl(body: &str) -> bool {
    let b = body.as_bytes();
    body.contains("glow::")
        || body.contains(".gl()")
        || body
            .match_indices("gl.")
            .any(|(k, _)| k == 0 || !ident(b[k - 1]))
}

/// The ways `text` (one file's code) calls GL, as `line: what` entries.
fn violations(text: &str) -> Vec<String> {
    let code = code(text);
    let line_of = |k: usize| code[..k].matches('\n').count() + 1;
    let mut out = Vec::new();
    for (k, _) in code.match_indices("HasContext") {
        out.push(format!("{}: names glow::HasContext", line_of(k)));
    }
    for glob in ["glow::*", "glow::{*"] {
        for (k, _) in code.match_indices(glob) {
            out.push(format!("{}: globs glow in", line_of(k)));
        }
    }
    let b = code.as_bytes();
    for (k, _) in code.match_indices("unsafe") {
        let at_word = (k == 0 || !ident(b[k - 1])) && !b.get(k + 6).copied().is_some_and(ident);
        let Some(open) = code[k + 6..]
            .find(|c: char| !c.is_whitespace())
            .map(|o| k + 6 + o)
        else {
            continue;
        };
        if !at_word || b[open] != b'{' {
            continue;
        }
        // The block's body, braces matched.
        let mut depth = 0usize;
        let mut end = open;
        for (i, &c) in b.iter().enumerate().skip(open) {
            match c {
                b'{' => depth += 1,
                b'}' => {
                    depth -= 1;
                    if depth == 0 {
                        end = i;
                        break;
                    }
                }
                _ => {}
            }
        }
        if mentions_gl(&code[open..=end]) {
            out.push(format!("{}: an unsafe block calls GL", line_of(k)));
        }
    }
    out
}

/// Every `.rs` file under `dir`, as paths relative to `root` with `/` separators.
fn rust_files(dir: &Path, root: &Path, out: &mut Vec<String>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            rust_files(&p, root, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            let rel = p.strip_prefix(root).unwrap();
            let parts: Vec<_> = rel
                .components()
                .map(|c| c.as_os_str().to_string_lossy())
                .collect();
            out.push(parts.join("/"));
        }
    }
}

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// The GL uses the scan finds in every `.rs` file under `dir` (relative to the crate
/// root), as `path:line: what`, and how many files it read.
fn scan(dir: &str, skip: &[&str]) -> (Vec<String>, usize) {
    let base = root().join(dir);
    let mut files = Vec::new();
    rust_files(&base, &base, &mut files);
    files.retain(|f| !skip.contains(&f.as_str()));
    let mut found = Vec::new();
    for f in &files {
        let text = std::fs::read_to_string(base.join(f)).unwrap();
        found.extend(
            violations(&text)
                .into_iter()
                .map(|v| format!("{dir}/{f}:{v}")),
        );
    }
    (found, files.len())
}

#[test]
fn no_gl_call_outside_gpu_gl() {
    let (in_src, _) = scan("src", &[]);
    let (sealed, outside): (Vec<_>, Vec<_>) = in_src
        .into_iter()
        .partition(|v| v.starts_with("src/gpu/gl/"));
    // The scan sees GL where it is meant to be: gpu/gl is full of it.
    assert!(
        sealed.len() > 20,
        "the scan found only {} GL uses in src/gpu/gl",
        sealed.len()
    );
    // This file's own examples of raw calls are strings, not calls.
    let (in_tests, n_tests) = scan("tests", &["gl_sealed.rs"]);
    let (in_web, n_web) = scan("web/src", &[]);
    assert!(
        n_tests > 20 && n_web >= 3,
        "{n_tests} test files, {n_web} web files"
    );
    let found: Vec<String> = outside.into_iter().chain(in_tests).chain(in_web).collect();
    assert!(
        found.is_empty(),
        "GL calls outside src/gpu/gl (add a safe function to gpu::gl and call that):\n{}",
        found.join("\n")
    );
}

/// `GlContext::gl()`, the raw context, is not public: outside the crate, GL is reached
/// only through `gpu::gl`'s safe functions.
#[test]
fn the_raw_context_is_crate_private() {
    let text = std::fs::read_to_string(root().join("src/gpu/context.rs")).unwrap();
    let code = code(&text);
    assert!(
        code.contains("pub(crate) fn gl(&self) -> &glow::Context"),
        "GlContext::gl() must stay crate-private"
    );
    assert!(
        !code.contains("pub fn gl(&self)"),
        "GlContext::gl() is public again"
    );
}

/// The scanner itself: it flags what the tree had before GL was sealed, and passes the
/// sealed forms.
#[test]
fn the_scan_flags_raw_gl_calls() {
    let before = "use glow::HasContext;\n\
                  fn f(frame: &Frame) {\n\
                  \x20   // SAFETY: the context is current.\n\
                  \x20   unsafe { frame.gl().finish() };\n\
                  \x20   let gl = frame.gl();\n\
                  \x20   unsafe {\n\
                  \x20       gl.color_mask(false, false, false, false);\n\
                  \x20   }\n\
                  \x20   unsafe { gl.dispatch_compute(1, 1, 1) }\n\
                  }\n";
    let v = violations(before);
    assert_eq!(v.len(), 4, "{v:?}");
    assert!(v[0].starts_with("1: names"), "{v:?}");
    assert!(
        v.iter().any(|s| s.starts_with("4: an unsafe block")),
        "{v:?}"
    );
    assert!(
        v.iter().any(|s| s.starts_with("6: an unsafe block")),
        "{v:?}"
    );
    assert_eq!(violations("use glow::*;\n").len(), 1);
    let after = "use crate::gpu::gl::state;\n\
                 fn f(frame: &Frame) {\n\
                 \x20   state::finish(frame.gl());\n\
                 \x20   state::colour_writes(frame.gl(), false);\n\
                 \x20   // unsafe { gl.finish() } in a comment is no call\n\
                 \x20   let p = unsafe { egl.get_display(x) };\n\
                 \x20   let q = unsafe_thing { gl: 1 };\n\
                 }\n";
    assert_eq!(violations(after), Vec::<String>::new());
}

/// The crate (and the web page's crate) deny unsafe blocks without a `// SAFETY:` comment,
/// which clippy enforces in CI.
#[test]
fn unsafe_blocks_must_say_why() {
    let lint = "#![deny(clippy::undocumented_unsafe_blocks)]";
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    for lib in ["src/lib.rs", "web/src/lib.rs"] {
        let text = std::fs::read_to_string(root.join(lib)).unwrap();
        assert!(
            code(&text).contains(lint),
            "{lib} must keep `{lint}` (issue 51)"
        );
    }
}
