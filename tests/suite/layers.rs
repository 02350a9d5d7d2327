//! The layers of `docs/design.md` (its `### Layers` list) hold in `src/` (issue 42): no import
//! runs from a module to one on its own line or a later one, and no files import each other in
//! a circle. Every path that starts with `crate::`, `super::`, `self::` or, in the binary,
//! `sweep::` is read (`use` lines and code, not comments or strings) and resolved to the deepest
//! module that has a file. std only: a small tokenizer instead of a parser.

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::fs;
use std::path::Path;

/// Tolerated violations (an upward import `file -> module`, or a circle of files): none are
/// left. A violation not listed fails the test, and so does an entry that no longer occurs.
const KNOWN: &[&str] = &[];

/// First segments that name a module of sweep (`sweep` only from the binary's files).
const HEADS: [&str; 4] = ["crate", "super", "self", "sweep"];

/// A token and its line.
type Token = (usize, String);

fn is_ident(c: char) -> bool {
    c.is_alphanumeric() || c == '_'
}

/// The char at `i`, or NUL past the end: look-aheads without bounds checks.
fn at(s: &[char], i: usize) -> char {
    s.get(i).copied().unwrap_or('\0')
}

fn find(s: &[char], from: usize, pat: &[char]) -> Option<usize> {
    (from..s.len()).find(|&k| s[k..].starts_with(pat))
}

/// Where a comment, string or char literal starting at `i` ends (`i` if none starts there):
/// a `crate::` in a doc comment is no import, and a `'{'` must not count as a brace.
fn literal_end(s: &[char], i: usize) -> usize {
    let n = s.len();
    match (s[i], at(s, i + 1)) {
        ('/', '/') => find(s, i, &['\n']).unwrap_or(n),
        // (Rust's block comments nest; none in src/ does, so the first `*/` ends one.)
        ('/', '*') => find(s, i + 2, &['*', '/']).map_or(n, |k| k + 2),
        ('b', 'r') if literal_end(s, i + 1) > i + 1 => literal_end(s, i + 1),
        ('r', '"' | '#') => {
            let hashes = s[i + 1..].iter().take_while(|&&c| c == '#').count();
            if at(s, i + 1 + hashes) != '"' {
                return i; // a raw identifier
            }
            let mut close = vec!['"'];
            close.resize(hashes + 1, '#');
            find(s, i + 2 + hashes, &close).map_or(n, |k| k + close.len())
        }
        ('"', _) => {
            let mut e = i + 1;
            while e < n && s[e] != '"' {
                e += if s[e] == '\\' { 2 } else { 1 };
            }
            n.min(e + 1)
        }
        ('\'', '\\') => find(s, i + 3, &['\'']).map_or(n, |k| k + 1),
        ('\'', _) if at(s, i + 2) == '\'' => i + 3,
        _ => i, // code, or a lifetime's quote
    }
}

/// Identifiers, `::`, and any other char alone, with their lines; no comments or literals.
fn tokens(s: &[char]) -> Vec<Token> {
    let (mut out, mut line, mut i) = (Vec::new(), 1, 0);
    while i < s.len() {
        let literal = literal_end(s, i);
        let end = if literal > i {
            literal
        } else if is_ident(s[i]) {
            (i..s.len()).find(|&k| !is_ident(s[k])).unwrap_or(s.len())
        } else if s[i] == ':' && at(s, i + 1) == ':' {
            i + 2
        } else {
            i + 1
        };
        if literal == i && !s[i].is_whitespace() {
            out.push((line, s[i..end].iter().collect()));
        }
        line += s[i..end].iter().filter(|&&c| c == '\n').count();
        i = end;
    }
    out
}

/// The token at `i`, or "" past the end.
fn tok(t: &[Token], i: usize) -> &str {
    t.get(i).map_or("", |token| token.1.as_str())
}

