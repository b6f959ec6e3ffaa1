//! The crate's structure, read from `src/`: no module imports one that
//! imports it back, except a module and its own descendants (code under
//! `#[cfg(test)]` may use anything and is not counted); `src/sim/` names no
//! ECS type and none of the plugin; and only `src/simd/` names `std::arch`
//! or a target feature.

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};

/// Every `.rs` file under `dir`.
fn sources(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            sources(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The module path of a source file: `src/a/b.rs` and `src/a/b/mod.rs` are
/// `a::b`; `src/lib.rs` is the crate root, the empty path.
fn module_of(src: &Path, file: &Path) -> String {
    let rel = file.strip_prefix(src).unwrap().with_extension("");
    let mut parts: Vec<String> = rel
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    if matches!(parts.last().map(String::as_str), Some("mod" | "lib")) {
        parts.pop();
    }
    parts.join("::")
}

/// The text without comments, string literals' contents, and items under
/// `#[cfg(test)]` (the attribute and the item after it: up to its `;` or its
/// closing brace).
fn code(text: &str) -> String {
    let mut out = String::new();
    for line in text.lines() {
        let line = match line.find("//") {
            Some(at) => &line[..at],
            None => line,
        };
        out.push_str(line);
        out.push('\n');
    }
    let mut result = String::new();
    let mut rest = out.as_str();
    while let Some(at) = rest.find("#[cfg(test)]") {
        result.push_str(&rest[..at]);
        let item = &rest[at + "#[cfg(test)]".len()..];
        let end_semi = item.find(';');
        let open = item.find('{');
        let skip = match (end_semi, open) {
            (Some(s), Some(o)) if s < o => s + 1,
            (_, Some(o)) => {
                let mut depth = 0usize;
                let mut end = item.len();
                for (i, c) in item[o..].char_indices() {
                    match c {
                        '{' => depth += 1,
                        '}' => {
                            depth -= 1;
                            if depth == 0 {
                                end = o + i + 1;
                                break;
                            }
                        }
                        _ => {}
                    }
                }
                end
            }
            (Some(s), None) => s + 1,
            (None, None) => item.len(),
        };
        rest = &item[skip..];
    }
    result.push_str(rest);
    result
}

/// The paths named in a `use` group starting after `{` at `text[0]`,
/// expanded (`a::{b, c::{d}}` gives `a::b`, `a::c::d`), and the length of
/// the group.
fn group(text: &str) -> (Vec<String>, usize) {
    let mut depth = 0usize;
    let mut items = Vec::new();
    let mut current = String::new();
    let mut end = text.len();
    for (i, c) in text.char_indices() {
        match c {
            '{' => {
                depth += 1;
                if depth > 1 {
                    current.push(c);
                }
            }
            '}' => {
                depth -= 1;
                if depth == 0 {
                    end = i + 1;
                    break;
                }
                current.push(c);
            }
            ',' if depth == 1 => items.push(std::mem::take(&mut current)),
            _ => current.push(c),
        }
    }
    items.push(current);
    let mut paths = Vec::new();
    for item in items {
        let item = item.trim();
        if item.is_empty() {
            continue;
        }
        match item.find('{') {
            Some(at) => {
                let head = item[..at].trim().trim_end_matches("::");
                for inner in group(&item[at..]).0 {
                    paths.push(if head.is_empty() {
                        inner
                    } else {
                        format!("{head}::{inner}")
                    });
                }
            }
            None => paths.push(item.split(" as ").next().unwrap().trim().to_string()),
        }
    }
    (paths, end)
}

/// Every path after `crate::` or `super::` in `text`, made absolute for a
/// file whose module is `module` (`super` is its parent, whether the file is
/// `a/b.rs` or `a/b/mod.rs`).
fn named_paths(text: &str, module: &str) -> Vec<String> {
    let here: Vec<&str> = module.split("::").filter(|s| !s.is_empty()).collect();
    let mut out = Vec::new();
    for (prefix, base) in [
        ("crate::", Vec::new()),
        ("super::", here[..here.len().saturating_sub(1)].to_vec()),
    ] {
        let mut from = 0;
        while let Some(at) = text[from..].find(prefix) {
            let start = from + at;
            from = start + prefix.len();
            // A whole word: `crate::`, not `my_crate::`.
            if text[..start]
                .chars()
                .last()
                .is_some_and(|c| c.is_alphanumeric() || c == '_')
            {
                continue;
            }
            let rest = &text[from..];
            let len = rest
                .find(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':'))
                .unwrap_or(rest.len());
            let mut path = rest[..len].trim_end_matches(':').to_string();
            let tails = if rest[len..].starts_with('{') && (len == 0 || rest[..len].ends_with("::"))
            {
                group(&rest[len..]).0
            } else {
                vec![String::new()]
            };
            for tail in tails {
                let full = if tail.is_empty() {
                    path.clone()
                } else if path.is_empty() {
                    tail
                } else {
                    format!("{path}::{tail}")
                };
                let mut parts = base.clone();
                let full = full.replace("super::", "");
                parts.extend(full.split("::").filter(|s| !s.is_empty() && *s != "self"));
                out.push(parts.join("::"));
            }
            path.clear();
        }
    }
    out
}

/// The longest prefix of `path` that is a module.
fn resolve<'a>(modules: &'a BTreeSet<String>, path: &str) -> Option<&'a String> {
    let parts: Vec<&str> = path.split("::").collect();
    (1..=parts.len())
        .rev()
        .find_map(|k| modules.get(&parts[..k].join("::")))
}

