//! ARCHITECTURE.md's table stays true by itself: every module of `tprf-core` and of the
//! app reads only the modules its row lists under "reads", and a row reads only rows
//! above it (the arrows point one way). Paths are collected from the source text:
//! `crate::MODULE` inside `tprf-core`, `tprf_core::MODULE` and `crate::MODULE` in the app.

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