/// The paths of the path or use tree at token `i` (`a::b`, `a::{b, c::d as e}`, `a::*`) into
/// `out`; returns the token after it.
fn parse_tree(t: &[Token], mut i: usize, prefix: &[String], out: &mut Vec<Vec<String>>) -> usize {
    let mut segs = prefix.to_vec();
    loop {
        let w = tok(t, i);
        if w == "{" {
            i += 1;
            while !matches!(tok(t, i), "}" | "") {
                i = parse_tree(t, i, &segs, out).max(i + 1);
                if tok(t, i) == "," {
                    i += 1;
                }
            }
            return i + 1;
        }
        if !w.starts_with(is_ident) {
            out.push(segs);
            return if w == "*" { i + 1 } else { i };
        }
        if w != "self" || segs.is_empty() {
            segs.push(w.to_string());
        }
        if tok(t, i + 1) != "::" {
            out.push(segs);
            return if tok(t, i + 1) == "as" { i + 3 } else { i + 1 };
        }
        i += 2;
    }
}

/// Each path that starts with a HEAD: its line, the inline modules around it (`mod tests {`:
/// there `super` is the file itself), its segments.
fn scan(t: &[Token]) -> Vec<(usize, Vec<String>, Vec<String>)> {
    let (mut found, mut stack, mut depth, mut i) = (Vec::new(), Vec::<(String, i64)>::new(), 0, 0);
    while i < t.len() {
        let w = t[i].1.as_str();
        if w == "{" {
            depth += 1;
        } else if w == "}" {
            if stack.last().is_some_and(|m| m.1 == depth) {
                stack.pop();
            }
            depth -= 1;
        } else if w == "mod" && tok(t, i + 2) == "{" {
            stack.push((t[i + 1].1.clone(), depth + 1));
        } else if HEADS.contains(&w)
            && tok(t, i + 1) == "::"
            && (i == 0 || !matches!(tok(t, i - 1), "::" | "$"))
        {
            let mut paths = Vec::new();
            let end = parse_tree(t, i, &[], &mut paths);
            let inline: Vec<String> = stack.iter().map(|m| m.0.clone()).collect();
            found.extend(paths.into_iter().map(|p| (t[i].0, inline.clone(), p)));
            i = end;
            continue;
        }
        i += 1;
    }
    found
}

/// Whether a file under `src/` is in the binary, and its module path (`a/b.rs` and `a/b/mod.rs`
/// are `a::b`; `lib.rs` and `main.rs` are the roots).
fn module_of(file: &str) -> (bool, Vec<String>) {
    let stem = file.strip_suffix(".rs").unwrap_or(file);
    let mut parts: Vec<String> = stem.split('/').map(String::from).collect();
    if parts.last().is_some_and(|p| p == "mod") {
        parts.pop();
    }
    let binary = parts[0] == "cli" || parts == ["main"];
    if parts == ["lib"] || parts == ["main"] {
        parts.clear();
    }
    (binary, parts)
}

/// The top-level module of a file: the binary's files are `cli`; `None` for `lib.rs`.
fn top(file: &str) -> Option<String> {
    let (binary, module) = module_of(file);
    binary
        .then(|| "cli".to_string())
        .or_else(|| module.into_iter().next())
}

fn rust_files(dir: &Path, rel: &str, out: &mut Vec<String>) {
    let mut paths: Vec<_> = fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    paths.sort();
    for path in paths {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        if path.is_dir() {
            rust_files(&path, &format!("{rel}{name}/"), out);
        } else if name.ends_with(".rs") {
            out.push(format!("{rel}{name}"));
        }
    }
}