fn is_descendant(module: &str, of: &str) -> bool {
    of.is_empty() || module.starts_with(&format!("{of}::"))
}

/// The module graph: each module and the modules it names, leaving out a
/// module naming its own descendants (its children are its parts).
fn graph() -> BTreeMap<String, BTreeSet<String>> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    sources(&src, &mut files);
    let modules: BTreeSet<String> = files.iter().map(|f| module_of(&src, f)).collect();
    let mut edges = BTreeMap::new();
    for file in &files {
        let module = module_of(&src, file);
        let text = code(&fs::read_to_string(file).unwrap());
        let mut deps = BTreeSet::new();
        for path in named_paths(&text, &module) {
            if let Some(target) = resolve(&modules, &path)
                && *target != module
                && !is_descendant(target, &module)
            {
                deps.insert(target.clone());
            }
        }
        edges.insert(module, deps);
    }
    edges
}

/// The strongly connected components with more than one module (Tarjan).
fn cycles(edges: &BTreeMap<String, BTreeSet<String>>) -> Vec<Vec<String>> {
    struct Walk<'a> {
        edges: &'a BTreeMap<String, BTreeSet<String>>,
        index: BTreeMap<&'a str, usize>,
        low: BTreeMap<&'a str, usize>,
        stack: Vec<&'a str>,
        on_stack: BTreeSet<&'a str>,
        found: Vec<Vec<String>>,
    }
    fn visit<'a>(w: &mut Walk<'a>, v: &'a str) {
        let i = w.index.len();
        w.index.insert(v, i);
        w.low.insert(v, i);
        w.stack.push(v);
        w.on_stack.insert(v);
        for next in w.edges.get(v).into_iter().flatten() {
            let next = next.as_str();
            if !w.index.contains_key(next) {
                visit(w, next);
                let low = w.low[v].min(w.low[next]);
                w.low.insert(v, low);
            } else if w.on_stack.contains(next) {
                let low = w.low[v].min(w.index[next]);
                w.low.insert(v, low);
            }
        }
        if w.low[v] == w.index[v] {
            let mut component = Vec::new();
            loop {
                let m = w.stack.pop().unwrap();
                w.on_stack.remove(m);
                component.push(m.to_string());
                if m == v {
                    break;
                }
            }
            if component.len() > 1 {
                component.sort();
                w.found.push(component);
            }
        }
    }
    let mut walk = Walk {
        edges,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on_stack: BTreeSet::new(),
        found: Vec::new(),
    };
    for v in edges.keys() {
        if !walk.index.contains_key(v.as_str()) {
            visit(&mut walk, v);
        }
    }
    walk.found
}

#[test]
fn no_module_imports_one_that_imports_it_back() {
    let edges = graph();
    assert!(edges.len() > 40, "read {} modules", edges.len());
    let found = cycles(&edges);
    let described: Vec<String> = found
        .iter()
        .map(|c| {
            let links: Vec<String> = c
                .iter()
                .map(|m| {
                    let to: Vec<&String> = edges[m].iter().filter(|d| c.contains(d)).collect();
                    format!("{m} -> {to:?}")
                })
                .collect();
            links.join("; ")
        })
        .collect();
    assert!(found.is_empty(), "import cycles: {described:#?}");
}

