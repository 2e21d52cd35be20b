//! Campaigns: autonomy judged as a success rate over many simulated
//! missions rather than on one run.
//!
//! A matrix (`campaigns/*.toml`) is expanded into numbered cases
//! ([`matrix`]), written to a folder ([`manifest`]), run as separate
//! `speleo sim` processes locally or one case per cluster task
//! ([`runner`], [`outcome`]), and judged ([`success`], [`summary`],
//! [`stats`], [`plot`]).

pub mod chart;
pub mod manifest;
pub mod matrix;
pub mod outcome;
pub mod plot;
pub mod runner;
pub mod stats;
pub mod success;
pub mod summary;
