//! ARCHITECTURE.md's table stays true by itself: every module of `tprf-core` and of the
//! app reads only the modules its row lists under "reads", and a row reads only rows
//! above it (the arrows point one way). Paths are collected from the source text:
//! `crate::MODULE` inside `tprf-core`, `tprf_core::MODULE` and `crate::MODULE` in the app.
//! Inside a module, the files' imports of each other form no cycle beyond the known
//! ones listed here, and every error type the prose names exists in the code.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

const ROOT: &str = env!("CARGO_MANIFEST_DIR");

/// One row of the table: the module and what it reads, in table order.
fn table() -> Vec<(String, BTreeSet<String>)> {
    let text = std::fs::read_to_string(Path::new(ROOT).join("ARCHITECTURE.md")).unwrap();
    let mut rows = Vec::new();
    for line in text.lines() {
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        // | `module` | what | reads | knows nothing of |
        if cells.len() < 5 || !cells[1].starts_with('`') {
            continue;
        }
        let module = ticked(cells[1]).into_iter().next().unwrap();
        // "all above" (the command line) reads every row before it.
        let reads = if cells[3].contains("all above") {
            rows.iter().map(|(m, _): &(String, _)| m.clone()).collect()
        } else {
            ticked(cells[3]).into_iter().collect()
        };
        rows.push((module, reads));
    }
    assert!(rows.len() >= 10, "ARCHITECTURE.md's table was not found");
    rows
}

/// The words in backticks of a table cell.
fn ticked(cell: &str) -> Vec<String> {
    cell.split('`')
        .skip(1)
        .step_by(2)
        .map(|s| s.trim().to_string())
        .collect()
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The module a source file belongs to, as the table names it: the file's first path
/// component under `src/` (`request/worker.rs` is `request::worker`, its own row).
fn module_of(src: &Path, file: &Path, rows: &[(String, BTreeSet<String>)]) -> Option<String> {
    let rel = file.strip_prefix(src).unwrap();
    let parts: Vec<String> = rel
        .iter()
        .map(|p| p.to_string_lossy().trim_end_matches(".rs").to_string())
        .collect();
    let top = parts.first()?.clone();
    if top == "lib" || top == "main" {
        return None;
    }
    if let Some(sub) = parts.get(1) {
        let nested = format!("{top}::{sub}");
        if rows.iter().any(|(m, _)| *m == nested) {
            return Some(nested);
        }
    }
    Some(top)
}

/// Modules `text` refers to through `prefix` (`crate::` or `tprf_core::`), with the row
/// names of nested rows (`request::worker`) where the path goes that deep. Comments
/// are skipped.
fn referenced(text: &str, prefix: &str, rows: &[(String, BTreeSet<String>)]) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    for line in text.lines() {
        let code = line.split("//").next().unwrap_or("");
        let mut rest = code;
        while let Some(i) = rest.find(prefix) {
            let before = rest[..i].chars().last();
            rest = &rest[i + prefix.len()..];
            if before.is_some_and(|c| c.is_alphanumeric() || c == '_') {
                continue;
            }
            // `crate::{a, b::c}` or `crate::a::b`.
            let names: Vec<String> = if let Some(group) = rest.strip_prefix('{') {
                let end = group.find('}').unwrap_or(group.len());
                group[..end]
                    .split(',')
                    .map(|s| s.trim().to_string())
                    .filter(|s| !s.is_empty())
                    .collect()
            } else {
                vec![
                    rest.chars()
                        .take_while(|c| c.is_alphanumeric() || *c == '_' || *c == ':')
                        .collect(),
                ]
            };
            for name in names {
                let mut parts = name.split("::").filter(|s| !s.is_empty());
                let Some(top) = parts.next() else { continue };
                let top = top.trim_end_matches(|c: char| !c.is_alphanumeric() && c != '_');
                if let Some(sub) = parts.next() {
                    let nested = format!("{top}::{sub}");
                    if rows.iter().any(|(m, _)| *m == nested) {
                        out.insert(nested);
                        continue;
                    }
                }
                out.insert(top.to_string());
            }
        }
    }
    out
}

/// Is `used` allowed for a module whose row reads `reads`? Reading `transport` allows
/// its nested rows' parent only; a nested row (`request::worker`) is listed by name.
fn allowed(module: &str, used: &str, reads: &BTreeSet<String>) -> bool {
    used == module
        || module.starts_with(&format!("{used}::"))
        || used.starts_with(&format!("{module}::")) && !module.contains("::")
        || reads.contains(used)
}

