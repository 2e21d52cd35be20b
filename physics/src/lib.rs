//! The rover's physics, shared by the hardware twin (`speleo-twin`) and the
//! internal simulator (`speleo-simulator`): the rapier3d rover
//! ([`rover::PhysicsRover`]), the true state it produces ([`BodyState`]),
//! quaternion helpers, and the terrain it drives on: triangle meshes with a
//! material per triangle ([`Mesh`], [`Material`]), read from PLY, OBJ and STL.
//!
//! rapier is built with `enhanced-determinism` and the trigonometry is
//! `libm`'s pure-Rust code: the same terrain, start and commands give the
//! same motion, bit for bit, on any machine.

pub mod body;
pub mod chassis_contacts;
pub mod quat;
pub mod rover;
pub mod terrain;

pub use body::BodyState;
pub use rover::{PhysicsParams, PhysicsRover};
pub use terrain::{Material, Mesh};
