//! `mc-study paths`: every parameter path of a scene, with its unit and value.

use crate::scene::Scene;
use anyhow::Result;
use std::path::PathBuf;

/// `mc-study paths` arguments.
#[derive(clap::Args, Debug)]
pub struct PathsArgs {
    /// Scene YAML file.
    pub scene: PathBuf,
}

/// `mc-study paths`: one line per parameter.
pub fn paths(args: &PathsArgs) -> Result<()> {
    let scene = Scene::load(&args.scene)?;
    for p in scene.parameters() {
        let value = p.value.map_or("default".into(), |v| format!("{v}"));
        println!("{:<48} {:<8} {value}", p.path, p.dim.si_unit());
    }
    Ok(())
}
