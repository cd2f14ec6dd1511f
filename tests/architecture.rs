//! The architecture's one rule, checked: imports between the files of `src/` run one way
//! (no file reaches, through `crate::`, `super::` or `self::` paths, a file that reaches it
//! back), and no source file grows far past the ~800 lines that ask for a split by job.
//! And its document, checked: `docs/architecture.md` names every file of `src/` and no file
//! that does not exist.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Module path (e.g. ["gpu", "fragment", "frame"]) of every `.rs` file under `src/`.
fn modules(root: &Path) -> BTreeMap<Vec<String>, PathBuf> {
    fn walk(dir: &Path, root: &Path, out: &mut BTreeMap<Vec<String>, PathBuf>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                walk(&p, root, out);
            } else if p.extension().is_some_and(|x| x == "rs") {
                let rel = p.strip_prefix(root).unwrap().with_extension("");
                let mut m: Vec<String> = rel
                    .components()
                    .map(|c| c.as_os_str().to_string_lossy().into_owned())
                    .collect();
                if matches!(m.last().map(String::as_str), Some("mod" | "lib" | "main")) {
                    m.pop();
                }
                out.insert(m, p);
            }
        }
    }
    let mut out = BTreeMap::new();
    walk(root, root, &mut out);
    out
}

/// The code of a file before its tests, without `//` comments.
fn code(path: &Path) -> String {
    let text = std::fs::read_to_string(path).unwrap();
    let text = match text.find("#[cfg(test)]") {
        Some(k) => &text[..k],
        None => &text[..],
    };
    text.lines()
        .map(|l| match l.find("//") {
            Some(k) => &l[..k],
            None => l,
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// Every `crate::`/`super::`/`self::` path in `src`, expanded through `{...}` groups, as
/// module segments from the crate root.
fn paths(src: &str, module: &[String]) -> Vec<Vec<String>> {
    let ident = |c: char| c.is_ascii_alphanumeric() || c == '_';
    let mut out = Vec::new();
    let bytes: Vec<char> = src.chars().collect();
    let mut i = 0;
    while i < bytes.len() {
        let rest: String = bytes[i..bytes.len().min(i + 7)].iter().collect();
        let kw = ["crate::", "super::", "self::"]
            .into_iter()
            .find(|k| rest.starts_with(k) && (i == 0 || !ident(bytes[i - 1])));
        let Some(kw) = kw else {
            i += 1;
            continue;
        };
        let mut base: Vec<String> = match kw {
            "crate::" => vec![],
            "self::" => module.to_vec(),
            // The parent of the module, whether the file is `x.rs` or `x/mod.rs`.
            _ => module[..module.len().saturating_sub(1)].to_vec(),
        };
        i += kw.len();
        // Further `super::` steps.
        while bytes[i..].iter().collect::<String>().starts_with("super::") {
            base.pop();
            i += 7;
        }
        let mut segs = base;
        loop {
            let start = i;
            while i < bytes.len() && ident(bytes[i]) {
                i += 1;
            }
            if i > start {
                segs.push(bytes[start..i].iter().collect());
            }
            if bytes[i..].iter().take(2).collect::<String>() == "::" {
                i += 2;
                if i < bytes.len() && bytes[i] == '{' {
                    let end = i + bytes[i..].iter().position(|&c| c == '}').unwrap_or(0);
                    let inner: String = bytes[i + 1..end].iter().collect();
                    for item in inner.split(',') {
                        let item = item.trim().split(" as ").next().unwrap_or("").trim();
                        let mut p = segs.clone();
                        if !item.is_empty() && item != "self" {
                            p.extend(item.split("::").map(str::to_string));
                        }
                        out.push(p);
                    }
                    i = end + 1;
                    break;
                }
                continue;
            }
            out.push(segs);
            break;
        }
    }
    out
}

#[test]
fn no_import_cycles_between_files_of_src() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let files = modules(&root);
    let resolve = |parts: &[String]| -> Option<Vec<String>> {
        (1..=parts.len())
            .rev()
            .map(|k| parts[..k].to_vec())
            .find(|p| files.contains_key(p))
    };
    let mut edges: BTreeMap<Vec<String>, BTreeSet<Vec<String>>> = BTreeMap::new();
    for (m, path) in &files {
        let e = edges.entry(m.clone()).or_default();
        let text = code(path);
        // As ../shared/tools/import-cycles.py counts them: paths through `crate::`,
        // `super::` and `self::` (a module file's `use child::item` re-exports are not
        // edges: a parent re-exporting its children is how a module shows its API).
        let found = paths(&text, m);
        for p in found {
            if let Some(t) = resolve(&p) {
                // A bare path to a parent module's file names the module, not its items.
                let parent_only = t.len() < m.len() && m[..t.len()] == t[..] && p.len() == t.len();
                if &t != m && !parent_only {
                    e.insert(t);
                }
            }
        }
    }
    // Tarjan's strongly connected components.
    struct T<'a> {
        edges: &'a BTreeMap<Vec<String>, BTreeSet<Vec<String>>>,
        index: BTreeMap<&'a Vec<String>, usize>,
        low: BTreeMap<&'a Vec<String>, usize>,
        stack: Vec<&'a Vec<String>>,
        on: BTreeSet<&'a Vec<String>>,
        out: Vec<Vec<&'a Vec<String>>>,
    }
    fn visit<'a>(t: &mut T<'a>, v: &'a Vec<String>) {
        let n = t.index.len();
        t.index.insert(v, n);
        t.low.insert(v, n);
        t.stack.push(v);
        t.on.insert(v);
        for w in &t.edges[v] {
            if !t.index.contains_key(w) {
                visit(t, w);
                let lw = t.low[w];
                let lv = t.low.get_mut(v).unwrap();
                *lv = (*lv).min(lw);
            } else if t.on.contains(w) {
                let iw = t.index[w];
                let lv = t.low.get_mut(v).unwrap();
                *lv = (*lv).min(iw);
            }
        }
        if t.low[v] == t.index[v] {
            let mut scc = Vec::new();
            while let Some(w) = t.stack.pop() {
                t.on.remove(w);
                scc.push(w);
                if w == v {
                    break;
                }
            }
            if scc.len() > 1 {
                t.out.push(scc);
            }
        }
    }
    let mut t = T {
        edges: &edges,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on: BTreeSet::new(),
        out: Vec::new(),
    };
    for v in edges.keys() {
        if !t.index.contains_key(v) {
            visit(&mut t, v);
        }
    }
    let cycles: Vec<String> = t
        .out
        .iter()
        .map(|c| {
            let mut names: Vec<String> = c.iter().map(|m| m.join("/")).collect();
            names.sort();
            names.join(" <-> ")
        })
        .collect();
    assert!(
        cycles.is_empty(),
        "import cycles between files of src/ (imports must run one way, docs/architecture.md):\n{}",
        cycles.join("\n")
    );
    assert!(files.len() > 50, "found only {} files", files.len());
}