#[test]
fn every_module_reads_only_what_architecture_md_says() {
    let rows = table();
    let known: BTreeSet<&str> = rows.iter().map(|(m, _)| m.as_str()).collect();
    let mut violations = Vec::new();
    let crates: [(&str, &[&str]); 2] = [
        ("crates/tprf-core/src", &["crate::"]),
        ("src", &["crate::", "tprf_core::"]),
    ];
    let mut seen_modules = BTreeSet::new();
    for (dir, prefixes) in crates {
        let src = Path::new(ROOT).join(dir);
        let mut files = Vec::new();
        rust_files(&src, &mut files);
        for file in files {
            let Some(module) = module_of(&src, &file, &rows) else {
                continue;
            };
            seen_modules.insert(module.clone());
            let Some((_, reads)) = rows.iter().find(|(m, _)| *m == module) else {
                violations.push(format!("{}: module `{module}` has no row", file.display()));
                continue;
            };
            let text = std::fs::read_to_string(&file).unwrap();
            for prefix in prefixes {
                for used in referenced(&text, prefix, &rows) {
                    if !known.contains(used.as_str()) {
                        continue; // an item of the crate root, not a module
                    }
                    if !allowed(&module, &used, reads) {
                        violations.push(format!(
                            "{}: `{module}` uses `{used}`, which its row does not list",
                            file.strip_prefix(ROOT).unwrap_or(&file).display()
                        ));
                    }
                }
            }
        }
    }
    assert!(
        violations.is_empty(),
        "ARCHITECTURE.md and the code disagree:\n{}",
        violations.join("\n")
    );
    // Every row names a module that exists.
    for (m, _) in &rows {
        assert!(
            seen_modules.contains(m),
            "ARCHITECTURE.md lists `{m}`, not in the code"
        );
    }
}

#[test]
fn the_table_points_one_way() {
    let rows = table();
    let mut above: BTreeMap<&str, usize> = BTreeMap::new();
    for (i, (m, reads)) in rows.iter().enumerate() {
        for r in reads {
            let parent = r.split("::").next().unwrap_or(r);
            let ok = above.contains_key(r.as_str()) || above.contains_key(parent);
            assert!(
                ok,
                "`{m}` reads `{r}`, which is not above it in ARCHITECTURE.md"
            );
        }
        above.insert(m, i);
    }
}

/// Every error type ARCHITECTURE.md's prose names (a word in backticks ending in
/// `Error`) is declared somewhere in the code, as an enum or a struct.
#[test]
fn every_error_type_architecture_md_names_exists() {
    let text = std::fs::read_to_string(Path::new(ROOT).join("ARCHITECTURE.md")).unwrap();
    let named: BTreeSet<String> = ticked(&text)
        .into_iter()
        .filter(|w| w.ends_with("Error") && w.chars().all(|c| c.is_alphanumeric() || c == '_'))
        .collect();
    assert!(
        named.len() >= 5,
        "ARCHITECTURE.md's error types were not found: {named:?}"
    );
    let mut declared = BTreeSet::new();
    for dir in ["crates/tprf-core/src", "src", "crates/tprf-py/src"] {
        let mut files = Vec::new();
        rust_files(&Path::new(ROOT).join(dir), &mut files);
        for file in files {
            let text = std::fs::read_to_string(&file).unwrap();
            for line in text.lines() {
                let code = line.split("//").next().unwrap_or("");
                let words: Vec<&str> = code
                    .split(|c: char| !(c.is_alphanumeric() || c == '_'))
                    .filter(|w| !w.is_empty())
                    .collect();
                for pair in words.windows(2) {
                    if pair[0] == "enum" || pair[0] == "struct" {
                        declared.insert(pair[1].to_string());
                    }
                }
            }
        }
    }
    let missing: Vec<&String> = named.difference(&declared).collect();
    assert!(
        missing.is_empty(),
        "ARCHITECTURE.md names error types the code does not declare: {missing:?}"
    );
}

/// Import cycles between the files of one module that are known today, as
/// "module: file, file, ...". The list may only shrink: a cycle broken must leave it,
/// and a new cycle (or a file joining one) fails the test below.
const KNOWN_CYCLES: &[&str] = &[
    "film: error, time_axis",
    "nlos: files, reconstruct",
    "scene::gltf_load: decode, resource, validate",
    "scene::mitsuba: transform, xml",
    "sensor: model, preset, spad",
    "transport: connect, integrator, media, split",
    "viewer: app, exports, files, nlos, panels, sensor, source",
];

