//! The motor drive's hardware-independent half: drivers written against embedded-hal 1.0
//! traits, the per-tick glue around model-core's controller, the command link, and the
//! drive assembled from its configuration (a [`model_core::DriveTable`], passed in).
//!
//! Nothing here holds a gain table: the board's firmware compiles its own in and passes it to
//! [`config`]; the host tools (the PIL host, `beam drive --sim`) pass one they loaded at run
//! time. The board names the STM32F405's concrete types in its own crate (`firmware`) and
//! runs [`drive::Drive::tick`] from the 1 kHz timer interrupt. Everything here is generic and
//! `no_std`, and is tested on the host against `embedded-hal-mock` and [`fakes`].
#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]

pub mod ads1220;
pub mod amplifier;
pub mod config;
pub mod drive;
pub mod fakes;
pub mod link;
pub mod operator;
