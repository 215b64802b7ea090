//! mc-study: Monte-Carlo tolerance studies of mechanisms with clearances, on a nonsmooth
//! multibody integrator of the Moreau–Jean family (Newton–Euler bodies with unit
//! quaternions, unilateral frictional contact with impacts as FC3D).
//!
//! Layout: [`math`] rotation helpers and reusable buffers, [`mechanics`] what the system is,
//! [`integrator`] how it is integrated, [`solver`] pure numerics, [`input`] what users
//! write (files, quantities with units, expressions, column names), [`scene`] the YAML
//! scene format, [`probe`] a run's named outputs and the run that produces them,
//! [`single_run`] one simulation with its report, trajectory and drawing, [`study`] the
//! Monte-Carlo runner, store, statistics and sensitivity, [`reliability`] rare-event
//! estimation, [`tolerancing`] worst case, stack-up and allocation, [`report`] the HTML
//! report, [`commands`] the command line's commands.

pub mod commands;
pub mod input;
pub mod integrator;
pub mod math;
pub mod mechanics;
pub mod probe;
pub mod reliability;
pub mod report;
pub mod scene;
pub mod single_run;
pub mod solver;
pub mod study;
pub mod tolerancing;
