//! What the docs claim about the repository, checked: every repository path README.md and docs/ name exists,
//! every `DESIGN_SPEC §N` citation in code and docs names a section of docs/DESIGN_SPEC.md, and every key the
//! scene reader accepts is documented in docs/formats/scene.md (dial keyframe keys in dial.md), and the test
//! build resolves every shared crate as the release build does; the core warns on missing docs and has no
//! `#[path]` modules; every `#anchor` a doc links to is made by a heading of the page it names.

use metamer_core::render::Scene;
use std::path::{Path, PathBuf};

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// Markdown files under `dir`, recursively.
fn markdown(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_dir() {
            markdown(&p, out);
        } else if p.extension().is_some_and(|x| x == "md") {
            out.push(p);
        }
    }
}

/// Files of the given extensions under `dir`, recursively.
fn sources(dir: &Path, exts: &[&str], out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_dir() {
            sources(&p, exts, out);
        } else if p.extension().and_then(|x| x.to_str()).is_some_and(|x| exts.contains(&x)) {
            out.push(p);
        }
    }
}

const TOP: [&str; 12] = [
    "crates/",
    "src/",
    "tests/",
    "docs/",
    "volumes/",
    "palettes/",
    "benches/",
    "examples/",
    "fuzz/",
    "data/",
    "snapshots/",
    ".ci/",
];

/// The repository paths a text names: tokens starting with one of [`TOP`] (optionally after `../`).
fn named_paths(text: &str) -> Vec<String> {
    let ok = |c: char| c.is_ascii_alphanumeric() || "_./*-".contains(c);
    let mut out = Vec::new();
    let bytes: Vec<char> = text.chars().collect();
    let mut i = 0;
    while i < bytes.len() {
        let before_ok = i == 0 || !ok(bytes[i - 1]);
        if before_ok && ok(bytes[i]) {
            let mut j = i;
            while j < bytes.len() && ok(bytes[j]) {
                j += 1;
            }
            let tok: String = bytes[i..j].iter().collect();
            let tok = tok.trim_end_matches(['.', ',']);
            let bare = tok.trim_start_matches("../");
            if TOP.iter().any(|t| bare.starts_with(t)) && bare.len() > 4 {
                out.push(tok.to_string());
            }
            i = j;
        } else {
            i += 1;
        }
    }
    out
}

fn exists(doc: &Path, p: &str) -> bool {
    let candidates = [root().join(p.trim_start_matches("../")), doc.parent().unwrap_or(root()).join(p)];
    candidates.iter().any(|c| {
        if let Some((dir, pattern)) = c.to_str().and_then(|s| s.rsplit_once('/')).filter(|(_, f)| f.contains('*')) {
            // `volumes/*.toml`, `tests/it/tui_*.rs`: the folder holds a file of that shape.
            let (pre, post) = pattern.split_once('*').unwrap_or((pattern, ""));
            std::fs::read_dir(dir).into_iter().flatten().flatten().any(|e| {
                let n = e.file_name().to_string_lossy().into_owned();
                n.starts_with(pre) && n.ends_with(post.trim_start_matches('*'))
            })
        } else {
            c.exists()
        }
    })
}

#[test]
fn every_path_the_docs_name_exists() {
    let mut docs = vec![root().join("README.md")];
    markdown(&root().join("docs"), &mut docs);
    assert!(docs.len() >= 8, "README and the docs/ pages are found: {docs:?}");
    let mut missing = Vec::new();
    let mut checked = 0;
    for doc in &docs {
        let text = std::fs::read_to_string(doc).expect("a doc is readable");
        for p in named_paths(&text) {
            checked += 1;
            if !exists(doc, &p) {
                missing.push(format!("{}: {p}", doc.strip_prefix(root()).unwrap_or(doc).display()));
            }
        }
    }
    assert!(checked > 50, "only {checked} paths named: the scan is broken");
    assert!(missing.is_empty(), "paths the docs name that do not exist:\n{}", missing.join("\n"));
}

#[test]
fn every_design_spec_citation_resolves() {
    let spec = std::fs::read_to_string(root().join("docs/DESIGN_SPEC.md")).expect("docs/DESIGN_SPEC.md exists");
    let sections: Vec<String> = spec
        .lines()
        .filter_map(|l| l.strip_prefix("## "))
        .filter_map(|l| l.split_once('.').map(|(n, _)| n.trim().to_string()))
        .collect();
    assert!(sections.len() >= 5, "DESIGN_SPEC's numbered sections: {sections:?}");
    let mut files = vec![root().join("README.md")];
    for d in ["src", "crates", "tests", "benches", "examples", "docs"] {
        sources(&root().join(d), &["rs", "md", "toml", "py", "sh"], &mut files);
    }
    let mut citations = 0;
    let mut bad = Vec::new();
    for f in &files {
        if f.ends_with("tests/it/doc_claims.rs") {
            continue; // this file names the form in its own checks
        }
        let Ok(text) = std::fs::read_to_string(f) else { continue };
        for (at, _) in text.match_indices("DESIGN_SPEC §") {
            let rest = &text[at + "DESIGN_SPEC §".len()..];
            let n: String = rest.chars().take_while(char::is_ascii_digit).collect();
            if n.is_empty() && rest.starts_with('N') {
                continue; // `DESIGN_SPEC §N`: the form of a citation, not one
            }
            citations += 1;
            if !sections.contains(&n) {
                bad.push(format!("{}: §{n}", f.strip_prefix(root()).unwrap_or(f).display()));
            }
        }
    }
    assert!(citations > 20, "only {citations} citations found: the scan is broken");
    assert!(bad.is_empty(), "citations of sections docs/DESIGN_SPEC.md does not have:\n{}", bad.join("\n"));
}

