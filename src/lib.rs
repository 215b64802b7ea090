//! mc-study: Monte-Carlo tolerance studies of mechanisms with clearances, on a nonsmooth
//! multibody integrator of the Moreau–Jean family (Newton–Euler bodies with unit
//! quaternions, unilateral frictional contact with impacts as FC3D).
//!
//! Layout: [`math`] rotation helpers and reusable buffers, [`mechanics`] what the system is,
//! [`integrator`] how it is integrated, [`solver`] pure numerics, [`scene`] the YAML scene
//! format, [`probe`] a run's named outputs, [`probe_run`] a run that produces them (extrapolated over a refinement window), [`trajectory`] recorded outputs, [`drawing`] SVG views of a mechanism, [`expr`]
//! closed-form expressions, [`study`] the Monte-Carlo runner, store, statistics and sensitivity, [`report`] the HTML report.

pub mod commands;
pub mod drawing;
pub mod expr;
pub mod extremes;
pub mod input_file;
pub mod integrator;
pub mod math;
pub mod mechanics;
pub mod probe;
pub mod probe_run;
pub mod reliability;
pub mod report;
pub mod scene;
pub mod simulate;
pub mod solver;
pub mod study;
pub mod tolerancing;
pub mod trajectory;
