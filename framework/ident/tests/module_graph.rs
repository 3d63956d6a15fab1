//! The modules of `identify` import each other in one direction (issue 31: causes, spectrum and
//! search imported each other in a circle, and design and select did): read from the sources,
//! every `super::m` and `crate::identify::m` between sibling modules, and no path may return.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// Sibling modules of `identify` and the siblings each refers to (a folder module counts as one).
fn edges() -> BTreeMap<String, BTreeSet<String>> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("src/identify");
    let mut files: Vec<(String, String)> = Vec::new();
    for entry in std::fs::read_dir(&root).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_stem().unwrap().to_string_lossy().to_string();
        if path.is_dir() {
            for inner in std::fs::read_dir(&path).unwrap() {
                let inner = inner.unwrap().path();
                // Inside the folder, `super::` is the folder's own module: only `crate::identify::`
                // (and `super::super::`) leave it.
                let text = std::fs::read_to_string(&inner).unwrap();
                let text = if inner.file_stem().unwrap() == "mod" { text } else { text.replace("super::super::", "crate::identify::").replace("super::", "self_folder::") };
                files.push((name.clone(), text));
            }
        } else if name != "mod" {
            files.push((name, std::fs::read_to_string(&path).unwrap()));
        }
    }
    let modules: BTreeSet<String> = files.iter().map(|(m, _)| m.clone()).collect();
    let mut out: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (module, text) in &files {
        // Test modules of a file may use anything.
        let text = text.split("#[cfg(test)]").next().unwrap_or(text);
        for other in &modules {
            if other != module && (text.contains(&format!("super::{other}")) || text.contains(&format!("crate::identify::{other}"))) {
                out.entry(module.clone()).or_default().insert(other.clone());
            }
        }
    }
    out
}

#[test]
fn the_identify_modules_import_each_other_in_one_direction() {
    let graph = edges();
    assert!(graph.get("search").is_some_and(|s| s.contains("causes")), "the reading found no edges: {graph:?}");
    // Depth-first: a module on the current path reached again is a circle.
    fn visit(m: &str, graph: &BTreeMap<String, BTreeSet<String>>, path: &mut Vec<String>, done: &mut BTreeSet<String>) {
        if done.contains(m) {
            return;
        }
        assert!(!path.iter().any(|p| p == m), "import circle: {} -> {m}", path.join(" -> "));
        path.push(m.to_string());
        for next in graph.get(m).into_iter().flatten() {
            visit(next, graph, path, done);
        }
        path.pop();
        done.insert(m.to_string());
    }
    let mut done = BTreeSet::new();
    for m in graph.keys() {
        visit(m, &graph, &mut Vec::new(), &mut done);
    }
}