/// Measured here: the longest file before its tests is src/scene/toml_scene/build.rs at 871
/// lines (the former single-file CLI, 865, was split into src/cli/ at stop 34); the
/// bound leaves room to finish a change and say "split me" before it becomes a habit.
#[test]
fn no_source_file_far_past_800_lines() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let long: Vec<String> = modules(&root)
        .values()
        .filter_map(|p| {
            let n = code(p).lines().count();
            (n > 900).then(|| format!("{}: {n} lines before its tests", p.display()))
        })
        .collect();
    assert!(long.is_empty(), "split by job:\n{}", long.join("\n"));
}

/// The repository's root.
fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Every file path the text names: a run of path characters ending in one of the project's
/// file extensions (`src/gpu/render.rs`, `glsl120/step.glsl`, `ci/test.sh`, `docs/web.md`,
/// `view/control.rs`, `Cargo.toml`). A path after a commit and a colon
/// (`git show 5d36e05:src/accel/two_level.rs`) names a file in history and is left out, as
/// are URLs and absolute paths.
fn named_files(text: &str) -> Vec<String> {
    const EXT: [&str; 10] = [
        ".rs", ".md", ".sh", ".glsl", ".frag", ".comp", ".toml", ".py", ".html", ".obj",
    ];
    let path_char = |c: char| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.' | '/');
    let mut out = Vec::new();
    let chars: Vec<char> = text.chars().collect();
    let mut i = 0;
    while i < chars.len() {
        if !path_char(chars[i]) {
            i += 1;
            continue;
        }
        let start = i;
        while i < chars.len() && path_char(chars[i]) {
            i += 1;
        }
        let word: String = chars[start..i].iter().collect();
        let word = word.trim_end_matches('.');
        let before = start.checked_sub(1).map(|k| chars[k]);
        let after = chars.get(i).copied();
        let in_history = before == Some(':');
        let glob = matches!(after, Some('*' | '{')) || matches!(before, Some('}' | '*'));
        if in_history || glob || word.starts_with('/') || word.starts_with('.') {
            continue;
        }
        if EXT
            .iter()
            .any(|e| word.ends_with(e) && word.len() > e.len())
        {
            out.push(word.to_string());
        }
    }
    out
}