/// Every import from one file to another: (from, to) -> line and path of its first use.
fn import_edges(src: &Path, files: &[String]) -> BTreeMap<(String, String), (usize, String)> {
    let by_module: HashMap<(bool, String), &String> = files
        .iter()
        .map(|f| {
            let (binary, module) = module_of(f);
            ((binary, module.join("::")), f)
        })
        .collect();
    let mut edges = BTreeMap::new();
    for file in files {
        let (binary, here) = module_of(file);
        let text: Vec<char> = fs::read_to_string(src.join(file))
            .unwrap()
            .chars()
            .collect();
        for (line, inline, segs) in scan(&tokens(&text)) {
            let scope: Vec<String> = here.iter().chain(&inline).cloned().collect();
            let (mut in_binary, mut rest) = (binary, &segs[1..]);
            let mut full = match segs[0].as_str() {
                "crate" => Vec::new(),
                "sweep" if binary => {
                    in_binary = false; // the binary uses the library as `sweep::`
                    Vec::new()
                }
                "sweep" => continue,
                "self" => scope,
                _ => {
                    let mut base = scope;
                    base.pop();
                    while rest.first().is_some_and(|s| s == "super") {
                        base.pop();
                        rest = &rest[1..];
                    }
                    base
                }
            };
            full.extend_from_slice(rest);
            // The deepest module with a file: `crate::engine::cpu::HISTORY_SLOTS` is engine/cpu.
            let key = |k: usize| (in_binary, full[..k].join("::"));
            let target = (1..=full.len()).rev().find_map(|k| by_module.get(&key(k)));
            if let Some(&to) = target.filter(|&&to| to != file) {
                let first_use = (line, segs.join("::"));
                edges.entry((file.clone(), to.clone())).or_insert(first_use);
            }
        }
    }
    edges
}

/// The `### Layers` list: one line per layer, lowest first, its modules in backticks before `:`.
fn read_layers(design: &str) -> Vec<Vec<String>> {
    let (mut layers, mut on) = (Vec::new(), false);
    for line in design.lines() {
        if line.starts_with('#') {
            on = line.trim() == "### Layers";
        } else if on && line.starts_with("- ") {
            let names = line.split_once(':').map_or(line, |p| p.0).split('`');
            layers.push(names.skip(1).step_by(2).map(String::from).collect());
        }
    }
    layers
}

#[test]
fn imports_follow_the_layers() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let (src, mut files) = (root.join("src"), Vec::new());
    rust_files(&src, "", &mut files);
    let edges = import_edges(&src, &files);
    assert!(!edges.is_empty(), "no imports found under src/");
    let layers = read_layers(&fs::read_to_string(root.join("docs/design.md")).unwrap());
    assert!(!layers.is_empty(), "no `### Layers` list in docs/design.md");
    let layer_of: HashMap<&str, usize> = layers
        .iter()
        .enumerate()
        .flat_map(|(i, line)| line.iter().map(move |m| (m.as_str(), i)))
        .collect();
    let mut found: BTreeMap<String, Vec<String>> = BTreeMap::new(); // violation -> its imports

    // Circles: the files a file reaches that reach it back.
    let mut next: HashMap<&str, Vec<&str>> = HashMap::new();
    for (a, b) in edges.keys() {
        next.entry(a.as_str()).or_default().push(b.as_str());
    }
    let mut reach: HashMap<&str, BTreeSet<&str>> = HashMap::new();
    for f in &files {
        let (mut seen, mut todo) = (BTreeSet::new(), vec![f.as_str()]);
        while let Some(g) = todo.pop() {
            for &h in next.get(g).into_iter().flatten() {
                if seen.insert(h) {
                    todo.push(h);
                }
            }
        }
        reach.insert(f.as_str(), seen);
    }
    for f in &files {
        let back = reach[f.as_str()]
            .iter()
            .filter(|g| reach[*g].contains(f.as_str()));
        let mut circle: BTreeSet<&str> = back.copied().collect();
        circle.insert(f.as_str());
        if circle.len() > 1 {
            let inside = edges
                .iter()
                .filter(|((a, b), _)| circle.contains(a.as_str()) && circle.contains(b.as_str()));
            let imports: Vec<String> = inside
                .map(|((a, b), (line, path))| format!("src/{a}:{line} {path} -> src/{b}"))
                .collect();
            found.insert(
                circle.iter().copied().collect::<Vec<_>>().join(" <-> "),
                imports,
            );
        }
    }

    // Upward imports, and imports between modules on one line.
    for ((a, b), (line, path)) in &edges {
        let (Some(ta), Some(tb)) = (top(a), top(b)) else {
            continue;
        };
        if ta == tb {
            continue;
        }
        for m in [&ta, &tb] {
            if !layer_of.contains_key(m.as_str()) {
                found
                    .entry(format!("module {m} is in no layer"))
                    .or_default();
            }
        }
        let (Some(la), Some(lb)) = (layer_of.get(ta.as_str()), layer_of.get(tb.as_str())) else {
            continue;
        };
        if la <= lb {
            let imports = found.entry(format!("{a} -> {tb}")).or_default();
            imports.push(format!("src/{a}:{line} {path}"));
        }
    }

    // The ratchet: nothing new, and nothing listed that is gone.
    let known: BTreeSet<&str> = KNOWN.iter().copied().collect();
    let mut problems = Vec::new();
    for (violation, imports) in &found {
        if !known.contains(violation.as_str()) {
            problems.push(format!(
                "new: {violation}\n      {}",
                imports.join("\n      ")
            ));
        }
    }
    for k in known.iter().filter(|k| !found.contains_key(**k)) {
        problems.push(format!(
            "gone: {k} (fixed: delete it from KNOWN in tests/suite/layers.rs)"
        ));
    }
    assert!(
        problems.is_empty(),
        "imports against the layers (docs/design.md, ### Layers: a module uses only the lines \
         above its own; no circles of files):\n  {}\n",
        problems.join("\n  ")
    );
}

