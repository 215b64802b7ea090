//! What the system is: bodies, applied forces, contacts and the assembled model.

pub mod body;
pub mod contact;
pub mod force;
pub mod joint;
pub mod model;

pub use body::{BodyRef, Motion, Planar, Pose, RigidBody, Shape, Twist};
pub use contact::{ContactGeometry, ContactPair, ContactPoint, Primitive};
pub use force::{ExternalLoad, Force, LoadProfile, PointSpring, TorsionalSpring};
pub use model::Model;