/// Whether a path the document names exists: from the repository's root (`src/...`,
/// `glsl120/...`, `ci/...`, `docs/...`, `tests/...`), from `src/` (`gpu/render.rs`, as the
/// document names modules inside their layer), from `docs/` (links), or, for a bare file
/// name (`step.glsl`, `frame.rs`), anywhere in the tracked tree.
fn exists(named: &str, all_files: &BTreeSet<String>) -> bool {
    let root = repo();
    if !named.contains('/') {
        return all_files
            .iter()
            .any(|f| f.rsplit('/').next() == Some(named));
    }
    [
        root.join(named),
        root.join("src").join(named),
        root.join("docs").join(named),
    ]
    .iter()
    .any(|p| p.exists())
}

/// Every file under the repository's root, as a path relative to it (build output and
/// version control left out).
fn tree_files() -> BTreeSet<String> {
    fn walk(dir: &Path, root: &Path, out: &mut BTreeSet<String>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            if p.is_dir() {
                if name != "target" && !name.starts_with('.') {
                    walk(&p, root, out);
                }
            } else {
                let rel = p.strip_prefix(root).unwrap();
                out.insert(rel.to_string_lossy().replace('\\', "/"));
            }
        }
    }
    let mut out = BTreeSet::new();
    walk(&repo(), &repo(), &mut out);
    out
}

/// The files of `src/` that a document leaves out: each must appear by its path from the
/// repository's root (`src/gpu/fragment/frame.rs`), as the module list names them.
fn modules_missing_from(doc: &str) -> Vec<String> {
    modules(&repo().join("src"))
        .values()
        .map(|p| {
            let rel = p.strip_prefix(repo()).unwrap();
            rel.to_string_lossy().replace('\\', "/")
        })
        .filter(|f| !doc.contains(&format!("`{f}`")))
        .collect()
}

#[test]
fn architecture_document_names_every_module_of_src() {
    let doc = std::fs::read_to_string(repo().join("docs/architecture.md")).unwrap();
    let missing = modules_missing_from(&doc);
    assert!(
        missing.is_empty(),
        "docs/architecture.md leaves out these files of src/; give each a line in its module \
         list (\"- `src/...rs`: what it holds\"):\n{}",
        missing.join("\n")
    );
}

#[test]
fn architecture_document_names_no_missing_file() {
    let doc = std::fs::read_to_string(repo().join("docs/architecture.md")).unwrap();
    let all = tree_files();
    let dead: Vec<String> = named_files(&doc)
        .into_iter()
        .filter(|f| !exists(f, &all))
        .collect();
    assert!(
        dead.is_empty(),
        "docs/architecture.md names files that do not exist:\n{}",
        dead.join("\n")
    );
}

/// The two checks themselves: a document that leaves out a module, or names a file that is
/// not there, is caught; history paths, globs and URLs are not files to check.
#[test]
fn architecture_checks_catch_a_missing_module_and_a_dead_path() {
    let doc = std::fs::read_to_string(repo().join("docs/architecture.md")).unwrap();
    let without = doc.replace("`src/animate.rs`", "animate");
    assert!(modules_missing_from(&without).contains(&"src/animate.rs".to_string()));

    let all = tree_files();
    let names = named_files(
        "`src/cli.rs` and `gpu/contract.rs`, `glsl120/render.comp`, `ci/h200/run9.sh`, \
         `docs/bench/x.md`, `tests/architecture.rs`; `git show 5d36e05:src/accel/two_level.rs`; \
         `docs/mutants/{a,b}-before-*.txt`, https://example.org/x.md, `step.glsl`, `nothing.frag`.",
    );
    let dead: Vec<&str> = names
        .iter()
        .map(String::as_str)
        .filter(|f| !exists(f, &all))
        .collect();
    assert_eq!(
        dead,
        [
            "src/cli.rs",
            "gpu/contract.rs",
            "ci/h200/run9.sh",
            "docs/bench/x.md",
            "nothing.frag"
        ]
    );
    assert!(names.contains(&"glsl120/render.comp".to_string()));
    assert!(!names
        .iter()
        .any(|n| n.contains("two_level") || n.contains("example.org")));
}
