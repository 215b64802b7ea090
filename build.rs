//! Three integration tests need things outside the project: `tests/slurm.rs` a Slurm
//! cluster, `tests/interop.rs` python3 with pyarrow and DuckDB, `tests/python.rs` python3
//! with maturin, pytest, OpenTURNS and SALib. `.ci/run` provides them (`ci/local-slurm
//! start`, `pip install -r python/requirements-ci.txt`) and sets `MC_STUDY_SLURM=1`,
//! `MC_STUDY_INTEROP=1` and `MC_STUDY_PYTHON=1`, which compile those tests in as required;
//! without the variables they are reported as ignored, with their reason, never as passed.

fn main() {
    println!("cargo::rustc-check-cfg=cfg(slurm_cluster)");
    println!("cargo::rustc-check-cfg=cfg(interop)");
    println!("cargo::rustc-check-cfg=cfg(python_package)");
    println!("cargo::rerun-if-env-changed=MC_STUDY_SLURM");
    println!("cargo::rerun-if-env-changed=MC_STUDY_INTEROP");
    println!("cargo::rerun-if-env-changed=MC_STUDY_PYTHON");
    println!("cargo::rerun-if-changed=build.rs");
    if std::env::var("MC_STUDY_SLURM").is_ok_and(|v| v == "1") {
        println!("cargo::rustc-cfg=slurm_cluster");
    }
    if std::env::var("MC_STUDY_INTEROP").is_ok_and(|v| v == "1") {
        println!("cargo::rustc-cfg=interop");
    }
    if std::env::var("MC_STUDY_PYTHON").is_ok_and(|v| v == "1") {
        println!("cargo::rustc-cfg=python_package");
    }
}
