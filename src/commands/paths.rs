//! `mc-study paths`: every parameter path of a scene, with its unit and value.

use crate::scene::parameter_paths::Fallback;
use crate::scene::Scene;
use anyhow::Result;
use std::path::PathBuf;

/// `mc-study paths` arguments.
#[derive(clap::Args, Debug)]
pub struct PathsArgs {
    /// Scene YAML file.
    pub scene: PathBuf,
}

/// `mc-study paths`: one line per parameter; a value the scene leaves out in parentheses.
pub fn paths(args: &PathsArgs) -> Result<()> {
    let scene = Scene::load(&args.scene)?;
    for p in scene.parameters() {
        let value = match (p.value, p.default) {
            (Some(v), _) => number(v),
            (None, Fallback::Value(v)) => format!("({})", number(v)),
            (None, Fallback::Rule(rule)) => format!("({rule})"),
        };
        println!("{:<48} {:<8} {value}", p.path, p.dim.si_unit());
    }
    Ok(())
}

/// A number in its plain form where that is short (0.5, 1000), else in the shorter of its
/// plain and exponent forms (5e-6, 1e-10).
fn number(v: f64) -> String {
    let (plain, exponent) = (format!("{v}"), format!("{v:e}"));
    if plain.len() > 6 && exponent.len() < plain.len() {
        exponent
    } else {
        plain
    }
}