/// The engine's rooms (`docs/design.md`, after the layers): the root keeps the model both
/// backends share and imports neither; `engine/cpu` and `engine/gpu` import the root, never
/// each other. `engine/mod.rs` declares the rooms and re-exports their engines.
#[test]
fn the_backends_sit_on_the_shared_engine_model() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let (src, mut files) = (root.join("src"), Vec::new());
    rust_files(&src, "", &mut files);
    let room = |f: &str| -> Option<&'static str> {
        let rest = f.strip_prefix("engine/")?;
        Some(if rest.starts_with("cpu/") {
            "cpu"
        } else if rest.starts_with("gpu/") || rest == "gpu.rs" {
            "gpu"
        } else {
            "root"
        })
    };
    let mut wrong = Vec::new();
    for ((a, b), (line, path)) in import_edges(&src, &files) {
        if a == "engine/mod.rs" {
            continue;
        }
        let (Some(ra), Some(rb)) = (room(&a), room(&b)) else {
            continue;
        };
        if ra != rb && rb != "root" {
            wrong.push(format!("src/{a}:{line} {path} -> src/{b} ({ra} -> {rb})"));
        }
    }
    assert!(
        wrong.is_empty(),
        "imports across the engine's rooms:\n{}",
        wrong.join("\n")
    );
}

/// The binary reaches the store only through the project facade (`sweep::project`): no file of
/// `src/cli/`, `src/cli.rs` or `src/main.rs` imports `store` or names SQLite.
#[test]
fn the_binary_reaches_the_store_only_through_the_project() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let (src, mut files) = (root.join("src"), Vec::new());
    rust_files(&src, "", &mut files);
    let binary = |f: &str| f.starts_with("cli/") || f == "cli.rs" || f == "main.rs";
    let mut wrong: Vec<String> = import_edges(&src, &files)
        .into_iter()
        .filter(|((a, b), _)| binary(a) && top(b).as_deref() == Some("store"))
        .map(|((a, b), (line, path))| format!("src/{a}:{line} {path} -> src/{b}"))
        .collect();
    for f in files.iter().filter(|f| binary(f)) {
        let text = fs::read_to_string(src.join(f)).unwrap();
        for (k, line) in text.lines().enumerate() {
            if line.contains("rusqlite") {
                wrong.push(format!("src/{f}:{}: names rusqlite", k + 1));
            }
        }
    }
    assert!(
        wrong.is_empty(),
        "the binary goes around the project:\n{}",
        wrong.join("\n")
    );
}
