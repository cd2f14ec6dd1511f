//! The architecture's one rule, checked: imports between the files of `src/` run one way
//! (no file reaches, through `crate::`, `super::` or `self::` paths, a file that reaches it
//! back), and no source file grows far past the ~800 lines that ask for a split by job.

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
/// lines (src/cli.rs, 865, was split into src/cli/ at stop 34); the
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
