//! The repository stands on its own: no file names the sibling directory the project was
//! developed beside (a clone has nothing next to it), and every relative link in the
//! Markdown documentation leads to a file or directory of the repository.

use std::path::{Path, PathBuf};

/// Every file of the source tree, without build output, results or version control.
fn files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        let name = p.file_name().unwrap().to_string_lossy().to_string();
        if p.is_dir() {
            if !matches!(name.as_str(), "target" | ".git" | "results") {
                files(&p, out);
            }
        } else {
            out.push(p);
        }
    }
}

fn repository() -> Vec<PathBuf> {
    let mut v = Vec::new();
    files(Path::new(env!("CARGO_MANIFEST_DIR")), &mut v);
    v
}

#[test]
fn no_file_points_outside_the_repository() {
    // spelt in two pieces so that this file does not name it
    let outside = ["..", "/shared"].concat();
    let offenders: Vec<String> = repository()
        .iter()
        .filter(|p| {
            std::fs::read(p)
                .map(|b| String::from_utf8_lossy(&b).contains(&outside))
                .unwrap_or(false)
        })
        .map(|p| p.display().to_string())
        .collect();
    assert!(
        offenders.is_empty(),
        "these files name {outside}, which a clone does not have: {offenders:#?}"
    );
}

/// The targets of the Markdown links `[text](target)` in `text`.
fn link_targets(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut rest = text;
    while let Some(i) = rest.find("](") {
        rest = &rest[i + 2..];
        if let Some(j) = rest.find(')') {
            out.push(rest[..j].to_string());
            rest = &rest[j..];
        }
    }
    out
}

#[test]
fn documentation_links_lead_somewhere() {
    let mut dead = Vec::new();
    let mut checked = 0;
    for md in repository()
        .iter()
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
    {
        let text = std::fs::read_to_string(md).unwrap();
        for target in link_targets(&text) {
            if target.contains("://") || target.starts_with("mailto:") || target.starts_with('#') {
                continue;
            }
            let file = target.split('#').next().unwrap();
            checked += 1;
            if !md.parent().unwrap().join(file).exists() {
                dead.push(format!("{}: {target}", md.display()));
            }
        }
    }
    assert!(
        checked > 40,
        "only {checked} links found: is the parser broken?"
    );
    assert!(dead.is_empty(), "dead links: {dead:#?}");
}

#[test]
fn the_link_parser_finds_targets() {
    assert_eq!(
        link_targets("see [a](docs/a.md) and [b](b.md#x), not (c)"),
        ["docs/a.md", "b.md#x"]
    );
}
