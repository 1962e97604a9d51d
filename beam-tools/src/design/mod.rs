//! Design: gains by optimisation, their robustness, and gain tables read at run time.

pub mod optimize;
pub mod sweep;
