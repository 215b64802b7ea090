//! `MC_STUDY_SLURM=1` (set by `.ci/run` after starting `../shared/tools/local-slurm`)
//! enables the test that submits job arrays to a real Slurm; without it that test is
//! reported as ignored, never as passed.

fn main() {
    println!("cargo::rustc-check-cfg=cfg(slurm_cluster)");
    println!("cargo::rerun-if-env-changed=MC_STUDY_SLURM");
    println!("cargo::rerun-if-changed=build.rs");
    if std::env::var("MC_STUDY_SLURM").is_ok_and(|v| v == "1") {
        println!("cargo::rustc-cfg=slurm_cluster");
    }
}