/// The anchors of a markdown page as GitHub makes them from its headings (fenced code skipped): the heading's
/// text lower-cased, inline code and links reduced to their text, every character but letters, digits, `_`,
/// `-` and spaces dropped, spaces turned into `-`; a repeated anchor gets `-1`, `-2`, …
fn anchors(text: &str) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    let mut fenced = false;
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
            continue;
        }
        let Some(heading) = line.strip_prefix('#').map(|l| l.trim_start_matches('#')).filter(|l| l.starts_with(' '))
        else {
            continue;
        };
        if fenced {
            continue;
        }
        // A link's text stands for the link: `[text](target)` → `text`.
        let mut plain = String::new();
        let mut rest = heading.trim();
        while let Some(open) = rest.find("](") {
            plain.push_str(&rest[..open]);
            rest = rest[open + 2..].split_once(')').map_or("", |(_, r)| r);
        }
        plain.push_str(rest);
        let slug: String = plain
            .to_lowercase()
            .chars()
            .filter(|c| c.is_alphanumeric() || matches!(c, '_' | '-' | ' '))
            .map(|c| if c == ' ' { '-' } else { c })
            .collect();
        let repeats = out
            .iter()
            .filter(|a| {
                **a == slug
                    || a.strip_prefix(&slug).is_some_and(|r| r.starts_with('-') && r[1..].parse::<u32>().is_ok())
            })
            .count();
        out.push(if repeats == 0 { slug } else { format!("{slug}-{repeats}") });
    }
    out
}

#[test]
fn every_anchor_the_docs_link_to_exists() {
    let mut docs = vec![root().join("README.md")];
    markdown(&root().join("docs"), &mut docs);
    let mut checked = 0;
    let mut broken = Vec::new();
    for doc in &docs {
        let text = std::fs::read_to_string(doc).expect("a doc is readable");
        for (at, _) in text.match_indices("](") {
            let target = text[at + 2..].split([')', ' ', '\n']).next().unwrap_or_default();
            let Some((file, anchor)) = target.split_once('#') else { continue };
            if file.contains("://") || file.contains('<') {
                continue;
            }
            let page = if file.is_empty() { doc.clone() } else { doc.parent().unwrap_or(root()).join(file) };
            let Ok(page_text) = std::fs::read_to_string(&page) else {
                broken.push(format!("{}: {target} (no such page)", doc.strip_prefix(root()).unwrap_or(doc).display()));
                continue;
            };
            checked += 1;
            if !anchors(&page_text).iter().any(|a| a == anchor) {
                broken.push(format!("{}: {target}", doc.strip_prefix(root()).unwrap_or(doc).display()));
            }
        }
    }
    assert!(checked > 40, "only {checked} anchors linked: the scan is broken");
    assert!(broken.is_empty(), "links to anchors no heading makes:\n{}", broken.join("\n"));
}

#[test]
fn anchors_are_made_as_github_makes_them() {
    let page = "# Where it stands (2026-12-07, session 53)\n```\n# not a heading\n```\n## `Fields::build` and [links](x.md)\n## Twice\n### Twice\n## A–B: ≥ 20×, 384²\n";
    assert_eq!(
        anchors(page),
        ["where-it-stands-2026-12-07-session-53", "fieldsbuild-and-links", "twice", "twice-1", "ab--20-384²"]
    );
}

/// The keys the scene reader accepts in one table: what it names when it refuses an unknown key there.
fn accepted_keys(scene: &str) -> Vec<String> {
    let err = match Scene::parse(scene, Path::new("probe.toml")) {
        Ok(_) => panic!("an unknown key was accepted:\n{scene}"),
        Err(e) => e.to_string(),
    };
    let list = err.split_once("expected one of").map(|(_, l)| l.to_string()).unwrap_or_else(|| {
        panic!("the reader's refusal of an unknown key does not list the known ones: {err}");
    });
    list.split('`').skip(1).step_by(2).map(str::to_string).collect()
}

