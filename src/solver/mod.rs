//! Pure numerics: sees matrices and vectors only, never the model.
//!
//! `fc3d` states the 3D frictional contact problem FC3D(W, q, μ) and its natural-map
//! error; `nsgs` solves it by nonsmooth Gauss–Seidel with a one-contact Alart–Curnier
//! Newton method; `block_lu` factorises the Jacobian of its global Newton method in the
//! blocks of its pattern, `ordering` orders the contacts so that the factors stay sparse,
//! and `lu` factorises `mlcp`'s equality systems.

pub mod block_lu;
pub mod fc3d;
pub mod lu;
pub mod mlcp;
pub mod newton;
pub mod nsgs;
pub mod ordering;

pub use fc3d::{natural_map_error, project_on_cone, Fc3d, SolverStatus};
pub use lu::Lu;
pub use mlcp::{solve_mixed_pgs, EqualitySolver};
pub use nsgs::{solve_fc3d, NsgsOptions, SolverStorage};