#[test]
fn only_the_simd_folder_names_cpu_features() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    sources(&src, &mut files);
    let mut found = Vec::new();
    for file in &files {
        if file.starts_with(src.join("simd")) {
            continue;
        }
        let text = fs::read_to_string(file).unwrap();
        for (i, line) in text.lines().enumerate() {
            let code = line.split("//").next().unwrap_or("");
            for word in [
                "std::arch",
                "core::arch",
                "target_feature",
                "is_x86_feature_detected",
            ] {
                if code.contains(word) {
                    found.push(format!("{}:{}: {word}", file.display(), i + 1));
                }
            }
        }
    }
    assert!(
        found.is_empty(),
        "CPU-specific code outside src/simd/: {found:#?}"
    );
}

/// What `src/sim/` may not name: the ECS (components, resources, queries,
/// commands, entities, messages, events, task pools, apps, worlds,
/// plugins, systems), Bevy outside `bevy::math`, `bevy::shape` (shapes
/// and bounding volumes), `bevy::reflect` and `bevy::platform` (a clock
/// that works in a browser), and the plugin layer.
fn ecs_names(text: &str) -> Vec<String> {
    const WORDS: [&str; 17] = [
        "Component",
        "Resource",
        "Query",
        "Commands",
        "Entity",
        "Message",
        "Event",
        "EntityEvent",
        "TaskPool",
        "ComputeTaskPool",
        "App",
        "World",
        "Plugin",
        "SystemParam",
        "Res",
        "ResMut",
        "Bundle",
    ];
    let mut found = Vec::new();
    let words = text
        .split(|c: char| !(c.is_alphanumeric() || c == '_'))
        .filter(|w| !w.is_empty());
    for word in words {
        if WORDS.contains(&word) {
            found.push(word.to_string());
        }
    }
    let mut from = 0;
    while let Some(at) = text[from..].find("bevy::") {
        let start = from + at + "bevy::".len();
        let module: String = text[start..]
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect();
        if !["math", "shape", "reflect", "platform"].contains(&module.as_str()) {
            found.push(format!("bevy::{module}"));
        }
        from = start;
    }
    if text.contains("crate::plugin") || text.contains("bevy_cloth::plugin") {
        found.push("crate::plugin".to_string());
    }
    found
}

#[test]
fn the_simulation_core_names_no_ecs_type() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    sources(&src.join("sim"), &mut files);
    assert!(files.len() > 30, "read {} files", files.len());
    let mut found = Vec::new();
    for file in &files {
        // Unit-test files (`mod tests;` under `#[cfg(test)]`) may use anything.
        let module = module_of(&src, file);
        if module.split("::").any(|part| part == "tests") {
            continue;
        }
        let text = code(&fs::read_to_string(file).unwrap());
        for name in ecs_names(&text) {
            found.push(format!("{}: {name}", file.display()));
        }
    }
    assert!(found.is_empty(), "ECS names in src/sim/: {found:#?}");
}

#[test]
fn the_reader_sees_uses_groups_and_test_code() {
    // The checker itself: a grouped `use`, `super::`, and imports under
    // `#[cfg(test)]` and in comments left out.
    let text = code(
        "use crate::{a::B, c::{d::E, F}};\nuse super::g::H; // crate::comment\n\
         #[cfg(test)]\nuse crate::tested;\n#[cfg(test)]\nmod tests { use crate::x; }\n",
    );
    let mut paths = named_paths(&text, "m::n");
    paths.sort();
    assert_eq!(paths, ["a::B", "c::F", "c::d::E", "m::g::H"]);
    // A cycle between two modules is found; a chain is not.
    let mut edges: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    edges.insert("a".into(), ["b".to_string()].into());
    edges.insert("b".into(), ["a".to_string()].into());
    edges.insert("c".into(), ["a".to_string()].into());
    assert_eq!(cycles(&edges), vec![vec!["a".to_string(), "b".to_string()]]);
    // ECS names are found as whole words, outside comments and tests;
    // `ComponentCount` or a comment about a `Query` is not one.
    let text = code(
        "use bevy::prelude::{Component, Query};\nuse bevy::math::Vec3;\n\
         struct ComponentCount; // a Query\nfn f(e: Entity) {}\n\
         use crate::plugin::x;\n#[cfg(test)]\nmod tests { use bevy::ecs::World; }\n",
    );
    assert_eq!(
        ecs_names(&text),
        [
            "Component",
            "Query",
            "Entity",
            "bevy::prelude",
            "crate::plugin"
        ]
    );
}