#[test]
fn every_scene_key_the_reader_accepts_is_documented() {
    let scene_md = std::fs::read_to_string(root().join("docs/formats/scene.md")).expect("scene.md");
    let dial_md = std::fs::read_to_string(root().join("docs/formats/dial.md")).expect("dial.md");
    let head = "palette = \"p.toml\"\nvolume = \"v.nhdr\"\n";
    let probes = [
        ("top level", "zz_unknown = 1\n".to_string(), &scene_md),
        ("[[materials]]", format!("{head}[[materials]]\nzz_unknown = 1\n"), &scene_md),
        ("[camera]", format!("{head}[camera]\nzz_unknown = 1\n"), &scene_md),
        ("[dial]", format!("{head}[dial]\nzz_unknown = 1\n"), &scene_md),
        ("[[dial.keyframes]]", format!("{head}[[dial.keyframes]]\nzz_unknown = 1\n"), &dial_md),
        ("[render]", format!("{head}[render]\nzz_unknown = 1\n"), &scene_md),
        ("[raw]", format!("{head}[raw]\nzz_unknown = 1\n"), &scene_md),
    ];
    let mut undocumented = Vec::new();
    for (table, text, doc) in probes {
        let keys = accepted_keys(&text);
        assert!(!keys.is_empty(), "{table}: no keys listed");
        for k in keys {
            // A row of a key table (`| `k` |`, tables as `| `[k]` |` or `| `[[k]]` |`), or a key of a
            // commented TOML example at the start of a line (dial.md's keyframe block).
            let documented =
                [format!("| `{k}` |"), format!("| `[{k}]` |"), format!("| `[[{k}]]` |"), format!("\n{k} = ")]
                    .iter()
                    .any(|form| doc.contains(form.as_str()));
            if !documented {
                undocumented.push(format!("{table}: `{k}`"));
            }
        }
    }
    assert!(
        undocumented.is_empty(),
        "scene keys the reader accepts but the format pages do not list:\n{}",
        undocumented.join("\n")
    );
}

/// Every package `cargo tree` resolves for the workspace along `edges`, with its features:
/// `name vX.Y.Z` → `a,b,c`.
fn resolved_features(edges: &str) -> std::collections::BTreeMap<String, String> {
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let out = std::process::Command::new(cargo)
        .args(["tree", "--offline", "--workspace", "--prefix", "none", "--format", "{p}|{f}", "--edges", edges])
        .current_dir(root())
        .output()
        .expect("run cargo tree");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "cargo tree --edges {edges} failed:\n{}", String::from_utf8_lossy(&out.stderr));
    let mut map = std::collections::BTreeMap::new();
    for line in text.lines() {
        // Package lines only (feature nodes read `name feature "f"`); a path package's line ends with its folder.
        let Some((package, features)) = line.split_once('|') else { continue };
        let package = package.split(" (").next().unwrap_or(package).trim().to_string();
        let features = features.trim_end_matches(" (*)").trim().to_string();
        if let Some(old) = map.insert(package.clone(), features.clone()) {
            assert_eq!(old, features, "{package} is resolved twice with different features along {edges}");
        }
    }
    assert!(map.len() > 50, "cargo tree --edges {edges} listed only {} packages:\n{text}", map.len());
    map
}

/// The README's and Cargo.toml's claim: `cargo test --release` after `cargo build --release` compiles no
/// shared crate again, because every shared dependency is resolved with the same features in both builds
/// (Cargo.toml's [dependencies] name the features the dev-dependencies switch on).
#[test]
fn the_test_build_reuses_the_release_build() {
    let release = resolved_features("normal,build,features");
    let test = resolved_features("normal,build,dev,features");
    let differ: Vec<String> = release
        .iter()
        .filter_map(|(package, features)| {
            let with_dev = test.get(package)?;
            (with_dev != features).then(|| format!("{package}: release [{features}], test [{with_dev}]"))
        })
        .collect();
    assert!(
        differ.is_empty(),
        "shared crates the test build resolves with other features than `cargo build --release` (so compiles \
         again); name the missing features in Cargo.toml's [dependencies]:\n{}",
        differ.join("\n")
    );
}

/// ARCHITECTURE.md's rules for the core's face: missing docs warn (CI's `clippy -D warnings` makes them errors),
/// and the module tree is the folder tree (no `#[path]` in the core).
#[test]
fn the_core_warns_on_missing_docs_and_its_module_tree_is_its_folder_tree() {
    let src = root().join("crates/metamer-core/src");
    let lib = std::fs::read_to_string(src.join("lib.rs")).expect("lib.rs");
    assert!(lib.contains("#![warn(missing_docs)]"), "metamer-core's lib.rs must warn on missing docs");
    let mut files = Vec::new();
    sources(&src, &["rs"], &mut files);
    assert!(files.len() > 50, "expected the core's sources, found {}", files.len());
    let with_path: Vec<String> = files
        .iter()
        .filter(|f| std::fs::read_to_string(f).is_ok_and(|t| t.lines().any(|l| l.trim_start().starts_with("#[path"))))
        .map(|f| f.display().to_string())
        .collect();
    assert!(with_path.is_empty(), "#[path] makes the module tree differ from the folder tree: {with_path:?}");
}
