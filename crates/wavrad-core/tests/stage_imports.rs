//! The crate's folders are the stages of the paper's data flow, and every
//! import points down that flow: no module names a module of a later stage
//! (`use crate::…` or a `crate::…` path anywhere in its code, its tests
//! included; comments are free to point anywhere).

use std::fs;
use std::path::{Path, PathBuf};

/// The top-level modules of `src/`, by stage, in the order data flows.
const STAGES: &[(&str, usize)] = &[
    // 0. Foundations.
    ("error", 0),
    ("progress", 0),
    ("sampling", 0),
    ("setting", 0),
    // 1. Scene description.
    ("scene", 1),
    ("testing", 1),
    // 2. Geometry.
    ("geometry", 2),
    // 3. Kernel quadrature.
    ("kernel", 3),
    // 4. Refinement (projection and oracles).
    ("refine", 4),
    // 5. Solve.
    ("solve", 5),
    // 6. Render.
    ("render", 6),
];

fn stage_of(module: &str) -> Option<usize> {
    STAGES.iter().find(|(m, _)| *m == module).map(|&(_, s)| s)
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The top-level module a file of `src/` belongs to (`None` for `lib.rs`).
fn module_of(src: &Path, file: &Path) -> Option<String> {
    let relative = file.strip_prefix(src).unwrap();
    let first = relative.components().next()?.as_os_str().to_str()?;
    let name = first.strip_suffix(".rs").unwrap_or(first);
    (name != "lib").then(|| name.to_string())
}

/// The top-level modules a source names through `crate::`, comments left out.
fn crate_paths(source: &str) -> Vec<(usize, String)> {
    let mut found = Vec::new();
    for (line_number, line) in source.lines().enumerate() {
        let code = match line.find("//") {
            Some(i) => &line[..i],
            None => line,
        };
        let mut rest = code;
        while let Some(i) = rest.find("crate::") {
            let after = &rest[i + "crate::".len()..];
            let name: String = after
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                .collect();
            // `crate::{a, b}` names each of a and b.
            if name.is_empty() && after.starts_with('{') {
                let list = &after[1..after.find('}').unwrap_or(after.len())];
                for item in list.split(',') {
                    let item: String = item
                        .trim()
                        .chars()
                        .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                        .collect();
                    if !item.is_empty() {
                        found.push((line_number + 1, item));
                    }
                }
            } else if !name.is_empty() {
                found.push((line_number + 1, name));
            }
            rest = after;
        }
    }
    found
}

#[test]
fn every_top_level_module_has_a_stage() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    for file in &files {
        if let Some(module) = module_of(&src, file) {
            assert!(
                stage_of(&module).is_some(),
                "src/{module} is in no stage: add it to STAGES (and to lib.rs's stage list)"
            );
        }
    }
}

#[test]
fn no_module_imports_from_a_later_stage() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    files.sort();
    let mut violations = Vec::new();
    for file in &files {
        let Some(module) = module_of(&src, file) else {
            continue;
        };
        let Some(own) = stage_of(&module) else {
            continue;
        };
        let source = fs::read_to_string(file).unwrap();
        for (line, used) in crate_paths(&source) {
            // Items re-exported at the crate root (`Error`, `Result`) are the
            // foundations'.
            let stage = stage_of(&used).unwrap_or(0);
            let relative = file.strip_prefix(&src).unwrap().display().to_string();
            if stage > own {
                violations.push(format!(
                    "src/{relative}:{line}: {module} (stage {own}) imports {used} (stage {stage})"
                ));
            }
        }
    }
    assert!(
        violations.is_empty(),
        "imports against the data flow:\n{}",
        violations.join("\n")
    );
}

#[test]
fn the_check_sees_paths_in_code_and_not_in_comments() {
    let source = "use crate::render::Image;\n// crate::solve in a comment\nlet x = crate::refine::oracle::Oracle::Kernel; use crate::{scene, solve};";
    let names: Vec<String> = crate_paths(source).into_iter().map(|(_, n)| n).collect();
    assert_eq!(names, ["render", "refine", "scene", "solve"]);
}
