//! The layout `docs/architecture.md` draws, checked: every crate depends only on the crates
//! below it in the data's flow (frames → pipeline → summary → wire → host), and inside
//! each library no two modules reach into each other, directly or round a circle.
#![allow(clippy::unwrap_used)] // tests unwrap: a failure is the test failing

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_path_buf()
}

/// The workspace's own crates a manifest depends on (normal dependencies only).
fn our_dependencies(manifest: &Path) -> BTreeSet<String> {
    let text = std::fs::read_to_string(manifest).unwrap();
    let mut section = String::new();
    let mut deps = BTreeSet::new();
    for line in text.lines() {
        let line = line.trim();
        if line.starts_with('[') {
            section = line.to_string();
            continue;
        }
        if section == "[dependencies]" {
            if let Some(name) = line.split([' ', '=']).next() {
                if name.starts_with("vistaf-") {
                    deps.insert(name.to_string());
                }
            }
        }
    }
    deps
}

#[test]
fn crates_depend_only_on_what_is_below_them_in_the_flow() {
    // Each crate and the crates of ours it may use.
    let allowed: [(&str, &[&str]); 9] = [
        ("protocol", &[]),
        // The guided calibration session over any device that captures and fits a kit:
        // it speaks the wire's types, and host and board both run it.
        ("protocol/session", &["vistaf-protocol"]),
        ("hardware", &[]),
        // Figures of a frame from plain grids: a leaf, like a drawing library.
        ("host/figure", &[]),
        ("hardware/sim", &["vistaf-hardware"]),
        ("firmware/pipeline", &["vistaf-protocol", "vistaf-hardware"]),
        (
            "firmware/calibrate",
            &["vistaf-protocol", "vistaf-pipeline", "vistaf-hardware"],
        ),
        (
            "firmware",
            &[
                "vistaf-protocol",
                "vistaf-hardware",
                "vistaf-sim",
                "vistaf-pipeline",
                "vistaf-calibrate",
                "vistaf-figure",
                "vistaf-session",
            ],
        ),
        (
            "host",
            &["vistaf-protocol", "vistaf-session", "vistaf-figure"],
        ),
    ];
    for (dir, may) in allowed {
        let deps = our_dependencies(&root().join(dir).join("Cargo.toml"));
        let extra: Vec<&String> = deps.iter().filter(|d| !may.contains(&d.as_str())).collect();
        assert!(extra.is_empty(), "{dir} depends on {extra:?}");
    }
}

/// A library's modules by path (`measure::contact`), each with the source of its file.
fn modules(src: &Path) -> BTreeMap<Vec<String>, String> {
    let mut out = BTreeMap::new();
    let mut stack = vec![src.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let p = entry.unwrap().path();
            if p.is_dir() {
                stack.push(p);
                continue;
            }
            if p.extension().is_none_or(|e| e != "rs") {
                continue;
            }
            let rel = p.strip_prefix(src).unwrap().with_extension("");
            let mut path: Vec<String> = rel
                .components()
                .map(|c| c.as_os_str().to_string_lossy().into_owned())
                .collect();
            if path
                .last()
                .is_some_and(|l| l == "mod" || l == "lib" || l == "main")
            {
                path.pop();
            }
            let text = std::fs::read_to_string(&p).unwrap();
            // Code only: the tests of a module may reach anywhere.
            let code = text.split("#[cfg(test)]\nmod tests").next().unwrap_or("");
            out.insert(path, code.to_string());
        }
    }
    out
}

/// Module `from` uses module `to`, both among the children of one parent (the crate root
/// for top-level modules): the edges a circle would be made of.
fn sibling_uses(mods: &BTreeMap<Vec<String>, String>) -> BTreeSet<(Vec<String>, Vec<String>)> {
    let is_module = |p: &[String]| mods.contains_key(p);
    let mut edges = BTreeSet::new();
    for (path, code) in mods {
        for line in code.lines() {
            let l = line.trim_start();
            if l.starts_with("//") {
                continue;
            }
            let mut targets: Vec<Vec<String>> = Vec::new();
            for (prefix, base) in [
                ("crate::", Vec::new()),
                ("super::", {
                    let mut p = path.clone();
                    p.pop();
                    p
                }),
            ] {
                for (i, _) in l.match_indices(prefix) {
                    if prefix == "crate::" && i >= 1 && l[..i].ends_with("$") {
                        continue;
                    }
                    let rest = &l[i + prefix.len()..];
                    let names: Vec<String> = rest
                        .split("::")
                        .map(|s| {
                            s.chars()
                                .take_while(|c| c.is_alphanumeric() || *c == '_')
                                .collect::<String>()
                        })
                        .take_while(|s| !s.is_empty())
                        .collect();
                    let mut t = base.clone();
                    for n in names {
                        t.push(n);
                        if !is_module(&t) {
                            t.pop();
                            break;
                        }
                    }
                    targets.push(t);
                }
            }
            for t in targets {
                // The first level where the two paths part: siblings under a common parent.
                let common = path.iter().zip(&t).take_while(|(a, b)| a == b).count();
                if common < path.len() && common < t.len() {
                    edges.insert((path[..=common].to_vec(), t[..=common].to_vec()));
                }
            }
        }
    }
    edges
}

/// A circle among the edges, if there is one.
fn circle(edges: &BTreeSet<(Vec<String>, Vec<String>)>) -> Option<Vec<Vec<String>>> {
    let nodes: BTreeSet<&Vec<String>> = edges.iter().flat_map(|(a, b)| [a, b]).collect();
    fn visit<'a>(
        n: &'a Vec<String>,
        edges: &'a BTreeSet<(Vec<String>, Vec<String>)>,
        on_path: &mut Vec<&'a Vec<String>>,
        done: &mut BTreeSet<&'a Vec<String>>,
    ) -> Option<Vec<Vec<String>>> {
        if let Some(at) = on_path.iter().position(|m| *m == n) {
            return Some(on_path[at..].iter().map(|m| (*m).clone()).collect());
        }
        if !done.insert(n) {
            return None;
        }
        on_path.push(n);
        for (_, b) in edges.iter().filter(|(a, _)| a == n) {
            if let Some(c) = visit(b, edges, on_path, done) {
                return Some(c);
            }
        }
        on_path.pop();
        None
    }
    let mut done = BTreeSet::new();
    for n in nodes {
        if let Some(c) = visit(n, edges, &mut Vec::new(), &mut done) {
            return Some(c);
        }
    }
    None
}

#[test]
fn no_module_reaches_round_a_circle() {
    for dir in [
        "protocol",
        "hardware",
        "hardware/sim",
        "firmware/pipeline",
        "firmware/calibrate",
        "firmware",
        "host",
    ] {
        let mods = modules(&root().join(dir).join("src"));
        let edges = sibling_uses(&mods);
        assert!(!edges.is_empty() || mods.len() < 3, "{dir}: no uses found");
        if let Some(c) = circle(&edges) {
            panic!("{dir}: modules in a circle: {c:?}");
        }
    }
}

#[test]
fn a_circle_is_seen() {
    let mods: BTreeMap<Vec<String>, String> = [
        (vec![], "mod a;\nmod b;".to_string()),
        (vec!["a".to_string()], "use crate::b::X;".to_string()),
        (vec!["b".to_string()], "use super::a::Y;".to_string()),
    ]
    .into_iter()
    .collect();
    assert!(circle(&sibling_uses(&mods)).is_some());
}
