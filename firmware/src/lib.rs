//! The drive's hardware-independent half: drivers written against embedded-hal 1.0 traits and
//! the per-tick glue around model-core's controller.
//!
//! The binary (`src/main.rs`) names the STM32F405's concrete types in its board module and
//! runs [`drive::Drive::tick`] from the 1 kHz timer interrupt. Everything here is generic and
//! `no_std`, and is tested on the host against `embedded-hal-mock`.
#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]

pub mod ads1220;
pub mod amplifier;
pub mod config;
pub mod drive;
pub mod fakes;
pub mod link;
pub mod operator;