/// The module path of a source file (`transport/integrator.rs` is `transport::integrator`,
/// `transport/mod.rs` is `transport`).
fn module_path(src: &Path, file: &Path) -> Vec<String> {
    let rel = file.strip_prefix(src).unwrap();
    let mut parts: Vec<String> = rel
        .iter()
        .map(|p| p.to_string_lossy().trim_end_matches(".rs").to_string())
        .collect();
    if parts
        .last()
        .is_some_and(|p| p == "mod" || p == "lib" || p == "main")
    {
        parts.pop();
    }
    parts
}

/// The paths `code` names through `crate::`, `super::` or `self::`, made absolute for a
/// file of module `module`, groups expanded (`super::{a::B, c}` is `a::B` and `c`).
fn absolute_paths(code: &str, module: &[String]) -> Vec<Vec<String>> {
    fn expand(text: &str, prefix: Vec<String>, out: &mut Vec<Vec<String>>) -> usize {
        // Reads `ident::ident::...` then maybe `{...}`; returns the bytes consumed.
        let mut path = prefix;
        let mut i = 0;
        let bytes = text.as_bytes();
        loop {
            let start = i;
            while i < bytes.len() && (bytes[i].is_ascii_alphanumeric() || bytes[i] == b'_') {
                i += 1;
            }
            if i > start {
                path.push(text[start..i].to_string());
            }
            if text[i..].starts_with("::") {
                i += 2;
                if text[i..].starts_with('{') {
                    i += 1;
                    loop {
                        while text[i..].starts_with([' ', '\n', ',']) {
                            i += 1;
                        }
                        if i >= bytes.len() || text[i..].starts_with('}') {
                            return i + 1;
                        }
                        let used = expand(&text[i..], path.clone(), out);
                        if used == 0 {
                            return i;
                        }
                        i += used;
                    }
                }
                continue;
            }
            out.push(path);
            return i;
        }
    }
    let mut out = Vec::new();
    let mut rest = code;
    loop {
        let found = ["crate::", "super::", "self::"]
            .iter()
            .filter_map(|p| rest.find(p).map(|i| (i, *p)))
            .min();
        let Some((i, prefix)) = found else { break };
        let before = rest[..i].chars().last();
        let after = &rest[i + prefix.len()..];
        rest = after;
        if before.is_some_and(|c| c.is_alphanumeric() || c == '_' || c == ':') {
            continue;
        }
        // The base the path starts from, then any further `super::`.
        let mut base: Vec<String> = match prefix {
            "crate::" => Vec::new(),
            "self::" => module.to_vec(),
            _ => module[..module.len().saturating_sub(1)].to_vec(),
        };
        let mut tail = after;
        while let Some(t) = tail.strip_prefix("super::") {
            base.pop();
            tail = t;
        }
        let mut paths = Vec::new();
        let text: String = tail.chars().take(4000).collect();
        expand(&text, base, &mut paths);
        out.extend(paths);
    }
    out
}

/// The import cycles between the files (and sub-folders) of each module of a crate:
/// strongly connected groups of more than one file, as "module: a, b, c".
fn cycles_in(src_dir: &str) -> BTreeSet<String> {
    let src = Path::new(ROOT).join(src_dir);
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    // Per module: its children (files and folders) and the items its own file re-exports
    // from them (`pub use child::{A, B}`).
    let mut children: BTreeMap<Vec<String>, BTreeSet<String>> = BTreeMap::new();
    let mut reexports: BTreeMap<Vec<String>, BTreeMap<String, String>> = BTreeMap::new();
    let mut texts = Vec::new();
    for file in &files {
        let module = module_path(&src, file);
        let text = std::fs::read_to_string(file).unwrap();
        // Test modules are left out: their `super` is the file itself.
        let code: String = text
            .split("#[cfg(test)]")
            .next()
            .unwrap_or("")
            .lines()
            .map(|l| l.split("//").next().unwrap_or(""))
            .collect::<Vec<_>>()
            .join("\n");
        for depth in 0..module.len() {
            children
                .entry(module[..depth].to_vec())
                .or_default()
                .insert(module[depth].clone());
        }
        // `pub use child::{A, B};` (over lines too).
        for start in ["pub use ", "pub(crate) use "] {
            for (i, _) in code.match_indices(start) {
                let rest = &code[i + start.len()..];
                let rest = &rest[..rest.find(';').unwrap_or(rest.len())];
                let rest = rest.strip_prefix("self::").unwrap_or(rest);
                let child: String = rest
                    .chars()
                    .take_while(|c| c.is_alphanumeric() || *c == '_')
                    .collect();
                let mut items = Vec::new();
                expand_items(rest, &mut items);
                for item in items {
                    reexports
                        .entry(module.clone())
                        .or_default()
                        .insert(item, child.clone());
                }
            }
        }
        texts.push((module, code));
    }
    // Edges between the children of each module.
    let mut edges: BTreeMap<Vec<String>, BTreeSet<(String, String)>> = BTreeMap::new();
    for (module, code) in &texts {
        for path in absolute_paths(code, module) {
            for depth in 0..module.len() {
                let level = &module[..depth];
                let from = &module[depth];
                if path.len() <= depth || path[..depth] != *level {
                    continue;
                }
                let name = &path[depth];
                let kids = children.get(level);
                let to = if kids.is_some_and(|k| k.contains(name)) {
                    Some(name.clone())
                } else {
                    reexports
                        .get(level)
                        .and_then(|r| r.get(name))
                        .filter(|child| kids.is_some_and(|k| k.contains(*child)))
                        .cloned()
                };
                if let Some(to) = to
                    && to != *from
                {
                    edges
                        .entry(level.to_vec())
                        .or_default()
                        .insert((from.clone(), to));
                }
            }
        }
    }
    let mut cycles = BTreeSet::new();
    for (level, edges) in edges {
        for group in strongly_connected(&edges) {
            if group.len() > 1 {
                let name = if level.is_empty() {
                    src_dir.to_string()
                } else {
                    level.join("::")
                };
                let members: Vec<String> = group.into_iter().collect();
                cycles.insert(format!("{name}: {}", members.join(", ")));
            }
        }
    }
    cycles
}

