//! The ground tools as commands of the `speleo` binary: each reads its
//! arguments, runs the tool, prints its figures and writes its report.

pub mod decode;
pub mod info;
pub mod mesh;
pub mod solvers;
pub mod validate;
pub mod world;
