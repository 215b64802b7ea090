//! The Python package (python/): builds it with maturin, installs it into the target
//! directory and runs its pytest suite and examples, which compare it with this crate's
//! `mc-study` binary bit for bit. Needs python3 with maturin, pytest, numpy, pyarrow,
//! openturns and SALib: built with MC_STUDY_PYTHON=1 (`.ci/run` installs them and sets it)
//! the test runs and their absence is a failure; without the variable it is reported as
//! ignored.

use std::path::{Path, PathBuf};
use std::process::Command;

fn run(what: &str, cmd: &mut Command) {
    let out = cmd
        .output()
        .unwrap_or_else(|e| panic!("{what}: cannot start: {e}"));
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.status.success(), "{what} failed:\n{text}");
    println!("{what}:\n{text}");
}

#[test]
#[cfg_attr(
    not(python_package),
    ignore = "needs python3 with maturin, pytest, numpy, pyarrow, openturns and SALib: `pip install maturin pytest numpy pyarrow openturns SALib`, then MC_STUDY_PYTHON=1 cargo test (.ci/run does both)"
)]
fn the_python_package_builds_and_its_tests_and_examples_pass() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    // the test binary lives in <target>/<profile>/deps
    let target: PathBuf = Path::new(env!("CARGO_BIN_EXE_mc-study"))
        .parent()
        .and_then(Path::parent)
        .expect("target directory")
        .to_path_buf();
    let wheels = target.join("wheels");
    let site = target.join("python-site");
    let _ = std::fs::remove_dir_all(&wheels);
    let _ = std::fs::remove_dir_all(&site);
    // the development profile: the artifacts `cargo test` built are reused
    run(
        "maturin build",
        Command::new("python3")
            .args(["-m", "maturin", "build", "--quiet", "-m"])
            .arg(root.join("python/Cargo.toml"))
            .arg("-o")
            .arg(&wheels)
            .args(["--interpreter", "python3"]),
    );
    let wheel = std::fs::read_dir(&wheels)
        .expect("wheels")
        .map(|e| e.expect("entry").path())
        .find(|p| p.extension().is_some_and(|e| e == "whl"))
        .expect("a wheel");
    run(
        "pip install",
        Command::new("python3")
            .args(["-m", "pip", "install", "--quiet", "--no-deps", "--target"])
            .arg(&site)
            .arg(&wheel),
    );
    run(
        "pytest",
        Command::new("python3")
            .args(["-m", "pytest", "-q", "-p", "no:cacheprovider"])
            .arg(root.join("python/tests"))
            .env("PYTHONPATH", &site)
            .env("MC_STUDY_BIN", env!("CARGO_BIN_EXE_mc-study")),
    );
}