/// The names a `use` tree brings in: `a::{B, c::D}` gives `B` and `D`; `a::B as C` gives `C`.
fn expand_items(tree: &str, out: &mut Vec<String>) {
    let tree = tree.trim().trim_end_matches(';');
    if let Some(open) = tree.find('{') {
        let close = tree.rfind('}').unwrap_or(tree.len());
        let inner = &tree[open + 1..close];
        let mut depth = 0;
        let mut start = 0;
        for (i, c) in inner.char_indices() {
            match c {
                '{' => depth += 1,
                '}' => depth -= 1,
                ',' if depth == 0 => {
                    expand_items(&inner[start..i], out);
                    start = i + 1;
                }
                _ => {}
            }
        }
        expand_items(&inner[start..], out);
    } else if !tree.is_empty() {
        let last = tree.rsplit("::").next().unwrap_or(tree);
        let name = last.rsplit(" as ").next().unwrap_or(last).trim();
        if !name.is_empty() && name != "*" && name != "self" {
            out.push(name.to_string());
        }
    }
}

/// The strongly connected groups of a directed graph given by its edges (by mutual
/// reachability: the graphs are a module's files, a few dozen nodes at most).
fn strongly_connected(edges: &BTreeSet<(String, String)>) -> Vec<BTreeSet<String>> {
    let nodes: BTreeSet<&String> = edges.iter().flat_map(|(a, b)| [a, b]).collect();
    let reach = |start: &String| -> BTreeSet<String> {
        let mut seen = BTreeSet::new();
        let mut stack = vec![start.clone()];
        while let Some(n) = stack.pop() {
            for (a, b) in edges {
                if *a == n && seen.insert(b.clone()) {
                    stack.push(b.clone());
                }
            }
        }
        seen
    };
    let reaches: BTreeMap<&String, BTreeSet<String>> =
        nodes.iter().map(|n| (*n, reach(n))).collect();
    let mut groups: Vec<BTreeSet<String>> = Vec::new();
    for n in &nodes {
        if groups.iter().any(|g| g.contains(*n)) {
            continue;
        }
        let group: BTreeSet<String> = nodes
            .iter()
            .filter(|m| *m == n || reaches[*n].contains(**m) && reaches[**m].contains(*n))
            .map(|m| (*m).clone())
            .collect();
        groups.push(group);
    }
    groups
}

#[test]
fn no_import_cycles_inside_a_module_beyond_the_known_ones() {
    let mut found = cycles_in("crates/tprf-core/src");
    found.extend(cycles_in("src"));
    let known: BTreeSet<String> = KNOWN_CYCLES.iter().map(|s| s.to_string()).collect();
    let new: Vec<&String> = found.difference(&known).collect();
    let gone: Vec<&String> = known.difference(&found).collect();
    assert!(
        new.is_empty(),
        "import cycles between the files of a module (break them: move what both sides \
         need into a file of its own):\n{}",
        new.iter()
            .map(|s| s.as_str())
            .collect::<Vec<_>>()
            .join("\n")
    );
    assert!(
        gone.is_empty(),
        "these known cycles are gone (or changed): take them out of KNOWN_CYCLES:\n{}",
        gone.iter()
            .map(|s| s.as_str())
            .collect::<Vec<_>>()
            .join("\n")
    );
}
