//! How the model is integrated: the Moreau–Jean θ-scheme (velocity level, impulses, Newton
//! impact law), its parameters, and the time loop with per-step diagnostics.

mod activation;
pub mod assembly;
mod elimination;
mod impact;
pub mod iteration_matrix;
pub mod moreau_jean;
mod opposed;
pub mod params;
pub mod projection;
mod rollback;
mod rows;
pub mod schedule;
pub mod simulation;
mod sinking;
mod squeezed;
pub mod step_control;
mod subdivision;
mod tunnelling;
mod workspace;

pub use params::{IntegrationParameters, Preset, Scheme};
pub use schedule::{Refine, Schedule, Settle};
pub use simulation::{RunStats, SimError, Simulation, StepReport};
pub use step_control::StepControl;
